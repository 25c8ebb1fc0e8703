// The exec backend over the CUDA executor: every parallel_for of
// shadows/exec/ becomes a launch of parallel_for_kernel<lambda>, compiled in
// the translation units cuda/instances.cuh names.
#include "cuda_backend.h"

#include "cdsm/error.h"
#include "device.h"
#include "instances.cuh"

namespace cdsm::cuda {

std::unique_ptr<exec::ExecShadowBackend> make_cuda_backend() {
  const DeviceInfo d = probe_device();
  if (!d.available) throw Error("cuda backend", d.description);
  return std::make_unique<exec::ExecBackend<CudaExec>>("cuda", d.device);
}

}  // namespace cdsm::cuda
