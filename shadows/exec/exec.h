// Executors (STYLE.md 1; pbrt-v4's ParallelFor): the per-texel and
// per-pixel work of shadows/hd/ runs through one
//
//   ex.parallel_for("name", n, CDSM_LAMBDA(uint64_t i) { ... });
//
// on CPU threads (HostExec, shadows/exec/host_exec.h) or as a CUDA launch
// (CudaExec, cuda/launch.cuh). Everything written over an executor — the
// two-pass light pass, the camera pass, the ray-cast fragment producer and
// the backend of shadows/exec/exec_backend.h — is the same code for both;
// only where memory lives and how a launch starts differ.
//
// An executor Ex provides:
//   static constexpr bool kHostMemory;  // its memory is host memory (readable by the host)
//   static constexpr uint64_t kLightPassBatchBytes;  // the light pass's walk buffers per batch (exec/light_pass.h)
//   static constexpr bool kGlInterop;   // it can write GL buffers in place; then also
//     bool gl_context_on_device() const;  // the current GL context shares its memory
//     void write_gl_buffers(const GlMapWrite* w, int n, const void* const* src);  // src[array] + offset -> buffer
//     template <class F> void with_gl_buffer(unsigned name, uint64_t bytes, uint64_t generation, F f);  // f(mapped)
//     template <class F> void with_gl_source(int slot, unsigned name, uint64_t bytes, uint64_t generation, F f);
//     // f(mapped, read-only); slot 0 the rasterizer's pool, 1 its offsets
//   void* allocate(size_t bytes);       // 256-byte aligned; throws on failure
//   void release(void* p) noexcept;
//   template <class F> void parallel_for(const char* name, uint64_t n, F f);  // f(i) for i in [0, n)
//   void upload(void* dst, const void* src, size_t bytes);    // host -> executor (src reusable on return)
//   void download(void* dst, const void* src, size_t bytes);  // executor -> host, complete on return
//   ExecCounters counters;             // what it was asked so far (below)
//   void copy(void* dst, const void* src, size_t bytes);      // executor -> executor, in stream order
//   void fill_zero(void* dst, size_t bytes);
//   void synchronize();
//   // Milliseconds per launch name since the last call (CUDA events on the device, the wall clock on threads).
//   std::vector<StageTime> take_stage_times();
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "cdsm/config.h"
#include "hd/bits.h"
#include "hd/span.h"

namespace cdsm::exec {

// Time spent in the launches of one name.
struct StageTime {
  std::string name;
  double ms = 0.0;
  uint64_t launches = 0;
};

// What an executor was asked to do so far, counted alike on CPU threads and
// on the device: HostExec counts a download() as the synchronization it is
// on CUDA, so a test on CPU threads checks a frame's structure (how often the
// host waits, allocates, launches) as the GPU would run it.
struct ExecCounters {
  uint64_t bytes_up = 0;     // host -> executor bytes (upload)
  uint64_t bytes_down = 0;   // executor -> host bytes (download)
  uint64_t syncs = 0;        // the host waited for the executor (synchronize(), download(), blocking event reads)
  uint64_t allocations = 0;  // allocate() calls
  uint64_t launches = 0;     // parallel_for calls over a non-empty range

  ExecCounters since(const ExecCounters& before) const {
    return {bytes_up - before.bytes_up, bytes_down - before.bytes_down, syncs - before.syncs,
            allocations - before.allocations, launches - before.launches};
  }
};

// Adds `ms` to the entry `name` of `times` (in first-seen order).
inline void add_stage_time(std::vector<StageTime>& times, const char* name, double ms) {
  for (StageTime& t : times)
    if (t.name == name) {
      t.ms += ms;
      ++t.launches;
      return;
    }
  times.push_back({name, ms, 1});
}

// ---- atomics usable on both sides --------------------------------------------

CDSM_HD CDSM_INLINE uint32_t atomic_add(uint32_t* p, uint32_t v) {
#if defined(__CUDA_ARCH__)
  return atomicAdd(p, v);
#else
  return __atomic_fetch_add(p, v, __ATOMIC_RELAXED);
#endif
}

CDSM_HD CDSM_INLINE unsigned long long atomic_add(unsigned long long* p, unsigned long long v) {
#if defined(__CUDA_ARCH__)
  return atomicAdd(p, v);
#else
  return __atomic_fetch_add(p, v, __ATOMIC_RELAXED);
#endif
}

// Reads first and writes only a larger value: many threads offering values
// below the maximum share the line instead of taking turns writing it.
CDSM_HD CDSM_INLINE void atomic_max(uint32_t* p, uint32_t v) {
#if defined(__CUDA_ARCH__)
  if (v > *static_cast<volatile uint32_t*>(p)) atomicMax(p, v);
#else
  uint32_t cur = __atomic_load_n(p, __ATOMIC_RELAXED);
  while (cur < v && !__atomic_compare_exchange_n(p, &cur, v, true, __ATOMIC_RELAXED, __ATOMIC_RELAXED)) {
  }
#endif
}

// ---- memory ----------------------------------------------------------------

// An array in an executor's memory: an owner that cannot be copied (only
// moved), released with its executor (STYLE.md 6). resize() keeps the
// contents and grows the capacity by at least half, so appending maps to a
// store costs amortized copies; resize_discard() does not keep them.
template <class T, class Ex>
class ExecArray {
  static_assert(std::is_trivially_copyable<T>::value, "executor arrays hold plain structs");

 public:
  explicit ExecArray(Ex& ex) : ex_(&ex) {}
  ~ExecArray() { reset(); }
  ExecArray(const ExecArray&) = delete;
  ExecArray& operator=(const ExecArray&) = delete;
  ExecArray(ExecArray&& o) noexcept : ex_(o.ex_), ptr_(o.ptr_), size_(o.size_), capacity_(o.capacity_) {
    o.ptr_ = nullptr;
    o.size_ = o.capacity_ = 0;
  }
  ExecArray& operator=(ExecArray&& o) noexcept {
    if (this != &o) {
      reset();
      ex_ = o.ex_;
      ptr_ = o.ptr_;
      size_ = o.size_;
      capacity_ = o.capacity_;
      o.ptr_ = nullptr;
      o.size_ = o.capacity_ = 0;
    }
    return *this;
  }

  T* data() const { return ptr_; }
  uint64_t size() const { return size_; }
  uint64_t capacity() const { return capacity_; }
  uint64_t bytes() const { return size_ * sizeof(T); }
  Span<T> span() const { return {ptr_, size_}; }
  Span<const T> cspan() const { return {ptr_, size_}; }

  void resize(uint64_t n) { grow(n, true); }
  void resize_discard(uint64_t n) { grow(n, false); }
  // The capacity cut to the size (the memory given back; the contents kept).
  void shrink_to_fit() {
    if (capacity_ == size_) return;
    if (size_ == 0) {
      reset();
      return;
    }
    T* p = static_cast<T*>(ex_->allocate(size_t(size_ * sizeof(T))));
    try {
      ex_->copy(p, ptr_, size_t(size_ * sizeof(T)));
    } catch (...) {
      ex_->release(p);
      throw;
    }
    ex_->release(ptr_);
    ptr_ = p;
    capacity_ = size_;
  }
  // Releases the memory (size and capacity 0).
  void reset() noexcept {
    if (ptr_) ex_->release(ptr_);
    ptr_ = nullptr;
    size_ = capacity_ = 0;
  }
  // Host data in (size n).
  void assign(const T* src, uint64_t n) {
    resize_discard(n);
    if (n) ex_->upload(ptr_, src, n * sizeof(T));
  }
  void assign(const std::vector<T>& v) { assign(v.data(), v.size()); }
  // Host data into entries [at, at + n) (within the size).
  void write(uint64_t at, const T* src, uint64_t n) {
    if (at + n > size_) throw std::out_of_range("ExecArray::write past the array's end");
    if (n) ex_->upload(ptr_ + at, src, n * sizeof(T));
  }
  // Back to the host.
  void read(std::vector<T>& out) const {
    out.resize(size_);
    if (size_) ex_->download(out.data(), ptr_, bytes());
  }

 private:
  void grow(uint64_t n, bool keep) {
    if (n > capacity_) {
      uint64_t cap = capacity_ + capacity_ / 2;
      if (cap < n) cap = n;
      T* p = static_cast<T*>(ex_->allocate(size_t(cap * sizeof(T))));
      if (keep && size_) {
        try {
          ex_->copy(p, ptr_, size_t(size_ * sizeof(T)));
        } catch (...) {
          ex_->release(p);
          throw;
        }
      }
      if (ptr_) ex_->release(ptr_);
      ptr_ = p;
      capacity_ = cap;
    }
    size_ = n;
  }

  Ex* ex_;
  T* ptr_ = nullptr;
  uint64_t size_ = 0;
  uint64_t capacity_ = 0;
};

}  // namespace cdsm::exec
