// One macro checks every CUDA runtime call (STYLE.md 8): a failure throws
// cdsm::cuda::CudaError naming the file, the line, the call and CUDA's
// error; in destructors, CDSM_CUDA_CHECK_NOTHROW prints the same line
// instead (destructors never throw). A sticky error (the context is lost:
// an illegal address, a failed launch, a device-side assert, ...) marks
// CUDA unusable in this process (cuda/device.h mark_unusable: said once on
// stderr, later calls fail fast with that first message, probe_device()
// reports no device); cleanup after it stays quiet.
#pragma once

#include <cuda_runtime.h>

#include <cstdio>
#include <stdexcept>
#include <string>

#include "device.h"

namespace cdsm::cuda {

class CudaError : public std::runtime_error {
 public:
  CudaError(cudaError_t code, const std::string& what) : std::runtime_error(what), code_(code) {}
  cudaError_t code() const { return code_; }

 private:
  cudaError_t code_;
};

inline std::string describe(cudaError_t e, const char* call, const char* file, int line) {
  return std::string(file) + ":" + std::to_string(line) + ": " + call + ": " + cudaGetErrorName(e) + " (" +
         cudaGetErrorString(e) + ")";
}

// Errors after which the CUDA context cannot be used again in this process
// (CUDA's documentation: "the process must be terminated and relaunched").
inline bool is_sticky(cudaError_t e) {
  switch (e) {
    case cudaErrorIllegalAddress:
    case cudaErrorLaunchFailure:
    case cudaErrorLaunchTimeout:
    case cudaErrorAssert:
    case cudaErrorHardwareStackError:
    case cudaErrorIllegalInstruction:
    case cudaErrorMisalignedAddress:
    case cudaErrorInvalidAddressSpace:
    case cudaErrorInvalidPc:
    case cudaErrorECCUncorrectable:
    case cudaErrorExternalDevice:
    case cudaErrorMpsClientTerminated:
#if CUDART_VERSION >= 12080
    case cudaErrorContained:
    case cudaErrorTensorMemoryLeak:
#endif
      return true;
    default: return false;
  }
}

// The message and the CudaError of a failed call: a sticky error is recorded
// as the reason CUDA is unusable (the first one is kept and said once).
inline CudaError error_of(cudaError_t e, const std::string& what) {
  if (!is_sticky(e)) {
    cudaGetLastError();  // clear a non-sticky error so the next call starts clean
    return CudaError(e, what);
  }
  const std::string first = mark_unusable(int(e), what);
  return CudaError(e, first.rfind(what, 0) == 0 ? first + "; CUDA is unusable in this process from now on"
                                                : what + " (CUDA is unusable in this process since: " + first + ")");
}

inline void check(cudaError_t e, const char* call, const char* file, int line) {
  if (e == cudaSuccess) return;
  throw error_of(e, describe(e, call, file, line));
}

inline void check_nothrow(cudaError_t e, const char* call, const char* file, int line) noexcept {
  if (e == cudaSuccess) return;
  if (unusable()) return;  // said once already: every call fails now, cleanup included
  try {
    const std::string what = describe(e, call, file, line);
    if (is_sticky(e))
      mark_unusable(int(e), what);  // says so itself
    else
      std::fprintf(stderr, "cdsm: CUDA error ignored in cleanup: %s\n", what.c_str());
    cudaGetLastError();
  } catch (...) {
  }
}

// A CudaExec call once CUDA is unusable: fails fast, naming the first error.
inline void check_usable(const char* what) {
  if (!unusable()) return;
  throw CudaError(cudaError_t(unusable_error()),
                  std::string("cuda backend: ") + what +
                      ": CUDA is unusable in this process after an earlier error: " + unusable_reason());
}

}  // namespace cdsm::cuda

#define CDSM_CUDA_CHECK(call) ::cdsm::cuda::check((call), #call, __FILE__, __LINE__)
#define CDSM_CUDA_CHECK_NOTHROW(call) ::cdsm::cuda::check_nothrow((call), #call, __FILE__, __LINE__)
