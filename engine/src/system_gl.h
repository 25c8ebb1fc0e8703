// The GL side of a shadow system created on the application's context
// (cdsm/shadow_system.h, GlContextUse::Application): the adopted context,
// the map buffers, mesh read-back and the state guard around every GL use.
// Built without OpenGL, make_system_gl() throws and nothing else is called.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "cdsm/gl.h"
#include "cdsm/renderer.h"
#include "cdsm/scene.h"
#include "backend/backend.h"
#include "hd/lights.h"

namespace cdsm {

namespace gl {
class Context;
}

struct SystemGl;
struct SystemGlDeleter {
  void operator()(SystemGl* p) const;
};
using SystemGlPtr = std::unique_ptr<SystemGl, SystemGlDeleter>;

// Makes the system's context current; throws cdsm::Error naming the context
// that is current instead (the check of every call on the application's
// context, also those with nothing to do). A GL error the application left
// pending is cleared and reported in `warnings`, as SystemGlScope does.
void require_gl_current(SystemGl& g, std::vector<std::string>* warnings);

// Adopts the context current on this thread. Throws cdsm::Error (`where`
// names the system) when there is none, or it is not GL 4.5 core.
SystemGlPtr make_system_gl(const std::string& where);
gl::Context* system_context(SystemGl& g);
// Makes the adopted context current if it can be (no-op otherwise).
void try_make_current(SystemGl& g) noexcept;

// While alive: the adopted context is checked to be current (throws
// otherwise) and the GL state cdsm changes is saved, restored at the end.
class SystemGlScope {
 public:
  SystemGlScope(SystemGl* g, std::vector<std::string>* warnings);
  ~SystemGlScope();
  SystemGlScope(const SystemGlScope&) = delete;
  SystemGlScope& operator=(const SystemGlScope&) = delete;

 private:
  struct Guard;
  std::unique_ptr<Guard> guard_;
};

// Brings the GL map buffers to the frame's maps (engine/gl/map_buffers.h):
// what changed since the last call. `view` is the frame's view without its
// storage; the backend's arrays reach GL through the backend itself when it
// can write them in place (ShadowBackend::can_write_gl_maps: the cuda
// backend with this context on its device; counted in gl_map_device_bytes),
// else as uploads from its storage() (gl_map_upload_bytes). The figures go
// to `st`. Every map buffer is passed to backend.gl_buffer_released() before
// GL deletes or replaces it: in this sync, in later ones, and when
// set_gl_map_block_limit drops the buffers (not when the SystemGl is
// deleted: the system's backend dies first and unregisters everything).
void sync_gl_maps(SystemGl& g, ShadowView view, ShadowBackend& backend, UpdateStats& st);
GlMapBuffers gl_map_buffers(const SystemGl& g);
void bind_gl_maps(SystemGl& g, uint32_t program);
// Where a mesh lies in application buffers, checked against their sizes
// without reading them (the buffers are GL buffers of the current context,
// the counts, offsets, strides and index type fit them). Throws cdsm::Error
// naming the field. The mesh's index size and triangle count.
struct GlMeshExtent {
  uint32_t index_size = 0;  // 0: not indexed
  uint32_t triangles = 0;
};
GlMeshExtent check_gl_mesh(const GlMeshSource& src, const std::string& where);
// Reads a mesh from application buffers; adds the bytes read to `bytes`.
std::shared_ptr<TriangleMesh> read_gl_mesh(SystemGl& g, const GlMeshSource& src, const std::string& where,
                                           uint64_t& bytes);
// This thread's GL buffer allocations and blocking read-backs so far (a GL
// context's work runs on the thread where it is current; zeros without
// OpenGL): FrameStats::counters takes their difference over a frame.
struct GlWork {
  uint64_t allocations = 0;
  uint64_t readbacks = 0;
};
GlWork thread_gl_work();
// Test hook: the largest block the map buffers may use (0: the driver's).
void set_gl_map_block_limit(SystemGl& g, uint64_t bytes);

}  // namespace cdsm
