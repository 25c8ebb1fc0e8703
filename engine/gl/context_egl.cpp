// Headless GL 4.5 core contexts through EGL, without a surface.
//
// Order of attempts (create_headless_context):
//   1. EGL_EXT_platform_device, devices that are not software renderers,
//      NVIDIA's first (its driver exposes GPUs this way on servers without X);
//   2. EGL_MESA_platform_surfaceless (Mesa: llvmpipe, or a Mesa DRM driver);
//   3. EGL_EXT_platform_device, software devices (EGL_MESA_device_software).
// Every failed attempt is recorded in the reason string.
#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "cdsm/error.h"
#include "gl/context.h"
#include "gl/gl_api.h"

namespace cdsm::gl {

namespace {

const char* egl_error_name(EGLint e) {
  switch (e) {
    case EGL_SUCCESS: return "EGL_SUCCESS";
    case EGL_NOT_INITIALIZED: return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS: return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC: return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE: return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG: return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT: return "EGL_BAD_CONTEXT";
    case EGL_BAD_CURRENT_SURFACE: return "EGL_BAD_CURRENT_SURFACE";
    case EGL_BAD_DISPLAY: return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH: return "EGL_BAD_MATCH";
    case EGL_BAD_NATIVE_PIXMAP: return "EGL_BAD_NATIVE_PIXMAP";
    case EGL_BAD_NATIVE_WINDOW: return "EGL_BAD_NATIVE_WINDOW";
    case EGL_BAD_PARAMETER: return "EGL_BAD_PARAMETER";
    case EGL_BAD_SURFACE: return "EGL_BAD_SURFACE";
    case EGL_CONTEXT_LOST: return "EGL_CONTEXT_LOST";
    default: return "unknown EGL error";
  }
}

std::string egl_failure(const char* what) {
  return std::string(what) + " failed (" + egl_error_name(eglGetError()) + ")";
}

// Whole-word search in a space-separated extension string.
bool has_extension(const char* list, const char* name) {
  if (!list) return false;
  size_t n = std::strlen(name);
  for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += n) {
    bool starts = p == list || p[-1] == ' ';
    bool ends = p[n] == '\0' || p[n] == ' ';
    if (starts && ends) return true;
  }
  return false;
}

// eglInitialize/eglTerminate are not reference counted and
// eglGetPlatformDisplay returns the same handle for the same arguments, so
// two contexts on one display must not terminate it under each other. The
// registry is never destroyed: a context held in a static may be destroyed
// during exit, after ordinary statics are gone.
struct DisplayRegistry {
  std::mutex mutex;
  std::map<EGLDisplay, int> refs;
};
DisplayRegistry& displays() {
  static DisplayRegistry* r = new DisplayRegistry;
  return *r;
}

bool acquire_display(EGLDisplay dpy, EGLint* major, EGLint* minor) {
  DisplayRegistry& d = displays();
  std::lock_guard<std::mutex> lock(d.mutex);
  if (!eglInitialize(dpy, major, minor)) return false;
  ++d.refs[dpy];
  return true;
}

void release_display(EGLDisplay dpy) {
  DisplayRegistry& d = displays();
  std::lock_guard<std::mutex> lock(d.mutex);
  auto it = d.refs.find(dpy);
  if (it == d.refs.end()) return;
  if (--it->second == 0) {
    d.refs.erase(it);
    eglTerminate(dpy);
  }
}

class EglContext final : public Context {
 public:
  EglContext(Platform p, bool debug) : Context(p, debug) {}
  ~EglContext() override {
    if (dpy_ == EGL_NO_DISPLAY) return;
    if (ctx_ != EGL_NO_CONTEXT) {
      if (eglGetCurrentContext() == ctx_) {
        note_released();
        eglMakeCurrent(dpy_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      }
      eglDestroyContext(dpy_, ctx_);
    }
    release_display(dpy_);
  }

  void make_current() override {
    if (eglGetCurrentContext() == ctx_) {
      note_current();
      return;
    }
    release_other_api();
    eglBindAPI(EGL_OPENGL_API);
    if (!eglMakeCurrent(dpy_, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx_)) throw Error("EGL", egl_failure("eglMakeCurrent"));
    note_current();
  }

  void release() override {
    if (ctx_ != EGL_NO_CONTEXT && eglGetCurrentContext() == ctx_) {
      note_released();
      eglMakeCurrent(dpy_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    }
  }

  // Initializes `dpy` and makes a surfaceless 4.5 core context current on it.
  bool open(EGLDisplay dpy, const std::string& label, std::string* reason) {
    EGLint major = 0, minor = 0;
    if (!acquire_display(dpy, &major, &minor)) {
      *reason = label + ": " + egl_failure("eglInitialize");
      return false;
    }
    dpy_ = dpy;
    const char* ext = eglQueryString(dpy, EGL_EXTENSIONS);
    if (!has_extension(ext, "EGL_KHR_surfaceless_context")) {
      *reason = label + ": no EGL_KHR_surfaceless_context";
      return false;
    }
    bool egl15 = major > 1 || (major == 1 && minor >= 5);
    if (!egl15 && !has_extension(ext, "EGL_KHR_create_context")) {
      *reason =
          label + ": EGL " + std::to_string(major) + "." + std::to_string(minor) + " without EGL_KHR_create_context";
      return false;
    }
    if (!eglBindAPI(EGL_OPENGL_API)) {
      *reason = label + ": " + egl_failure("eglBindAPI(EGL_OPENGL_API)");
      return false;
    }
    EGLConfig config = EGL_NO_CONFIG_KHR;
    if (!has_extension(ext, "EGL_KHR_no_config_context")) {
      // No default framebuffer is ever used; any GL-capable config will do.
      const EGLint pbuffer[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_NONE};
      const EGLint any[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, 0, EGL_NONE};
      EGLint n = 0;
      if (!(eglChooseConfig(dpy, pbuffer, &config, 1, &n) && n == 1) &&
          !(eglChooseConfig(dpy, any, &config, 1, &n) && n == 1)) {
        *reason = label + ": no OpenGL-renderable EGLConfig";
        return false;
      }
    }
    std::vector<EGLint> attribs = {EGL_CONTEXT_MAJOR_VERSION_KHR,       4,
                                   EGL_CONTEXT_MINOR_VERSION_KHR,       5,
                                   EGL_CONTEXT_OPENGL_PROFILE_MASK_KHR, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT_KHR};
    if (debug()) {
      if (egl15) {
        attribs.insert(attribs.end(), {EGL_CONTEXT_OPENGL_DEBUG, EGL_TRUE});
      } else {
        attribs.insert(attribs.end(), {EGL_CONTEXT_FLAGS_KHR, EGL_CONTEXT_OPENGL_DEBUG_BIT_KHR});
      }
    }
    attribs.push_back(EGL_NONE);
    ctx_ = eglCreateContext(dpy, config, EGL_NO_CONTEXT, attribs.data());
    if (ctx_ == EGL_NO_CONTEXT) {
      *reason = label + ": " + egl_failure("eglCreateContext(OpenGL 4.5 core)");
      return false;
    }
    release_other_api();
    if (!eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx_)) {
      *reason = label + ": " + egl_failure("eglMakeCurrent(no surface)");
      return false;
    }
    note_current();
    return finish_setup(label, reason);
  }

 private:
  EGLDisplay dpy_ = EGL_NO_DISPLAY;
  EGLContext ctx_ = EGL_NO_CONTEXT;
};

struct EglDeviceInfo {
  EGLDeviceEXT device;
  bool software;
  bool cuda;         // EGL_NV_device_cuda: an NVIDIA GPU
  std::string name;  // DRM node or renderer name, for messages
};

}  // namespace

std::unique_ptr<Context> create_headless_context(const ContextOptions& options, std::string* reason) {
  std::string why;
  auto fail = [&](const std::string& r) { why += (why.empty() ? "" : "; ") + r; };
  try {
    const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (!client) {
      if (reason)
        *reason = "no headless OpenGL 4.5 context: EGL has no client extensions (" +
                  std::string(egl_error_name(eglGetError())) + "; no EGL vendor library?)";
      return nullptr;
    }
    auto get_platform_display =
        reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (!get_platform_display || !has_extension(client, "EGL_EXT_platform_base")) {
      if (reason) *reason = "no headless OpenGL 4.5 context: EGL without EGL_EXT_platform_base";
      return nullptr;
    }

    auto try_display = [&](EGLDisplay dpy, Platform platform, const std::string& label) -> std::unique_ptr<Context> {
      if (dpy == EGL_NO_DISPLAY) {
        fail(label + ": " + egl_failure("eglGetPlatformDisplayEXT"));
        return nullptr;
      }
      auto ctx = std::make_unique<EglContext>(platform, options.debug);
      std::string r;
      if (ctx->open(dpy, label, &r)) return ctx;
      fail(r);
      return nullptr;
    };

    // Enumerate EGL devices (glvnd merges every vendor's list).
    std::vector<EglDeviceInfo> devices;
    if (has_extension(client, "EGL_EXT_platform_device")) {
      auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
      auto query_string =
          reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(eglGetProcAddress("eglQueryDeviceStringEXT"));
      EGLint n = 0;
      if (query_devices && query_string && query_devices(0, nullptr, &n) && n > 0) {
        std::vector<EGLDeviceEXT> list(static_cast<size_t>(n));
        query_devices(n, list.data(), &n);
        for (EGLint i = 0; i < n; ++i) {
          const char* dext = query_string(list[size_t(i)], EGL_EXTENSIONS);
          EglDeviceInfo info{list[size_t(i)], has_extension(dext, "EGL_MESA_device_software"),
                             has_extension(dext, "EGL_NV_device_cuda"), "device " + std::to_string(i)};
          if (has_extension(dext, "EGL_EXT_device_query_name"))
            if (const char* r = query_string(list[size_t(i)], EGL_RENDERER_EXT)) info.name += " " + std::string(r);
          if (has_extension(dext, "EGL_EXT_device_drm"))
            if (const char* f = query_string(list[size_t(i)], EGL_DRM_DEVICE_FILE_EXT))
              info.name += " " + std::string(f);
          if (info.software) info.name += " (software)";
          devices.push_back(info);
        }
      } else {
        fail("EGL device platform: no devices");
      }
    } else {
      fail("EGL device platform: no EGL_EXT_platform_device");
    }

    // NVIDIA GPUs first, then other hardware devices, in enumeration order.
    std::stable_partition(devices.begin(), devices.end(), [](const EglDeviceInfo& d) { return d.cuda; });
    for (const EglDeviceInfo& d : devices) {
      if (d.software) continue;
      if (auto c = try_display(get_platform_display(EGL_PLATFORM_DEVICE_EXT, d.device, nullptr), Platform::EglDevice,
                               "EGL " + d.name))
        return c;
    }
    if (has_extension(client, "EGL_MESA_platform_surfaceless")) {
      if (auto c = try_display(get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr),
                               Platform::EglSurfaceless, "EGL surfaceless (Mesa)"))
        return c;
    } else {
      fail("no EGL_MESA_platform_surfaceless");
    }
    for (const EglDeviceInfo& d : devices) {
      if (!d.software) continue;
      if (auto c = try_display(get_platform_display(EGL_PLATFORM_DEVICE_EXT, d.device, nullptr), Platform::EglDevice,
                               "EGL " + d.name))
        return c;
    }
  } catch (const std::exception& e) {
    fail(e.what());
  }
  if (reason) *reason = "no headless OpenGL 4.5 context: " + why;
  return nullptr;
}

}  // namespace cdsm::gl
