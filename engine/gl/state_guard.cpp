#include "gl/state_guard.h"

namespace cdsm::gl {

namespace {
constexpr GLenum kCapList[] = {GL_SCISSOR_TEST, GL_DEPTH_CLAMP, GL_CLIP_DISTANCE0,     GL_DEPTH_TEST,
                               GL_CULL_FACE,    GL_BLEND,       GL_RASTERIZER_DISCARD, GL_MULTISAMPLE};
}  // namespace

GLenum drain_gl_errors() {
  const GLenum first = glGetError();
  for (int i = 0; i < 16 && glGetError() != GL_NO_ERROR; ++i) {
  }
  return first;
}

StateGuard::StateGuard() {
  static_assert(sizeof(kCapList) / sizeof(kCapList[0]) == kCaps, "one slot per capability");
  pending_ = drain_gl_errors();
  glGetIntegerv(GL_CURRENT_PROGRAM, &program_);
  glGetIntegerv(GL_VERTEX_ARRAY_BINDING, &vao_);
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &draw_fbo_);
  glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &read_fbo_);
  glGetIntegerv(GL_VIEWPORT, viewport_);
  glGetIntegerv(GL_SCISSOR_BOX, scissor_);
  glGetIntegerv(GL_POLYGON_MODE, polygon_mode_);
  glGetBooleani_v(GL_COLOR_WRITEMASK, 0, color_mask_);
  for (int i = 0; i < kCaps; ++i) enabled_[i] = glIsEnabled(kCapList[i]);
  glGetIntegerv(GL_SHADER_STORAGE_BUFFER_BINDING, &ssbo_generic_);
  for (int i = 0; i < kSavedStorageBindings; ++i) {
    glGetIntegeri_v(GL_SHADER_STORAGE_BUFFER_BINDING, GLuint(i), &ssbo_[i]);
    glGetInteger64i_v(GL_SHADER_STORAGE_BUFFER_START, GLuint(i), &ssbo_offset_[i]);
    glGetInteger64i_v(GL_SHADER_STORAGE_BUFFER_SIZE, GLuint(i), &ssbo_size_[i]);
  }
  glGetError();  // a query the context does not know is not the caller's failure
}

StateGuard::~StateGuard() {
  glUseProgram(GLuint(program_));
  glBindVertexArray(GLuint(vao_));
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, GLuint(draw_fbo_));
  glBindFramebuffer(GL_READ_FRAMEBUFFER, GLuint(read_fbo_));
  glViewport(viewport_[0], viewport_[1], viewport_[2], viewport_[3]);
  glScissor(scissor_[0], scissor_[1], scissor_[2], scissor_[3]);
  glPolygonMode(GL_FRONT_AND_BACK, GLenum(polygon_mode_[0]));
  glColorMaski(0, color_mask_[0], color_mask_[1], color_mask_[2], color_mask_[3]);
  for (int i = 0; i < kCaps; ++i) {
    if (enabled_[i])
      glEnable(kCapList[i]);
    else
      glDisable(kCapList[i]);
  }
  for (int i = 0; i < kSavedStorageBindings; ++i) {
    if (ssbo_[i] != 0 && ssbo_size_[i] > 0)
      glBindBufferRange(GL_SHADER_STORAGE_BUFFER, GLuint(i), GLuint(ssbo_[i]), GLintptr(ssbo_offset_[i]),
                        GLsizeiptr(ssbo_size_[i]));
    else
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, GLuint(i), GLuint(ssbo_[i]));
  }
  // Indexed binds set the generic binding too: restore it last.
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, GLuint(ssbo_generic_));
  glGetError();  // restoring must not throw (destructor); a bad restore is the caller's old state
}

}  // namespace cdsm::gl
