// The cuda backend (DESIGN.md §5): the exec backend (shadows/backend/
// exec_backend.h) over the CUDA executor (cuda/launch.cuh) — the same
// CDSM_HD kernels as the cpu backend, launched on a device. Plain C++:
// the engine includes it without nvcc (engine/src/backend_select.cpp).
#pragma once

#include <memory>

#include "backend/exec_backend.h"

namespace cdsm::cuda {

// The backend on the device probe_device() found. Throws cdsm::Error
// ("cuda backend: no CUDA device: ...") when there is none.
std::unique_ptr<exec::ExecShadowBackend> make_cuda_backend();

}  // namespace cdsm::cuda
