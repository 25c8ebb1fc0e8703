// OpenGL 4.5 core contexts: headless through EGL (CI, batch rendering, GPU
// servers) or in a GLFW window (the editor), behind one small interface.
//
// How GL functions are reached: no loader library. gl_api.h defines
// GL_GLEXT_PROTOTYPES and includes <GL/glcorearb.h>, and the targets link
// libglvnd's libOpenGL (CMake OpenGL::OpenGL) plus libEGL (OpenGL::EGL).
// libOpenGL exports every core 4.5 entry point as a thin dispatch stub, and
// libglvnd routes each call to the vendor library (Mesa, NVIDIA) that owns
// the context current on the calling thread -- whether EGL or GLX (GLFW)
// made it current. So the entry points resolve at link time, there is no
// extra dependency (glad/GLEW/epoxy), and the same binary runs on llvmpipe
// and on an NVIDIA driver. Extensions beyond 4.5 core would need
// eglGetProcAddress; this project uses none.
//
// Threading: a context is current on one thread at a time; GL objects made
// through it belong to it. make_current() binds it to the calling thread.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

namespace cdsm::gl {

// Where a context came from.
enum class Platform {
  EglDevice,       // EGL_EXT_platform_device (a GPU, or a software device as last resort)
  EglSurfaceless,  // EGL_MESA_platform_surfaceless (Mesa: llvmpipe or a DRM GPU)
  GlfwWindow,      // a GLFW 3.3 window (GLX/X11)
  External,        // the application's own context, adopted (adopt_current_context)
};
const char* platform_name(Platform p);

// Debug default: on in Debug builds (CMAKE_BUILD_TYPE Debug) or when the
// environment sets CDSM_GL_DEBUG=1 (CDSM_GL_DEBUG=0 forces it off).
bool debug_default();

struct ContextOptions {
  // KHR_debug output (messages to stderr, synchronous) and glObjectLabel on
  // every buffer, shader, program, vertex array and framebuffer.
  bool debug = debug_default();
  // Window only:
  int width = 1280;
  int height = 720;
  std::string title = "cdsm";
  bool visible = true;
  bool vsync = true;
};

// Implementation limits queried once when the context is created.
struct Limits {
  int64_t max_ssbo_block_size = 0;     // GL_MAX_SHADER_STORAGE_BLOCK_SIZE, bytes (128 MiB on llvmpipe)
  int32_t ssbo_offset_alignment = 0;   // GL_SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT, bytes
  int32_t max_framebuffer_width = 0;   // GL_MAX_FRAMEBUFFER_WIDTH (no-attachment FBOs)
  int32_t max_framebuffer_height = 0;  // GL_MAX_FRAMEBUFFER_HEIGHT
  int32_t max_viewport_width = 0;      // GL_MAX_VIEWPORT_DIMS
  int32_t max_viewport_height = 0;
  int32_t max_compute_groups_x = 0;  // GL_MAX_COMPUTE_WORK_GROUP_COUNT[0]
  int32_t max_compute_groups_y = 0;  // GL_MAX_COMPUTE_WORK_GROUP_COUNT[1]
  int32_t subpixel_bits = 0;         // GL_SUBPIXEL_BITS: window positions snap to 2^-bits pixel
  // Shader storage blocks one stage may use, and binding points (GL 4.5
  // guarantees 8 of each stage's, 8 combined, 8 bindings; drivers give more).
  int32_t max_fragment_ssbo_blocks = 0;  // GL_MAX_FRAGMENT_SHADER_STORAGE_BLOCKS
  int32_t max_compute_ssbo_blocks = 0;   // GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS
  int32_t max_combined_ssbo_blocks = 0;  // GL_MAX_COMBINED_SHADER_STORAGE_BLOCKS
  int32_t max_ssbo_bindings = 0;         // GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS
};

class Context {
 public:
  virtual ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  // Makes this context current on the calling thread (cheap when it already
  // is). Another cdsm context current on this thread through a different
  // window-system API (EGL vs GLX) is released first: libglvnd refuses a
  // thread two APIs' contexts at once.
  virtual void make_current() = 0;
  // Makes no context current on this thread, if this one is.
  virtual void release() = 0;
  bool is_current() const;
  // The context current on this thread, if it is one of ours.
  static Context* current();

  Platform platform() const { return platform_; }
  bool debug() const { return debug_; }
  const Limits& limits() const { return limits_; }
  // e.g. "EGL surfaceless (Mesa) | llvmpipe (LLVM 15.0.6, 256 bits) | 4.5 (Core Profile) Mesa 22.3.6"
  const std::string& description() const { return description_; }

  // Window contexts only (headless: nullptr / no-ops / false).
  virtual void* native_window() const { return nullptr; }  // the GLFWwindow*
  virtual void swap_buffers() {}
  virtual bool should_close() const { return false; }

 protected:
  Context(Platform platform, bool debug) : platform_(platform), debug_(debug) {}
  // Called by implementations once the context is current: checks for GL
  // 4.5, queries limits, builds the description, installs debug output.
  // Returns false with `reason` set when the context is unusable.
  bool finish_setup(const std::string& platform_detail, std::string* reason);
  void note_current();   // implementations call this after making it current
  void note_released();  // ... and this before releasing it
  // Releases the cdsm context current on this thread if it uses another
  // window-system API than this one (GLFW/GLX vs EGL).
  void release_other_api();

 private:
  Platform platform_;
  bool debug_;
  Limits limits_;
  std::string description_;
};

// A headless GL 4.5 core context with no surface (EGL_KHR_surfaceless_context),
// current on the calling thread. Tries, in order: EGL devices that are not
// software renderers (an NVIDIA GPU on a headless server), the Mesa
// surfaceless platform (llvmpipe or a Mesa GPU), then software EGL devices.
// Returns nullptr and sets `*reason` (every attempt and why it failed) when
// no context can be made. Never throws, never aborts.
std::unique_ptr<Context> create_headless_context(const ContextOptions& options = {}, std::string* reason = nullptr);

// A GL 4.5 core context in a GLFW window (needs a display: X11, or Xvfb via
// xvfb-run), current on the calling thread. nullptr + `*reason` on failure
// (no display, no GLFW in this build, GL < 4.5).
std::unique_ptr<Context> create_window_context(const ContextOptions& options = {}, std::string* reason = nullptr);

// The application's context, current on the calling thread (made by GLFW,
// SDL, Qt or its own EGL code), adopted: never made current, released or
// destroyed by cdsm. Its make_current() only checks that it is still the
// current one and throws cdsm::Error naming what is current instead (none,
// or another context: the adopted one was destroyed or switched). Needs
// 4.5 core. nullptr + `*reason` when none is current or it is older. Debug
// output is left as the application set it.
std::unique_ptr<Context> adopt_current_context(std::string* reason = nullptr);

}  // namespace cdsm::gl
