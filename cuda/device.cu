#include "device.h"

#include <cuda_runtime.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>

namespace cdsm::cuda {
namespace {

__global__ void probe_kernel() {}

std::string why_none(cudaError_t err) {
  switch (err) {
    case cudaErrorInsufficientDriver:
      return "no CUDA device: no NVIDIA driver, or one older than this CUDA runtime (" +
             std::to_string(CUDART_VERSION / 1000) + "." + std::to_string(CUDART_VERSION % 1000 / 10) + ")";
    case cudaErrorNoDevice: return "no CUDA device: the driver reports no GPU";
    default: return std::string("no CUDA device: ") + cudaGetErrorName(err) + " (" + cudaGetErrorString(err) + ")";
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
  info.description =
      "no CUDA device: this build has no code for " + skipped + " (configure with CMAKE_CUDA_ARCHITECTURES naming it)";
  return info;
}

struct UnusableState {
  std::atomic<bool> set{false};
  std::mutex mutex;
  int error = 0;
  std::string what;
};
UnusableState& unusable_state() {
  static UnusableState s;
  return s;
}
std::atomic<const char*> g_last_launch{nullptr};

}  // namespace

DeviceInfo probe_device() {
  static std::once_flag once;
  static DeviceInfo info;
  std::call_once(once, [] { info = probe(); });
  if (unusable()) {
    DeviceInfo gone = info;
    gone.available = false;
    gone.description = "no CUDA device: CUDA is unusable in this process after an earlier error: " + unusable_reason();
    return gone;
  }
  return info;
}

std::string mark_unusable(int cuda_error, const std::string& what) {
  UnusableState& s = unusable_state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (!s.set.load()) {
    s.error = cuda_error;
    s.what = what;
    const char* last = last_launch();
    if (*last) s.what += std::string("; last kernel launched: '") + last + "'";
    if (!sync_every_launch()) s.what += " (CDSM_CUDA_SYNC=1 names the kernel that failed)";
    s.set.store(true);
    std::fprintf(stderr, "cdsm: CUDA is unusable in this process: %s; every later CUDA call fails\n", s.what.c_str());
  }
  return s.what;
}

bool unusable() { return unusable_state().set.load(); }

std::string unusable_reason() {
  UnusableState& s = unusable_state();
  if (!s.set.load()) return {};
  std::lock_guard<std::mutex> lock(s.mutex);
  return s.what;
}

int unusable_error() {
  UnusableState& s = unusable_state();
  if (!s.set.load()) return 0;
  std::lock_guard<std::mutex> lock(s.mutex);
  return s.error;
}

bool sync_every_launch() {
  static const bool sync = [] {
    const char* v = std::getenv("CDSM_CUDA_SYNC");
    return v && *v && std::string(v) != "0";
  }();
  return sync;
}

void note_launch(const char* name) { g_last_launch.store(name); }

const char* last_launch() {
  const char* n = g_last_launch.load();
  return n ? n : "";
}

}  // namespace cdsm::cuda
