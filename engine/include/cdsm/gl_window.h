// A window with an OpenGL 4.5 core context, for tools and examples (the
// editor, cdsm_forward --window). An engine brings its own window and
// context (SystemOptions::gl_context = GlContextUse::Application); nothing
// of the engine API needs this header.
#pragma once

#include <memory>
#include <string>

#include "cdsm/gl.h"

namespace cdsm {

class GlWindow : public GlContext {
 public:
  // A GLFW window (needs a display: X11, or Xvfb through xvfb-run), its
  // context current on this thread. nullptr + `*reason` when none can be made.
  static std::unique_ptr<GlWindow> create(int width, int height, const std::string& title, bool visible = true,
                                          std::string* reason = nullptr);
  void* native_window() const;  // the GLFWwindow*
  void swap_buffers();
  bool should_close() const;

 private:
  using GlContext::GlContext;
};

}  // namespace cdsm
