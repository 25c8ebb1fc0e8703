// The CUDA executor (shadows/exec/exec.h): parallel_for as a kernel launch
// of the same CDSM_LAMBDA the CPU threads run (pbrt-v4's GPU ParallelFor),
// memory in device memory, every asynchronous call on the executor's
// stream, every call checked (cuda/check.cuh), and a pair of CUDA events
// around every launch so take_stage_times() reports milliseconds per
// launch name. Faults: $CDSM_CUDA_SYNC=1 synchronizes after every launch,
// so an illegal address is reported by the launch that made it, by name;
// after a sticky error every call fails fast with its message (check.cuh).
#pragma once

#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "backend/backend.h"
#include "check.cuh"
#include "exec/exec.h"
#include "gl_interop.h"

namespace cdsm::cuda {

// The functor (a pass's parameters: views of the scene, the store, the
// settings; some hundreds of bytes) stays in the kernel's parameter space:
// __grid_constant__ lets every thread read it there instead of copying it
// to its own local memory first (sm_70 and later; every F's operator() is
// const).
template <class F>
__global__ void parallel_for_kernel(uint64_t n, const __grid_constant__ F f) {
  const uint64_t i = uint64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) f(i);
}

// Owner of a CUDA stream (non-blocking), or of one event; cannot be copied.
class Stream {
 public:
  Stream() { CDSM_CUDA_CHECK(cudaStreamCreateWithFlags(&s_, cudaStreamNonBlocking)); }
  ~Stream() {
    if (s_) CDSM_CUDA_CHECK_NOTHROW(cudaStreamDestroy(s_));
  }
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
  cudaStream_t get() const { return s_; }

 private:
  cudaStream_t s_ = nullptr;
};

class CudaExec {
 public:
  static constexpr bool kHostMemory = false;
  static constexpr uint64_t kLightPassBatchBytes = uint64_t(1)
                                                   << 30;  // exec/light_pass.h: batches that fill the device
#if defined(CDSM_HAVE_CUDA_GL)
  static constexpr bool kGlInterop = true;  // write_gl_buffers below
#else
  static constexpr bool kGlInterop = false;  // built without GL headers: no cuda/gl_interop.cu
#endif

  // Works on `device` (the caller checked it exists: cuda/device.h).
  explicit CudaExec(int device = 0) : device_(device) {
    CDSM_CUDA_CHECK(cudaSetDevice(device));
    int pools = 0;
    CDSM_CUDA_CHECK(cudaDeviceGetAttribute(&pools, cudaDevAttrMemoryPoolsSupported, device));
    async_alloc_ = pools != 0;
    if (async_alloc_) make_pool();
    stream_ = std::make_unique<Stream>();
  }
  ~CudaExec() {
    if (stream_) CDSM_CUDA_CHECK_NOTHROW(cudaStreamSynchronize(stream_->get()));
    for (Launch& l : pending_) free_events_.push_back({l.start, l.stop});
    for (auto& e : free_events_) {
      CDSM_CUDA_CHECK_NOTHROW(cudaEventDestroy(e.first));
      CDSM_CUDA_CHECK_NOTHROW(cudaEventDestroy(e.second));
    }
    // Arrays still holding pool memory (none: the backend's arrays go
    // first) defer the destruction until they are freed.
    if (pool_) CDSM_CUDA_CHECK_NOTHROW(cudaMemPoolDestroy(pool_));
  }
  CudaExec(const CudaExec&) = delete;
  CudaExec& operator=(const CudaExec&) = delete;

  cudaStream_t stream() const { return stream_->get(); }
  int device() const { return device_; }

  void* allocate(size_t bytes) {
    check_usable("allocate");
    ++counters.allocations;
    void* p = nullptr;
    if (pool_)
      CDSM_CUDA_CHECK(cudaMallocFromPoolAsync(&p, bytes ? bytes : 1, pool_, stream()));
    else if (async_alloc_)
      CDSM_CUDA_CHECK(cudaMallocAsync(&p, bytes ? bytes : 1, stream()));
    else
      CDSM_CUDA_CHECK(cudaMalloc(&p, bytes ? bytes : 1));
    return p;
  }
  void release(void* p) noexcept {
    if (!p || unusable()) return;  // the context is lost: nothing to give back
    if (async_alloc_)
      CDSM_CUDA_CHECK_NOTHROW(cudaFreeAsync(p, stream()));
    else
      CDSM_CUDA_CHECK_NOTHROW(cudaFree(p));
  }

  template <class F>
  void parallel_for(const char* name, uint64_t n, F f) {
    if (n == 0) return;
    check_usable(name);
    const int block = block_size();
    const uint64_t grid = (n + uint64_t(block) - 1) / uint64_t(block);
    if (grid > 0x7fffffffull) throw std::length_error(std::string(name) + ": too many threads for one launch");
    Launch l{name, nullptr, nullptr};
    take_events(l);
    CDSM_CUDA_CHECK(cudaEventRecord(l.start, stream()));
    note_launch(name);
    ++counters.launches;
    parallel_for_kernel<F><<<unsigned(grid), unsigned(block), 0, stream()>>>(n, f);
    const cudaError_t launched = cudaGetLastError();
    if (launched != cudaSuccess) {
      free_events_.push_back({l.start, l.stop});
      throw error_of(launched,
                     describe(launched, (std::string("launch of kernel '") + name + "'").c_str(), __FILE__, __LINE__));
    }
    CDSM_CUDA_CHECK(cudaEventRecord(l.stop, stream()));
    pending_.push_back(l);
    if (sync_every_launch()) {  // CDSM_CUDA_SYNC=1: a fault here is this kernel's
      const cudaError_t ran = cudaStreamSynchronize(stream());
      if (ran != cudaSuccess)
        throw error_of(
            ran,
            describe(ran,
                     (std::string("kernel '") + name + "' (CDSM_CUDA_SYNC=1: synchronized after its launch)").c_str(),
                     __FILE__, __LINE__));
    }
    if (pending_.size() >= 1024) fold();  // nobody asked for the times yet: keep the events bounded
  }

  // Threads per block: 128 (four warps), $CDSM_CUDA_BLOCK (32..1024, a
  // multiple of 32) to measure others. Not the occupancy API's choice: for
  // a 128-register walk it answers 512, one block per SM, and the slowest
  // light ray of a block then holds its SM.
  static int block_size() {
    static const int b = [] {
      const char* e = std::getenv("CDSM_CUDA_BLOCK");
      if (!e || !*e) return 128;
      char* end = nullptr;
      const long v = std::strtol(e, &end, 10);
      if (*end != '\0' || v < 32 || v > 1024 || v % 32 != 0)
        throw std::invalid_argument(std::string("CDSM_CUDA_BLOCK=") + e +
                                    ": threads per block must be a multiple of 32 in [32, 1024]");
      return int(v);
    }();
    return b;
  }

  void upload(void* dst, const void* src, size_t bytes) {
    check_usable("upload");
    if (bytes) CDSM_CUDA_CHECK(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyHostToDevice, stream()));
    counters.bytes_up += bytes;
  }
  void download(void* dst, const void* src, size_t bytes) {
    check_usable("download");
    if (bytes) CDSM_CUDA_CHECK(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToHost, stream()));
    synchronize();
    counters.bytes_down += bytes;
  }
  exec::ExecCounters counters;  // shadows/exec/exec.h (HostExec counts the same)
  void copy(void* dst, const void* src, size_t bytes) {
    check_usable("copy");
    if (bytes) CDSM_CUDA_CHECK(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToDevice, stream()));
  }
  void fill_zero(void* dst, size_t bytes) {
    check_usable("fill_zero");
    if (bytes) CDSM_CUDA_CHECK(cudaMemsetAsync(dst, 0, bytes, stream()));
  }

  void synchronize() {
    check_usable("synchronize");
    ++counters.syncs;
    CDSM_CUDA_CHECK(cudaStreamSynchronize(stream()));
  }

#if defined(CDSM_HAVE_CUDA_GL)
  // CUDA-GL interop for the map buffers (engine/gl/map_buffers.h through
  // ShadowBackend::write_gl_maps): whether the current GL context runs on
  // this device, and the ranges copied device to device into the GL buffers,
  // each registered once per buffer object (again when its name, size or
  // generation changed), all mapped together on the stream for the copies.
  bool gl_context_on_device() const { return cuda::gl_context_on_device_cached(device_); }
  void write_gl_buffers(const GlMapWrite* w, int n, const void* const* src) {
    check_usable("write_gl_buffers");
    if (n < 0 || n > kStorageArrays)
      throw std::invalid_argument("write_gl_buffers: at most one range per storage array");
    GlBufferLink* links[kStorageArrays] = {};
    for (int i = 0; i < n; ++i) {
      const int a = int(w[i].array);
      GlBufferLink& l = gl_links_[a];
      if (gl_generation_[a] != w[i].gl_buffer_generation) l.reset();  // a new buffer object, maybe under an old name
      gl_generation_[a] = w[i].gl_buffer_generation;
      l.bind(w[i].gl_buffer, size_t(w[i].gl_buffer_bytes), GlAccess::ReadWrite);  // tails keep what is there
      links[i] = &l;
    }
    GlMapScope mapped(links, n, stream());
    for (int i = 0; i < n; ++i) {
      size_t size = 0;
      unsigned char* dst = static_cast<unsigned char*>(mapped.pointer(i, &size));
      if (w[i].offset + w[i].bytes > size) throw std::out_of_range("write_gl_buffers: range past the mapped GL buffer");
      CDSM_CUDA_CHECK(cudaMemcpyAsync(dst + w[i].offset,
                                      static_cast<const unsigned char*>(src[int(w[i].array)]) + w[i].offset,
                                      size_t(w[i].bytes), cudaMemcpyDeviceToDevice, stream()));
    }
  }  // unmapped in stream order: GL work issued after this sees the bytes
  // f(pointer) with GL buffer `name` mapped on the stream (an image target:
  // registered write-discard once per buffer object), unmapped after.
  template <class F>
  void with_gl_buffer(unsigned name, uint64_t bytes, uint64_t generation, F&& f) {
    with_mapped("with_gl_buffer", image_link_, image_generation_, GlAccess::WriteDiscard, name, bytes, generation,
                [&](void* p) { f(p); });
  }
  // f(pointer) with GL buffer `name` mapped read-only on the stream (source
  // `slot` of the fragment rasterizer: 0 its pool, 1 its offsets; each
  // registered once per buffer object), unmapped after, in stream order: GL
  // work issued later waits for what f launched.
  template <class F>
  void with_gl_source(int slot, unsigned name, uint64_t bytes, uint64_t generation, F&& f) {
    with_mapped("with_gl_source", source_link_[slot], source_generation_[slot], GlAccess::ReadOnly, name, bytes,
                generation, [&](void* p) { f(static_cast<const void*>(p)); });
  }
  // GL buffer `name` is about to be deleted or replaced by its owner
  // (ShadowBackend::gl_buffer_released): unregistered now, while it exists;
  // the next write registers its successor.
  void gl_buffer_released(unsigned name) noexcept {
    for (GlBufferLink& l : gl_links_)
      if (l.registered() && l.name() == name) l.reset();
    if (image_link_.registered() && image_link_.name() == name) image_link_.reset();
    for (GlBufferLink& l : source_link_)
      if (l.registered() && l.name() == name) l.reset();
  }
  uint64_t gl_registrations() const {
    uint64_t r = 0;
    for (const GlBufferLink& l : gl_links_) r += l.registrations();
    return r + image_link_.registrations() + source_link_[0].registrations() + source_link_[1].registrations();
  }
#endif

  // The times of the launches that have finished, without waiting: a launch
  // still running is reported by a later call (the next frame's).
  std::vector<exec::StageTime> take_stage_times() {
    fold_finished();
    return std::exchange(folded_, {});
  }

 private:
#if defined(CDSM_HAVE_CUDA_GL)
  // `link` (re)registered for buffer `name` of this generation, mapped on
  // the stream around f(pointer).
  template <class F>
  void with_mapped(const char* what, GlBufferLink& link, uint64_t& link_generation, GlAccess access, unsigned name,
                   uint64_t bytes, uint64_t generation, F&& f) {
    check_usable(what);
    if (link_generation != generation) link.reset();  // a new buffer object, maybe under an old name
    link_generation = generation;
    link.bind(name, size_t(bytes), access);
    GlBufferLink* links[] = {&link};
    GlMapScope mapped(links, 1, stream());
    size_t size = 0;
    void* p = mapped.pointer(0, &size);
    if (size < bytes) throw std::out_of_range(std::string(what) + ": the mapped GL buffer is smaller than said");
    f(p);
  }
#endif
  struct Launch {
    const char* name;  // a string literal
    cudaEvent_t start, stop;
  };
  // Every pending launch's time into folded_ (waiting for the last), their
  // events back to the pool.
  void fold() {
    synchronize();
    fold_finished();
  }
  // The launches whose stop event has been reached, in stream order (the
  // first unfinished one ends the walk), into folded_; never waits.
  void fold_finished() {
    size_t done = 0;
    for (; done < pending_.size(); ++done) {
      Launch& l = pending_[done];
      const cudaError_t q = cudaEventQuery(l.stop);
      if (q == cudaErrorNotReady) break;
      CDSM_CUDA_CHECK(q);
      float ms = 0.0f;
      CDSM_CUDA_CHECK(cudaEventElapsedTime(&ms, l.start, l.stop));
      exec::add_stage_time(folded_, l.name, double(ms));
      free_events_.push_back({l.start, l.stop});
    }
    pending_.erase(pending_.begin(), pending_.begin() + ptrdiff_t(done));
  }

  void take_events(Launch& l) {
    if (!free_events_.empty()) {
      l.start = free_events_.back().first;
      l.stop = free_events_.back().second;
      free_events_.pop_back();
      return;
    }
    CDSM_CUDA_CHECK(cudaEventCreate(&l.start));
    const cudaError_t e = cudaEventCreate(&l.stop);
    if (e != cudaSuccess) CDSM_CUDA_CHECK_NOTHROW(cudaEventDestroy(l.start));
    CDSM_CUDA_CHECK(e);
  }

  int device_;
  bool async_alloc_ = false;
  // The executor's own stream-ordered pool, its release threshold the
  // largest value: memory freed in a frame stays mapped for the next one
  // (the device's default pool gives it back at every synchronization, so a
  // steady frame would map its buffers again), and the application's own
  // cudaMallocAsync users keep their default pool as they set it. Null
  // where the pool cannot be made: the default pool then.
  cudaMemPool_t pool_ = nullptr;
  void make_pool() noexcept {
    cudaMemPoolProps props{};
    props.allocType = cudaMemAllocationTypePinned;
    props.location.type = cudaMemLocationTypeDevice;
    props.location.id = device_;
    if (cudaMemPoolCreate(&pool_, &props) != cudaSuccess) {
      (void)cudaGetLastError();
      pool_ = nullptr;
      return;
    }
    uint64_t keep = ~uint64_t(0);
    if (cudaMemPoolSetAttribute(pool_, cudaMemPoolAttrReleaseThreshold, &keep) != cudaSuccess) {
      (void)cudaGetLastError();
      (void)cudaMemPoolDestroy(pool_);
      pool_ = nullptr;
    }
  }
  std::unique_ptr<Stream> stream_;
#if defined(CDSM_HAVE_CUDA_GL)
  GlBufferLink gl_links_[kStorageArrays];  // declared after stream_: unregistered before it is destroyed
  uint64_t gl_generation_[kStorageArrays] = {};
  GlBufferLink image_link_;  // camera_pass_to_gl's target
  uint64_t image_generation_ = 0;
  GlBufferLink source_link_[2];  // lists_from_gl's sources (the rasterizer's fragment pool, its offsets)
  uint64_t source_generation_[2] = {};
#endif
  std::vector<Launch> pending_;
  std::vector<exec::StageTime> folded_;
  std::vector<std::pair<cudaEvent_t, cudaEvent_t>> free_events_;
};

}  // namespace cdsm::cuda
