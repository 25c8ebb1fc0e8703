// Which ShadowBackend a shadow system runs its kernels on (DESIGN.md §5):
// the cpu backend always; the cuda backend (cuda/cuda_backend.h) when the
// build has one (CDSM_HAVE_CUDA) and a device is there. resolve_backend()
// (cdsm/renderer.h) says which and why; the choice and its reason are
// reported in FrameStats.
#pragma once

#include <memory>
#include <string>

#include "backend/backend.h"
#include "cdsm/renderer.h"

namespace cdsm {

struct BackendChoice {
  std::unique_ptr<ShadowBackend> backend;
  std::string name;    // "cpu", "cuda"
  std::string reason;  // why this one
};

// The backend for `want` (Auto: cuda when it can run, else cpu). Throws
// cdsm::Error when a backend that cannot run here is requested explicitly
// (Cuda without a device; Reference draws no maps).
BackendChoice make_backend(Backend want);

}  // namespace cdsm
