#include "gl_interop.h"

#include <cuda_gl_interop.h>
#include <dlfcn.h>

#include <stdexcept>
#include <utility>

#include "check.cuh"

namespace cdsm::cuda {
namespace {

unsigned flags_of(GlAccess a) {
  switch (a) {
    case GlAccess::ReadOnly: return cudaGraphicsRegisterFlagsReadOnly;
    case GlAccess::WriteDiscard: return cudaGraphicsRegisterFlagsWriteDiscard;
    default: return cudaGraphicsRegisterFlagsNone;
  }
}

}  // namespace

GlBufferLink::~GlBufferLink() { reset(); }

GlBufferLink::GlBufferLink(GlBufferLink&& o) noexcept
    : resource_(std::exchange(o.resource_, nullptr)),
      name_(o.name_),
      bytes_(o.bytes_),
      access_(o.access_),
      registrations_(o.registrations_) {}

GlBufferLink& GlBufferLink::operator=(GlBufferLink&& o) noexcept {
  if (this != &o) {
    reset();
    resource_ = std::exchange(o.resource_, nullptr);
    name_ = o.name_;
    bytes_ = o.bytes_;
    access_ = o.access_;
    registrations_ = o.registrations_;
  }
  return *this;
}

bool GlBufferLink::bind(unsigned name, size_t bytes, GlAccess access) {
  if (name == 0) throw std::invalid_argument("GlBufferLink::bind: GL buffer name 0");
  check_usable("GlBufferLink::bind");
  if (resource_ && name == name_ && bytes == bytes_ && access == access_) return false;
  reset();
  cudaGraphicsResource_t r = nullptr;
  CDSM_CUDA_CHECK(cudaGraphicsGLRegisterBuffer(&r, GLuint(name), flags_of(access)));
  resource_ = r;
  name_ = name;
  bytes_ = bytes;
  access_ = access;
  ++registrations_;
  return true;
}

void GlBufferLink::reset() noexcept {
  if (!resource_) return;
  CDSM_CUDA_CHECK_NOTHROW(cudaGraphicsUnregisterResource(static_cast<cudaGraphicsResource_t>(resource_)));
  resource_ = nullptr;
}

GlMapScope::GlMapScope(GlBufferLink* const* links, int count, void* stream) : stream_(stream) {
  if (count < 0 || count > kMax) throw std::invalid_argument("GlMapScope: at most 16 buffers");
  check_usable("GlMapScope");
  for (int i = 0; i < count; ++i) {
    if (!links[i] || !links[i]->registered()) throw std::invalid_argument("GlMapScope: buffer not registered");
    resources_[i] = links[i]->resource();
  }
  CDSM_CUDA_CHECK(cudaGraphicsMapResources(count, reinterpret_cast<cudaGraphicsResource_t*>(resources_),
                                           static_cast<cudaStream_t>(stream)));
  count_ = count;
}

GlMapScope::~GlMapScope() {
  if (count_ > 0)
    CDSM_CUDA_CHECK_NOTHROW(cudaGraphicsUnmapResources(count_, reinterpret_cast<cudaGraphicsResource_t*>(resources_),
                                                       static_cast<cudaStream_t>(stream_)));
}

void* GlMapScope::pointer(int i, size_t* bytes) const {
  if (i < 0 || i >= count_) throw std::out_of_range("GlMapScope::pointer");
  void* p = nullptr;
  size_t n = 0;
  CDSM_CUDA_CHECK(cudaGraphicsResourceGetMappedPointer(&p, &n, static_cast<cudaGraphicsResource_t>(resources_[i])));
  if (bytes) *bytes = n;
  return p;
}

bool gl_context_on_device(int device, std::string* why) {
  unsigned count = 0;
  int devices[8] = {};
  const cudaError_t e = cudaGLGetDevices(&count, devices, 8, cudaGLDeviceListAll);
  if (e != cudaSuccess) {
    cudaGetLastError();
    if (why) *why = std::string("the GL context is not on a CUDA device (") + cudaGetErrorName(e) + ")";
    return false;
  }
  for (unsigned i = 0; i < count && i < 8; ++i)
    if (devices[i] == device) return true;
  if (why) *why = "the GL context runs on another GPU than CUDA device " + std::to_string(device);
  return false;
}

namespace {

// The current GL context of this thread as EGL or GLX names it (looked up
// in the process, so neither library is linked here); null when neither is
// loaded or none is current.
const void* current_gl_context() {
  using Get = void* (*)();
  static const Get egl = reinterpret_cast<Get>(dlsym(RTLD_DEFAULT, "eglGetCurrentContext"));
  static const Get glx = reinterpret_cast<Get>(dlsym(RTLD_DEFAULT, "glXGetCurrentContext"));
  const void* c = egl ? egl() : nullptr;
  if (!c && glx) c = glx();
  return c;
}

}  // namespace

bool gl_context_on_device_cached(int device) {
  struct Seen {
    const void* context = nullptr;
    int device = -1;
    bool on = false;
  };
  thread_local Seen seen;
  const void* c = current_gl_context();
  if (c == nullptr) return gl_context_on_device(device, nullptr);
  if (c != seen.context || device != seen.device) seen = {c, device, gl_context_on_device(device, nullptr)};
  return seen.on;
}

}  // namespace cdsm::cuda
