// A context the application made (GLFW, SDL, Qt, its own EGL): adopted,
// never owned. It is identified by what EGL and GLX report as current when
// it is adopted; make_current() cannot make it current (only the
// application can), it checks that it still is, and throws naming the
// situation otherwise: no context current, or another one (the adopted
// context destroyed, or the application switched contexts).
//
// GLX is asked through dlsym, and only when the process has libGLX (or
// libGL) loaded already: a GLX context can be current only then, and the
// library builds without X11 headers and links no libGLX (so neither X11 nor
// xcb), which a GPU machine without a display lacks.
#include <EGL/egl.h>
#include <dlfcn.h>

#include <atomic>
#include <cstdio>
#include <string>

#include "cdsm/error.h"
#include "gl/context.h"
#include "gl/gl_api.h"

namespace cdsm::gl {

namespace {

// glXGetCurrentContext of the libGLX or libGL the process loaded (GLFW
// loads one for a window), null while it has loaded neither. Looked up
// again until found: a library may be loaded after the first call.
void* current_glx_context() {
  using GetCurrent = void* (*)();
  static std::atomic<GetCurrent> found{nullptr};
  GetCurrent get = found.load();
  for (const char* soname : {"libGLX.so.0", "libGL.so.1"}) {
    if (get) break;
    void* lib = dlopen(soname, RTLD_LAZY | RTLD_NOLOAD);  // only if loaded already; kept referenced
    if (lib) get = reinterpret_cast<GetCurrent>(dlsym(lib, "glXGetCurrentContext"));
    if (get) found.store(get);
  }
  return get ? get() : nullptr;
}

struct CurrentIdentity {
  EGLContext egl = EGL_NO_CONTEXT;
  void* glx = nullptr;  // GLXContext
  bool any() const { return egl != EGL_NO_CONTEXT || glx != nullptr; }
  bool operator==(const CurrentIdentity& o) const { return egl == o.egl && glx == o.glx; }
};

CurrentIdentity current_identity() { return {eglGetCurrentContext(), current_glx_context()}; }

std::string describe(const CurrentIdentity& c) {
  char buf[96];
  if (c.egl != EGL_NO_CONTEXT)
    std::snprintf(buf, sizeof buf, "EGL context %p", c.egl);
  else if (c.glx)
    std::snprintf(buf, sizeof buf, "GLX context %p", c.glx);
  else
    std::snprintf(buf, sizeof buf, "no context");
  return buf;
}

class ExternalContext final : public Context {
 public:
  explicit ExternalContext(const CurrentIdentity& id) : Context(Platform::External, false), id_(id) {}
  ~ExternalContext() override { note_released(); }

  void make_current() override {
    const CurrentIdentity now = current_identity();
    if (now == id_) {
      note_current();
      return;
    }
    note_released();
    if (!now.any())
      throw Error("the application's GL context",
                  "no OpenGL context is current on this thread: make the context the shadow system was created on (" +
                      describe(id_) + ") current before calling it");
    throw Error("the application's GL context",
                "another OpenGL context is current (" + describe(now) +
                    ") than the one the shadow system was created on (" + describe(id_) +
                    "): it was destroyed or switched; make the system's context current, or create the "
                    "system again on the new one");
  }
  void release() override {}  // the application's to release

  bool setup(std::string* reason) {
    return finish_setup(std::string("application context (") + describe(id_) + ")", reason);
  }

 private:
  CurrentIdentity id_;
};

}  // namespace

std::unique_ptr<Context> adopt_current_context(std::string* reason) {
  const CurrentIdentity id = current_identity();
  if (!id.any()) {
    if (reason) *reason = "no OpenGL context is current on this thread (EGL and GLX report none)";
    return nullptr;
  }
  auto c = std::make_unique<ExternalContext>(id);
  // Errors the application left pending are not ours: drained before the
  // limits are queried (finish_setup checks glGetError).
  while (glGetError() != GL_NO_ERROR) {
  }
  if (!c->setup(reason)) return nullptr;
  c->make_current();
  return c;
}

}  // namespace cdsm::gl
