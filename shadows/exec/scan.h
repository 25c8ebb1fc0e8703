// An exclusive prefix sum over an executor (shadows/exec/exec.h), written
// once with parallel_for: chunk sums, a serial scan of the chunk sums, then
// each chunk's own scan. Used for the fragment producer's offsets. (CUB's
// device scan was the first choice; its kernels alone made ptxas take over
// ten minutes for one architecture.)
#pragma once

#include <stdexcept>

#include "exec/exec.h"

namespace cdsm::exec {

inline constexpr uint64_t kScanChunk = 1024;

// out[i] = in[0] + ... + in[i-1] for i < n, and the total at *total in
// executor memory (not read: several scans' totals can come back in one
// read). `sums` holds the chunk sums (resized here). in and out must not
// overlap.
template <class Ex>
void exclusive_scan_to(Ex& ex, const uint32_t* in, uint32_t* out, uint64_t n, ExecArray<unsigned long long, Ex>& sums,
                       unsigned long long* total) {
  const uint64_t chunks = (n + kScanChunk - 1) / kScanChunk;
  sums.resize_discard(chunks + 1);
  unsigned long long* s = sums.data();
  ex.parallel_for(
      "scan: chunk sums", chunks, CDSM_LAMBDA(uint64_t c) {
        const uint64_t end = (c + 1) * kScanChunk < n ? (c + 1) * kScanChunk : n;
        unsigned long long t = 0;
        for (uint64_t i = c * kScanChunk; i < end; ++i) t += in[i];
        s[c] = t;
      });
  ex.parallel_for(
      "scan: chunk offsets", 1, CDSM_LAMBDA(uint64_t) {
        unsigned long long run = 0;
        for (uint64_t c = 0; c < chunks; ++c) {
          const unsigned long long t = s[c];
          s[c] = run;
          run += t;
        }
        s[chunks] = run;
        *total = run;
      });
  ex.parallel_for(
      "scan: chunks", chunks, CDSM_LAMBDA(uint64_t c) {
        const uint64_t end = (c + 1) * kScanChunk < n ? (c + 1) * kScanChunk : n;
        unsigned long long run = s[c];
        for (uint64_t i = c * kScanChunk; i < end; ++i) {
          out[i] = uint32_t(run);
          run += in[i];
        }
      });
}

// exclusive_scan_to, the total read back (one host synchronization).
template <class Ex>
uint64_t exclusive_scan(Ex& ex, const uint32_t* in, uint32_t* out, uint64_t n,
                        ExecArray<unsigned long long, Ex>& sums) {
  if (n == 0) return 0;
  const uint64_t chunks = (n + kScanChunk - 1) / kScanChunk;
  sums.resize_discard(chunks + 1);
  exclusive_scan_to(ex, in, out, n, sums, sums.data() + chunks);
  unsigned long long total = 0;
  ex.download(&total, sums.data() + chunks, sizeof total);
  return total;
}

// out[i] = in[i] + shift (modulo 2^32) for i < n: a band of offsets
// scanned elsewhere (the GL rasterizer's batch) re-based onto its view's
// lists. in and out may not overlap.
template <class Ex>
void shifted_copy(Ex& ex, const uint32_t* in, uint32_t* out, uint64_t n, uint32_t shift) {
  ex.parallel_for(
      "lists: offsets from GL", n, CDSM_LAMBDA(uint64_t i) { out[i] = in[i] + shift; });
}

}  // namespace cdsm::exec
