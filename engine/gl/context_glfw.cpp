// A GL 4.5 core context in a GLFW 3.3 window (the editor). GLFW makes the
// context through GLX; libglvnd routes the libOpenGL entry points to it just
// as it does for EGL.
#include <string>

#include "gl/context.h"

#if defined(CDSM_HAVE_GLFW)
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <mutex>
#endif

namespace cdsm::gl {

#if defined(CDSM_HAVE_GLFW)
namespace {

// glfwInit/glfwTerminate are process-wide: count the windows alive. (Never
// destroyed, like the EGL display registry: safe for contexts in statics.)
struct GlfwState {
  std::mutex mutex;
  int users = 0;
  std::string last_error;
};
GlfwState& glfw_state() {
  static GlfwState* s = new GlfwState;
  return *s;
}

void glfw_error(int code, const char* message) {
  glfw_state().last_error = "GLFW error " + std::to_string(code) + ": " + (message ? message : "");
}

bool glfw_acquire(std::string* why) {
  GlfwState& g = glfw_state();
  std::lock_guard<std::mutex> lock(g.mutex);
  if (g.users == 0) {
    glfwSetErrorCallback(glfw_error);
    g.last_error.clear();
    if (!glfwInit()) {
      *why = "glfwInit failed: " + (g.last_error.empty() ? std::string("unknown") : g.last_error);
      return false;
    }
  }
  ++g.users;
  return true;
}

void glfw_release() {
  GlfwState& g = glfw_state();
  std::lock_guard<std::mutex> lock(g.mutex);
  if (--g.users == 0) glfwTerminate();
}

class GlfwContext final : public Context {
 public:
  explicit GlfwContext(bool debug) : Context(Platform::GlfwWindow, debug) {}
  ~GlfwContext() override {
    if (window_) {
      if (glfwGetCurrentContext() == window_) {
        note_released();
        glfwMakeContextCurrent(nullptr);
      }
      glfwDestroyWindow(window_);
    }
    if (initialized_) glfw_release();
  }

  bool open(const ContextOptions& o, std::string* why) {
    if (!glfw_acquire(why)) return false;
    initialized_ = true;
    glfwDefaultWindowHints();
    glfwWindowHint(GLFW_CLIENT_API, GLFW_OPENGL_API);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    glfwWindowHint(GLFW_OPENGL_DEBUG_CONTEXT, debug() ? GLFW_TRUE : GLFW_FALSE);
    glfwWindowHint(GLFW_VISIBLE, o.visible ? GLFW_TRUE : GLFW_FALSE);
    glfw_state().last_error.clear();
    release_other_api();  // GLFW makes the new context current while creating it
    window_ = glfwCreateWindow(o.width, o.height, o.title.c_str(), nullptr, nullptr);
    if (!window_) {
      *why = "glfwCreateWindow(OpenGL 4.5 core) failed: " + glfw_state().last_error;
      return false;
    }
    glfwMakeContextCurrent(window_);
    note_current();
    glfwSwapInterval(o.vsync ? 1 : 0);
    return finish_setup("GLFW window (GLX)", why);
  }

  void make_current() override {
    if (glfwGetCurrentContext() != window_) {
      release_other_api();
      glfwMakeContextCurrent(window_);
    }
    note_current();
  }
  void release() override {
    if (window_ && glfwGetCurrentContext() == window_) {
      note_released();
      glfwMakeContextCurrent(nullptr);
    }
  }
  void* native_window() const override { return window_; }
  void swap_buffers() override { glfwSwapBuffers(window_); }
  bool should_close() const override { return glfwWindowShouldClose(window_) != 0; }

 private:
  GLFWwindow* window_ = nullptr;
  bool initialized_ = false;
};

}  // namespace

std::unique_ptr<Context> create_window_context(const ContextOptions& options, std::string* reason) {
  std::string why;
  try {
    auto ctx = std::make_unique<GlfwContext>(options.debug);
    if (ctx->open(options, &why)) return ctx;
  } catch (const std::exception& e) {
    why = e.what();
  }
  if (reason) *reason = "no OpenGL 4.5 window: " + why;
  return nullptr;
}

#else

std::unique_ptr<Context> create_window_context(const ContextOptions&, std::string* reason) {
  if (reason) *reason = "no OpenGL window: this build has no GLFW (libglfw3-dev not found)";
  return nullptr;
}

#endif

}  // namespace cdsm::gl
