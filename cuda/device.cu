#include "device.h"

#include <cuda_runtime.h>

#include <cstdlib>
#include <mutex>
#include <string>

namespace cdsm::cuda {
namespace {

__global__ void probe_kernel() {}

std::string why_none(cudaError_t err) {
  switch (err) {
    case cudaErrorInsufficientDriver:
      return "no CUDA device: no NVIDIA driver, or one older than this CUDA runtime (" + std::to_string(CUDART_VERSION / 1000) +
             "." + std::to_string(CUDART_VERSION % 1000 / 10) + ")";
    case cudaErrorNoDevice:
      return "no CUDA device: the driver reports no GPU";
    default:
      return std::string("no CUDA device: ") + cudaGetErrorName(err) + " (" + cudaGetErrorString(err) + ")";
  }
}

DeviceInfo probe() {
  DeviceInfo info;
  const char* off = std::getenv("CDSM_CUDA_DISABLE");
  if (off && *off && std::string(off) != "0") {
    info.description = "no CUDA device: disabled by CDSM_CUDA_DISABLE";
    return info;
  }
  int count = 0;
  const cudaError_t err = cudaGetDeviceCount(&count);
  if (err != cudaSuccess) {
    cudaGetLastError();  // clear it: the process carries on without CUDA
    info.description = why_none(err);
    return info;
  }
  if (count == 0) {
    info.description = why_none(cudaErrorNoDevice);
    return info;
  }
  std::string skipped;
  for (int d = 0; d < count; ++d) {
    cudaDeviceProp prop{};
    if (cudaGetDeviceProperties(&prop, d) != cudaSuccess) {
      cudaGetLastError();
      continue;
    }
    const std::string name = std::string(prop.name) + " (sm_" + std::to_string(prop.major) + std::to_string(prop.minor);
    // Whether this build carries code the device can run (machine code or PTX it can compile).
    cudaFuncAttributes attr{};
    if (cudaSetDevice(d) != cudaSuccess || cudaFuncGetAttributes(&attr, probe_kernel) != cudaSuccess) {
      cudaGetLastError();
      skipped += (skipped.empty() ? "" : ", ") + name + ")";
      continue;
    }
    info.available = true;
    info.device = d;
    info.description = name + ", " + std::to_string((prop.totalGlobalMem + (1ull << 29)) >> 30) + " GiB)";
    return info;
  }
  info.description = "no CUDA device: this build has no code for " + skipped +
                     " (configure with CMAKE_CUDA_ARCHITECTURES naming it)";
  return info;
}

}  // namespace

DeviceInfo probe_device() {
  static std::once_flag once;
  static DeviceInfo info;
  std::call_once(once, [] { info = probe(); });
  return info;
}

}  // namespace cdsm::cuda
