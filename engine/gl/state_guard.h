// Saves the GL state cdsm's own GL work changes on a context it shares with
// the application, and restores it on destruction (also when that work
// throws). The list is exactly what the fragment rasterizer, the prefix sum
// and the map buffers touch (engine/gl/fragment_raster.cpp, prefix_sum.cpp,
// map_buffers.cpp); everything else they do goes through direct state
// access (glNamedBuffer*, glCreate*), which binds nothing:
//
//   program (GL_CURRENT_PROGRAM), vertex array, draw and read framebuffers,
//   viewport, scissor box, polygon mode, colour mask (draw buffer 0),
//   GL_SCISSOR_TEST, GL_DEPTH_CLAMP, GL_CLIP_DISTANCE0, GL_DEPTH_TEST,
//   GL_CULL_FACE, GL_BLEND, GL_RASTERIZER_DISCARD, GL_MULTISAMPLE,
//   the generic GL_SHADER_STORAGE_BUFFER binding and the indexed shader
//   storage bindings 0 .. kSavedStorageBindings-1 (buffer, offset, size).
//
// GL errors the application left pending are drained on entry (cdsm checks
// every call with glGetError) and counted in pending_errors().
#pragma once

#include <cstdint>

#include "gl/gl_api.h"

namespace cdsm::gl {

inline constexpr int kSavedStorageBindings = 8;

// The first GL error pending on the current context (GL_NO_ERROR: none),
// the others drained with it.
GLenum drain_gl_errors();

class StateGuard {
 public:
  StateGuard();
  ~StateGuard();
  StateGuard(const StateGuard&) = delete;
  StateGuard& operator=(const StateGuard&) = delete;
  // The first GL error that was pending on entry (GL_NO_ERROR: none).
  GLenum pending_error() const { return pending_; }

 private:
  GLenum pending_ = GL_NO_ERROR;
  GLint program_ = 0, vao_ = 0, draw_fbo_ = 0, read_fbo_ = 0;
  GLint viewport_[4] = {0, 0, 0, 0}, scissor_[4] = {0, 0, 0, 0};
  GLint polygon_mode_[2] = {GL_FILL, GL_FILL};
  GLboolean color_mask_[4] = {GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE};
  static constexpr int kCaps = 8;
  GLboolean enabled_[kCaps] = {};
  GLint ssbo_generic_ = 0;
  GLint ssbo_[kSavedStorageBindings] = {};
  GLint64 ssbo_offset_[kSavedStorageBindings] = {}, ssbo_size_[kSavedStorageBindings] = {};
};

}  // namespace cdsm::gl
