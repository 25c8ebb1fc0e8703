// cdsm::GlContext (cdsm/gl.h) and cdsm::GlWindow (cdsm/gl_window.h) over the
// engine's GL contexts (engine/gl/context.h).
#include "cdsm/error.h"
#include "cdsm/gl.h"
#include "cdsm/gl_window.h"

#if CDSM_HAVE_GL
#include "gl/context.h"
#endif

namespace cdsm {

#if CDSM_HAVE_GL

struct GlContext::Impl {
  std::unique_ptr<gl::Context> context;
};

GlContext::GlContext(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
GlContext::~GlContext() = default;

std::unique_ptr<GlContext> GlContext::create_headless(std::string* reason) {
  auto c = gl::create_headless_context({}, reason);
  if (!c) return nullptr;
  auto impl = std::make_unique<Impl>();
  impl->context = std::move(c);
  return std::unique_ptr<GlContext>(new GlContext(std::move(impl)));
}

std::unique_ptr<GlWindow> GlWindow::create(int width, int height, const std::string& title, bool visible,
                                           std::string* reason) {
  gl::ContextOptions o;
  o.width = width;
  o.height = height;
  o.title = title;
  o.visible = visible;
  auto c = gl::create_window_context(o, reason);
  if (!c) return nullptr;
  auto impl = std::make_unique<Impl>();
  impl->context = std::move(c);
  return std::unique_ptr<GlWindow>(new GlWindow(std::move(impl)));
}

void GlContext::make_current() { impl_->context->make_current(); }
void GlContext::release() { impl_->context->release(); }
const std::string& GlContext::description() const { return impl_->context->description(); }
int64_t GlContext::max_storage_block_bytes() const { return impl_->context->limits().max_ssbo_block_size; }
void* GlWindow::native_window() const { return impl_->context->native_window(); }
void GlWindow::swap_buffers() { impl_->context->swap_buffers(); }
bool GlWindow::should_close() const { return impl_->context->should_close(); }

#else

struct GlContext::Impl {};
GlContext::GlContext(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
GlContext::~GlContext() = default;
std::unique_ptr<GlContext> GlContext::create_headless(std::string* reason) {
  if (reason) *reason = "this build has no OpenGL (configured with CDSM_GL=OFF)";
  return nullptr;
}
std::unique_ptr<GlWindow> GlWindow::create(int, int, const std::string&, bool, std::string* reason) {
  if (reason) *reason = "this build has no OpenGL (configured with CDSM_GL=OFF)";
  return nullptr;
}
void GlContext::make_current() {}
void GlContext::release() {}
const std::string& GlContext::description() const {
  static const std::string none = "no OpenGL";
  return none;
}
int64_t GlContext::max_storage_block_bytes() const { return 0; }
void* GlWindow::native_window() const { return nullptr; }
void GlWindow::swap_buffers() {}
bool GlWindow::should_close() const { return false; }

#endif

}  // namespace cdsm
