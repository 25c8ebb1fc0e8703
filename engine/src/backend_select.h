// Which ShadowBackend a shadow system runs its kernels on (DESIGN.md §5):
// the cpu backend always; a cuda backend when the build has one and a
// device is there. The choice and its reason are reported in FrameStats.
#pragma once

#include <memory>
#include <string>

#include "backend/backend.h"
#include "cdsm/renderer.h"

namespace cdsm {

struct BackendChoice {
  std::unique_ptr<ShadowBackend> backend;
  std::string name;    // "cpu", ...
  std::string reason;  // why this one
};

// The backend for `want`. Throws cdsm::Error when a backend that cannot
// run here is requested explicitly (Backend::Reference draws no maps).
BackendChoice make_backend(Backend want);

}  // namespace cdsm
