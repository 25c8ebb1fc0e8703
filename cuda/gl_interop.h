// CUDA-GL interop for the map and fragment buffers (DESIGN.md §5, §8): a GL
// buffer object is registered with CUDA once (cudaGraphicsGLRegisterBuffer)
// and again only when it changed — a pool that grew is a new buffer or a new
// size — then mapped per frame on the backend's stream, so kernels read the
// rasterizer's fragment SSBOs and write the map SSBOs in place, with no copy
// through the host. Plain C++ (GL names are unsigned ints; the CUDA types
// stay in gl_interop.cu).
//
// Status: built and linked in every CUDA build (with GL headers); exercised
// only where a GPU and a GL context on it exist (tests/gpu/
// test_gl_interop.cpp). Used by the cuda backend to write the engine's GL map
// buffers (engine/gl/map_buffers.h, ShadowBackend::write_gl_maps) and a
// camera image into a pixel buffer (camera_pass_to_gl), through CudaExec in
// cuda/launch.cuh. The rasterizer's fragment buffers are not mapped yet.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace cdsm::cuda {

enum class GlAccess { ReadWrite, ReadOnly, WriteDiscard };

// One GL buffer object registered with CUDA. Cannot be copied; moving
// hands the registration over. A GL context must be current (and on the
// CUDA device) for bind() and the destructor. Whoever deletes or replaces
// the GL buffer resets the link first (CudaExec::gl_buffer_released, called
// through ShadowBackend::gl_buffer_released by engine/gl/map_buffers.cpp):
// a registration must not outlive its buffer object.
class GlBufferLink {
 public:
  GlBufferLink() = default;
  ~GlBufferLink();
  GlBufferLink(const GlBufferLink&) = delete;
  GlBufferLink& operator=(const GlBufferLink&) = delete;
  GlBufferLink(GlBufferLink&& o) noexcept;
  GlBufferLink& operator=(GlBufferLink&& o) noexcept;

  // Registers GL buffer `name` holding `bytes`; does nothing when that buffer
  // with that size is registered already. Returns true when it (re)registered.
  bool bind(unsigned name, size_t bytes, GlAccess access = GlAccess::ReadWrite);
  void reset() noexcept;  // unregisters
  bool registered() const { return resource_ != nullptr; }
  unsigned name() const { return name_; }
  size_t bytes() const { return bytes_; }
  uint64_t registrations() const { return registrations_; }  // how many times bind() registered
  void* resource() const { return resource_; }               // cudaGraphicsResource_t

 private:
  void* resource_ = nullptr;
  unsigned name_ = 0;
  size_t bytes_ = 0;
  GlAccess access_ = GlAccess::ReadWrite;
  uint64_t registrations_ = 0;
};

// The links mapped for one frame on `stream` (a cudaStream_t); unmapped,
// in stream order, when the scope ends. Kernels launched on that stream in
// between may use pointer(i).
class GlMapScope {
 public:
  GlMapScope(GlBufferLink* const* links, int count, void* stream);
  ~GlMapScope();
  GlMapScope(const GlMapScope&) = delete;
  GlMapScope& operator=(const GlMapScope&) = delete;
  void* pointer(int i, size_t* bytes = nullptr) const;

 private:
  static constexpr int kMax = 16;
  void* resources_[kMax] = {};
  int count_ = 0;
  void* stream_ = nullptr;
};

// Whether the current GL context runs on CUDA device `device` (cudaGLGetDevices);
// `why` says what it runs on otherwise. False without a current context.
bool gl_context_on_device(int device, std::string* why);
// The same answer, asked of the driver once per current GL context (EGL's or
// GLX's, whichever is current on this thread; every call when neither can
// be asked): what ShadowBackend::can_write_gl_maps() costs each frame.
bool gl_context_on_device_cached(int device);

}  // namespace cdsm::cuda
