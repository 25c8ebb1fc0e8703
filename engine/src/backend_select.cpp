#include "backend_select.h"

#include <cstdlib>

#include "cdsm/error.h"
#include "backend/backend.h"
#if defined(CDSM_HAVE_CUDA)
#include "cuda_backend.h"
#include "device.h"
#endif
#if defined(CDSM_HAVE_CUDA) && defined(CDSM_HAVE_CUDA_GL) && CDSM_HAVE_GL
#include "gl/context.h"
#include "gl/gl_api.h"
#include "gl_interop.h"
#define CDSM_BACKEND_GL_PROBE 1
#endif

namespace cdsm {

namespace {

// Whether the cuda backend can run here (which device), and why (not).
DeviceProbe probe_cuda() {
  DeviceProbe p;
  const char* off = std::getenv("CDSM_CUDA_DISABLE");
  if (off && *off && std::string(off) != "0") {
    p.description = "no CUDA device: disabled by CDSM_CUDA_DISABLE";
    return p;
  }
#if defined(CDSM_HAVE_CUDA)
  const cuda::DeviceInfo d = cuda::probe_device();
  p.available = d.available;
  p.device = d.device;
  p.description = d.description;
#else
  p.description =
      "no CUDA device: this build has no cuda backend (configured without it: CDSM_CUDA off, or no nvcc; "
      "scripts/demo.sh builds it only where an NVIDIA driver is loaded)";
#endif
  return p;
}

#if defined(CDSM_BACKEND_GL_PROBE)
// The current context against `device`.
GlProbe probe_current_context(int device) {
  GlProbe g;
  const auto str = [](GLenum e) {
    const GLubyte* s = glGetString(e);
    return s ? std::string(reinterpret_cast<const char*>(s)) : std::string("?");
  };
  g.context = str(GL_VENDOR) + " " + str(GL_RENDERER);
  std::string why;
  if (cuda::gl_context_on_device(device, &why)) {
    g.placement = GlPlacement::OnDevice;
  } else {
    g.placement = GlPlacement::Elsewhere;
    g.context += " (" + why + ")";
  }
  return g;
}
#endif

// Where the frame's GL context runs; probed only with a device (a headless
// context is made and dropped for it: the frame makes the same one later).
GlProbe probe_gl(GlUse use, const DeviceProbe& d) {
  GlProbe g;
  if (use == GlUse::None || !d.available) return g;
#if defined(CDSM_BACKEND_GL_PROBE)
  if (use == GlUse::Current) {
    if (!gl::Context::current() && !glGetString(GL_VERSION)) {
      g.placement = GlPlacement::Elsewhere;
      g.context = "no GL context current";
      return g;
    }
    return probe_current_context(d.device);
  }
  std::string why;
  std::unique_ptr<gl::Context> ctx = gl::create_headless_context({}, &why);
  if (!ctx) return g;  // no context can be made: the frame ray casts its fragments (no GL)
  g = probe_current_context(d.device);
  ctx->release();
  return g;
#else
    // A CUDA build without CUDA-GL interop (no GL headers when configured), or
    // without GL: a context the frame uses cannot be checked, nor shared.
#if CDSM_HAVE_GL
  g.placement = GlPlacement::Elsewhere;
  g.context = "a context this build cannot share with CUDA (built without CUDA-GL interop)";
#endif
  return g;
#endif
}

}  // namespace

BackendResolution decide_auto_backend(const DeviceProbe& d, const GlProbe& g) {
  BackendResolution r;
  r.backend = Backend::Cpu;
  r.name = "cpu";
  if (!d.available) {
    r.reason = d.description;
    return r;
  }
  switch (g.placement) {
    case GlPlacement::None:
      r.backend = Backend::Cuda;
      r.name = "cuda";
      r.reason = "default with a CUDA device (no GL context in this frame): " + d.description;
      return r;
    case GlPlacement::OnDevice:
      r.backend = Backend::Cuda;
      r.name = "cuda";
      r.reason = "default with a CUDA device and the GL context on it: " + d.description;
      return r;
    case GlPlacement::Elsewhere:
      r.reason = "GL context is " + g.context + ", not on CUDA device " + std::to_string(d.device) + " (" +
                 d.description + ")";
      return r;
  }
  return r;
}

GlUse default_gl_use() {
#if CDSM_HAVE_GL
  return GlUse::Headless;
#else
  return GlUse::None;
#endif
}

GlUse gl_use_of(FragmentSource fragments) {
  switch (fragments) {
    case FragmentSource::Cpu:
    case FragmentSource::Cuda: return GlUse::None;
    case FragmentSource::Gl:
    case FragmentSource::Auto: break;
  }
  return default_gl_use();
}

BackendResolution resolve_backend(Backend want) { return resolve_backend(want, default_gl_use()); }
BackendResolution resolve_backend(Backend want, FragmentSource fragments) {
  return resolve_backend(want, gl_use_of(fragments));
}

BackendResolution resolve_backend(Backend want, GlUse gl) {
  BackendResolution r;
  r.backend = want;
  switch (want) {
    case Backend::Cpu:
      r.name = "cpu";
      r.reason = "requested";
      return r;
    case Backend::Reference:
      r.name = "reference";
      r.reason = "requested";
      return r;
    case Backend::Cuda: {
      r.name = "cuda";
      const DeviceProbe d = probe_cuda();
      r.available = d.available;
      r.reason = d.description;
      return r;
    }
    case Backend::Auto: break;
  }
  const DeviceProbe d = probe_cuda();
  return decide_auto_backend(d, probe_gl(gl, d));
}

BackendChoice make_backend(Backend want, GlUse gl) {
  const BackendResolution r = resolve_backend(want, gl);
  if (r.backend == Backend::Reference)
    throw Error("backend",
                "the reference renderer builds no shadow maps: a shadow system needs the cpu or cuda backend");
  if (!r.available) throw Error("backend cuda", r.reason);
  BackendChoice c;
  c.name = r.name;
  c.reason = r.reason;
#if defined(CDSM_HAVE_CUDA)
  if (r.backend == Backend::Cuda) {
    c.backend = cuda::make_cuda_backend();
    return c;
  }
#endif
  c.backend = make_cpu_backend();
  return c;
}

BackendChoice make_system_backend(const SystemOptions& o) {
  GlUse gl_use = GlUse::None;
  if (o.gl_context == GlContextUse::Application)
    gl_use = GlUse::Current;
  else if (o.fragments == FragmentSource::Auto || o.fragments == FragmentSource::Gl)
    gl_use = default_gl_use();
  return make_backend(o.backend, gl_use);
}

}  // namespace cdsm
