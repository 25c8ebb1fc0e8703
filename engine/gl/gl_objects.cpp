#include "gl/gl_objects.h"

namespace cdsm::gl {

GlCounters& thread_gl_counters() {
  thread_local GlCounters c;
  return c;
}

bool Buffer::reserve(uint64_t bytes) {
  if (id_ != 0 && bytes <= capacity_) return false;
  destroy();
  uint64_t size = bytes == 0 ? 4 : bytes;
  CDSM_GL(glCreateBuffers(1, &id_));
  // Immutable storage: the driver may keep it in GPU memory; DYNAMIC_STORAGE
  // allows glBufferSubData uploads. Read-back uses glGetBufferSubData.
  CDSM_GL(glNamedBufferStorage(id_, GLsizeiptr(size), nullptr, GL_DYNAMIC_STORAGE_BIT));
  ++thread_gl_counters().allocations;
  capacity_ = size;
  label_object(GL_BUFFER, id_, label_);
  return true;
}

void Buffer::upload(const void* data, uint64_t bytes, uint64_t offset) {
  if (bytes == 0) return;
  CDSM_GL(glNamedBufferSubData(id_, GLintptr(offset), GLsizeiptr(bytes), data));
}

void Buffer::download(void* dst, uint64_t bytes, uint64_t offset) const {
  if (bytes == 0) return;
  CDSM_GL(glGetNamedBufferSubData(id_, GLintptr(offset), GLsizeiptr(bytes), dst));
  ++thread_gl_counters().readbacks;
}

void Buffer::clear(uint64_t bytes, uint64_t offset) {
  if (bytes == 0) return;
  CDSM_GL(glClearNamedBufferSubData(id_, GL_R32UI, GLintptr(offset), GLsizeiptr(bytes), GL_RED_INTEGER, GL_UNSIGNED_INT,
                                    nullptr));
}

void Buffer::destroy() noexcept {
  if (id_ != 0) glDeleteBuffers(1, &id_);
  id_ = 0;
  capacity_ = 0;
}

Shader::Shader(GLenum stage, std::string label) {
  label_ = std::move(label);
  id_ = CDSM_GLV(glCreateShader(stage));
  label_object(GL_SHADER, id_, label_);
}
void Shader::destroy() noexcept {
  if (id_ != 0) glDeleteShader(id_);
  id_ = 0;
}

Program::Program(std::string label) {
  label_ = std::move(label);
  id_ = CDSM_GLV(glCreateProgram());
  label_object(GL_PROGRAM, id_, label_);
}
void Program::destroy() noexcept {
  if (id_ != 0) glDeleteProgram(id_);
  id_ = 0;
}

VertexArray::VertexArray(std::string label) {
  label_ = std::move(label);
  CDSM_GL(glCreateVertexArrays(1, &id_));
  label_object(GL_VERTEX_ARRAY, id_, label_);
}
void VertexArray::destroy() noexcept {
  if (id_ != 0) glDeleteVertexArrays(1, &id_);
  id_ = 0;
}

Framebuffer::Framebuffer(std::string label) {
  label_ = std::move(label);
  CDSM_GL(glCreateFramebuffers(1, &id_));
  label_object(GL_FRAMEBUFFER, id_, label_);
}
void Framebuffer::destroy() noexcept {
  if (id_ != 0) glDeleteFramebuffers(1, &id_);
  id_ = 0;
}

}  // namespace cdsm::gl
