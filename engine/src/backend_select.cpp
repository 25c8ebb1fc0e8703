#include "backend_select.h"

#include <cstdlib>

#include "cdsm/error.h"
#include "cpu/cpu_backend.h"
#if defined(CDSM_HAVE_CUDA)
#include "cuda_backend.h"
#include "device.h"
#endif

namespace cdsm {

namespace {

// Whether the cuda backend can run here, and why (not).
bool cuda_usable(std::string& why) {
  const char* off = std::getenv("CDSM_CUDA_DISABLE");
  if (off && *off && std::string(off) != "0") {
    why = "no CUDA device: disabled by CDSM_CUDA_DISABLE";
    return false;
  }
#if defined(CDSM_HAVE_CUDA)
  const cuda::DeviceInfo d = cuda::probe_device();
  why = d.description;
  return d.available;
#else
  why = "no CUDA device: this build has no cuda backend (nvcc was not found when it was configured)";
  return false;
#endif
}

}  // namespace

BackendResolution resolve_backend(Backend want) {
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
      std::string why;
      r.available = cuda_usable(why);
      r.reason = why;
      return r;
    }
    case Backend::Auto:
      break;
  }
  std::string why;
  if (cuda_usable(why)) {
    r.backend = Backend::Cuda;
    r.name = "cuda";
    r.reason = "default with a CUDA device: " + why;
  } else {
    r.backend = Backend::Cpu;
    r.name = "cpu";
    r.reason = why;
  }
  return r;
}

BackendChoice make_backend(Backend want) {
  const BackendResolution r = resolve_backend(want);
  if (r.backend == Backend::Reference)
    throw Error("backend", "the reference renderer builds no shadow maps: a shadow system needs the cpu or cuda backend");
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

}  // namespace cdsm
