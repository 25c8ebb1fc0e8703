// One macro checks every CUDA runtime call (STYLE.md 8): a failure throws
// cdsm::cuda::CudaError naming the file, the line, the call and CUDA's
// error; in destructors, CDSM_CUDA_CHECK_NOTHROW prints the same line
// instead (destructors never throw).
#pragma once

#include <cuda_runtime.h>

#include <cstdio>
#include <stdexcept>
#include <string>

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

inline void check(cudaError_t e, const char* call, const char* file, int line) {
  if (e == cudaSuccess) return;
  cudaGetLastError();  // clear a non-sticky error so the next call starts clean
  throw CudaError(e, describe(e, call, file, line));
}

inline void check_nothrow(cudaError_t e, const char* call, const char* file, int line) noexcept {
  if (e == cudaSuccess) return;
  cudaGetLastError();
  std::fprintf(stderr, "cdsm: CUDA error ignored in cleanup: %s\n", describe(e, call, file, line).c_str());
}

}  // namespace cdsm::cuda

#define CDSM_CUDA_CHECK(call) ::cdsm::cuda::check((call), #call, __FILE__, __LINE__)
#define CDSM_CUDA_CHECK_NOTHROW(call) ::cdsm::cuda::check_nothrow((call), #call, __FILE__, __LINE__)
