// Exclusive prefix sum of uint32 values on the GPU (compute shaders,
// content/shaders/prefix_sum.comp): blocks of 1024 values are scanned by one
// workgroup each, the block totals are scanned recursively (1024^k values
// in k levels: 16.7M values = 4096^2 take three), then added back.
#pragma once

#include <cstdint>
#include <vector>

#include "gl/context.h"
#include "gl/gl_objects.h"

namespace cdsm::gl {

class PrefixSum {
 public:
  // Compiles the programs; `context` must be current.
  explicit PrefixSum(Context& context);

  // out[i] = in[0] + ... + in[i-1] for i < n, and out[n] = total (so `out`
  // holds n + 1 values). `in` and `out` may not be the same buffer. Issues
  // the needed memory barriers before and after. Scratch buffers are kept
  // and only grow.
  void exclusive_scan(const Buffer& in, Buffer& out, uint64_t n);

  // Whether the last scan's total did not fit in 32 bits (reads 4 bytes back).
  bool overflowed();
  // The same flag (0: the total fits) copied into value `at` of `out` on the
  // GPU, no read-back: a caller that reads `out` back anyway learns it with
  // the same read (the fragment rasterizer's offsets: out[n + 1]).
  void write_overflow_flag(Buffer& out, uint64_t at);

  static constexpr uint64_t kBlock = 1024;  // values per workgroup (256 threads x 4)

  // Drops every GL name without deleting it (its context is not current).
  void forget() noexcept;

 private:
  void dispatch_blocks(uint64_t blocks);

  Context& context_;
  Program scan_;
  Program add_;
  std::vector<Buffer> levels_;  // levels_[l]: block sums of level l (scanned in place)
  Buffer status_;
};

}  // namespace cdsm::gl
