// Platform-independent half of the GL context: limits, description, debug
// output, object labels and the checked-call machinery.
#include "gl/context.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "cdsm/error.h"
#include "gl/gl_api.h"

namespace cdsm::gl {

namespace {

thread_local Context* t_current = nullptr;

const char* debug_source_name(GLenum s) {
  switch (s) {
    case GL_DEBUG_SOURCE_API: return "api";
    case GL_DEBUG_SOURCE_WINDOW_SYSTEM: return "window";
    case GL_DEBUG_SOURCE_SHADER_COMPILER: return "compiler";
    case GL_DEBUG_SOURCE_THIRD_PARTY: return "third-party";
    case GL_DEBUG_SOURCE_APPLICATION: return "app";
    default: return "other";
  }
}

const char* debug_type_name(GLenum t) {
  switch (t) {
    case GL_DEBUG_TYPE_ERROR: return "error";
    case GL_DEBUG_TYPE_DEPRECATED_BEHAVIOR: return "deprecated";
    case GL_DEBUG_TYPE_UNDEFINED_BEHAVIOR: return "undefined";
    case GL_DEBUG_TYPE_PORTABILITY: return "portability";
    case GL_DEBUG_TYPE_PERFORMANCE: return "performance";
    case GL_DEBUG_TYPE_MARKER: return "marker";
    default: return "other";
  }
}

const char* debug_severity_name(GLenum s) {
  switch (s) {
    case GL_DEBUG_SEVERITY_HIGH: return "high";
    case GL_DEBUG_SEVERITY_MEDIUM: return "medium";
    case GL_DEBUG_SEVERITY_LOW: return "low";
    default: return "note";
  }
}

void APIENTRY debug_message(GLenum source, GLenum type, GLuint id, GLenum severity, GLsizei length,
                            const GLchar* message, const void* /*user*/) {
  std::fprintf(stderr, "[gl %s/%s/%s %u] %.*s\n", debug_source_name(source), debug_type_name(type),
               debug_severity_name(severity), id, length < 0 ? int(std::strlen(message)) : int(length), message);
}

std::string gl_string(GLenum name) {
  const GLubyte* s = glGetString(name);
  return s ? reinterpret_cast<const char*>(s) : "?";
}

}  // namespace

const char* platform_name(Platform p) {
  switch (p) {
    case Platform::EglDevice: return "EGL device";
    case Platform::EglSurfaceless: return "EGL surfaceless";
    case Platform::GlfwWindow: return "GLFW window";
    case Platform::External: return "application context";
  }
  return "?";
}

bool debug_default() {
  if (const char* e = std::getenv("CDSM_GL_DEBUG"); e && *e) return std::strcmp(e, "0") != 0;
#if defined(CDSM_GL_DEBUG_BUILD)
  return true;
#else
  return false;
#endif
}

const char* error_name(GLenum error) {
  switch (error) {
    case GL_NO_ERROR: return "GL_NO_ERROR";
    case GL_INVALID_ENUM: return "GL_INVALID_ENUM";
    case GL_INVALID_VALUE: return "GL_INVALID_VALUE";
    case GL_INVALID_OPERATION: return "GL_INVALID_OPERATION";
    case GL_INVALID_FRAMEBUFFER_OPERATION: return "GL_INVALID_FRAMEBUFFER_OPERATION";
    case GL_OUT_OF_MEMORY: return "GL_OUT_OF_MEMORY";
    case GL_STACK_UNDERFLOW: return "GL_STACK_UNDERFLOW";
    case GL_STACK_OVERFLOW: return "GL_STACK_OVERFLOW";
    case GL_CONTEXT_LOST: return "GL_CONTEXT_LOST";
    default: return "unknown GL error";
  }
}

namespace detail {
void check_gl(const char* call, const char* file, int line) {
  GLenum first = glGetError();
  if (first == GL_NO_ERROR) return;
  // Drain the queue so the next check starts clean; report the first.
  for (int i = 0; i < 16 && glGetError() != GL_NO_ERROR; ++i) {
  }
  char code[16];
  std::snprintf(code, sizeof code, "0x%04x", unsigned(first));
  throw Error(std::string(file) + ":" + std::to_string(line),
              std::string(call) + " failed: " + error_name(first) + " (" + code + ")");
}
}  // namespace detail

void label_object(GLenum identifier, GLuint name, std::string_view label) {
  Context* c = Context::current();
  if (!c || !c->debug() || name == 0) return;
  glObjectLabel(identifier, name, GLsizei(label.size()), label.data());
  glGetError();  // a label is a diagnostic aid: never fail because of it
}

Context::~Context() {
  if (t_current == this) t_current = nullptr;
}

bool Context::is_current() const { return t_current == this; }
Context* Context::current() { return t_current; }
void Context::note_current() { t_current = this; }
void Context::release_other_api() {
  Context* c = t_current;
  if (!c || c == this) return;
  bool mine_glx = platform_ == Platform::GlfwWindow, other_glx = c->platform_ == Platform::GlfwWindow;
  if (mine_glx != other_glx) c->release();
}

void Context::note_released() {
  if (t_current == this) t_current = nullptr;
}

bool Context::finish_setup(const std::string& platform_detail, std::string* reason) {
  GLint major = 0, minor = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  std::string renderer = gl_string(GL_RENDERER), version = gl_string(GL_VERSION);
  if (major * 10 + minor < 45) {
    if (reason)
      *reason = platform_detail + ": OpenGL " + std::to_string(major) + "." + std::to_string(minor) + " (" + renderer +
                "), 4.5 core needed";
    return false;
  }
  glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &limits_.max_ssbo_block_size);
  glGetIntegerv(GL_SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT, &limits_.ssbo_offset_alignment);
  glGetIntegerv(GL_MAX_FRAMEBUFFER_WIDTH, &limits_.max_framebuffer_width);
  glGetIntegerv(GL_MAX_FRAMEBUFFER_HEIGHT, &limits_.max_framebuffer_height);
  GLint dims[2] = {0, 0};
  glGetIntegerv(GL_MAX_VIEWPORT_DIMS, dims);
  limits_.max_viewport_width = dims[0];
  limits_.max_viewport_height = dims[1];
  glGetIntegeri_v(GL_MAX_COMPUTE_WORK_GROUP_COUNT, 0, &limits_.max_compute_groups_x);
  glGetIntegeri_v(GL_MAX_COMPUTE_WORK_GROUP_COUNT, 1, &limits_.max_compute_groups_y);
  glGetIntegerv(GL_SUBPIXEL_BITS, &limits_.subpixel_bits);
  glGetIntegerv(GL_MAX_FRAGMENT_SHADER_STORAGE_BLOCKS, &limits_.max_fragment_ssbo_blocks);
  glGetIntegerv(GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS, &limits_.max_compute_ssbo_blocks);
  glGetIntegerv(GL_MAX_COMBINED_SHADER_STORAGE_BLOCKS, &limits_.max_combined_ssbo_blocks);
  glGetIntegerv(GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS, &limits_.max_ssbo_bindings);
  if (GLenum e = glGetError(); e != GL_NO_ERROR) {
    if (reason) *reason = platform_detail + ": querying limits failed: " + error_name(e);
    return false;
  }
  description_ = platform_detail + " | " + renderer + " | " + version;

  if (debug_) {
    GLint flags = 0;
    glGetIntegerv(GL_CONTEXT_FLAGS, &flags);
    glEnable(GL_DEBUG_OUTPUT);
    glEnable(GL_DEBUG_OUTPUT_SYNCHRONOUS);  // messages point at the offending call
    glDebugMessageCallback(debug_message, this);
    glDebugMessageControl(GL_DONT_CARE, GL_DONT_CARE, GL_DEBUG_SEVERITY_NOTIFICATION, 0, nullptr, GL_FALSE);
    glGetError();
    description_ += (flags & GL_CONTEXT_FLAG_DEBUG_BIT) ? " | debug" : " | debug output (no debug flag)";
  }
  return true;
}

}  // namespace cdsm::gl
