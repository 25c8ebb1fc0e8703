// The executor on CPU threads (shadows/exec/exec.h): parallel_for over TBB,
// memory in host RAM. The exec backend over it is the cuda backend's code
// run on the CPU — how CI checks the two-pass light pass without a GPU.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cstring>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#include "exec/exec.h"

namespace cdsm::exec {

class HostExec {
 public:
  static constexpr bool kHostMemory = true;
  static constexpr bool kGlInterop = false;  // no GL buffers written from here (exec_backend.h)
  static constexpr uint64_t kLightPassBatchBytes = uint64_t(8) << 20;  // exec/light_pass.h: cache-sized batches

  void* allocate(size_t bytes) {
    injected_failure("allocate");
    ++counters.allocations;
    return ::operator new(bytes ? bytes : 1, std::align_val_t(256));
  }
  void release(void* p) noexcept { ::operator delete(p, std::align_val_t(256)); }

  template <class F>
  void parallel_for(const char* name, uint64_t n, F f) {
    injected_failure(name);
    if (n > 0) ++counters.launches;
    const auto t0 = std::chrono::steady_clock::now();
    if (n > 0)
      tbb::parallel_for(tbb::blocked_range<uint64_t>(0, n, 64), [&](const tbb::blocked_range<uint64_t>& r) {
        for (uint64_t i = r.begin(); i < r.end(); ++i) f(i);
      });
    add_stage_time(times_, name,
                   std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }

  void upload(void* dst, const void* src, size_t bytes) {
    std::memcpy(dst, src, bytes);
    counters.bytes_up += bytes;
  }
  void download(void* dst, const void* src, size_t bytes) {  // complete on return: a synchronization on CUDA
    synchronize();
    std::memcpy(dst, src, bytes);
    counters.bytes_down += bytes;
  }
  void copy(void* dst, const void* src, size_t bytes) { std::memmove(dst, src, bytes); }
  void fill_zero(void* dst, size_t bytes) { std::memset(dst, 0, bytes); }

  void synchronize() { ++counters.syncs; }

  std::vector<StageTime> take_stage_times() { return std::exchange(times_, {}); }

  ExecCounters counters;  // exec.h: counted as CudaExec counts them

  // Tests of the callers' exception guarantees: the fail_after-th call
  // (0-based) of allocate or parallel_for from now throws, naming it; -1 none.
  int64_t fail_after = -1;

 private:
  void injected_failure(const char* what) {
    if (fail_after >= 0 && fail_after-- == 0)
      throw std::runtime_error(std::string("HostExec: injected failure in ") + what);
  }

  std::vector<StageTime> times_;
};

}  // namespace cdsm::exec
