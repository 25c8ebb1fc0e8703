// An exclusive prefix sum over an executor (shadows/exec/exec.h), written
// once with parallel_for: chunk sums, a serial scan of the chunk sums, then
// each chunk's own scan. Used for the fragment producer's offsets. (CUB's
// device scan was the first choice; its kernels alone made ptxas take over
// ten minutes for one architecture.)
#pragma once

#include <stdexcept>

#include "exec/exec.h"
#include "hd/fragment.h"

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

// Lists made from a GL batch without the host reading a count
// (ShadowBackend::lists_from_gl_unchecked): one part of a view, pixels
// [first, first + count) whose batch offsets are src[at .. at + count],
// appended on the executor to the view's lists — offsets `dst`, fragments
// `frags` of `capacity` — after the fragments its earlier parts brought
// (status[0], the view's true count so far). Offsets are clamped to the
// capacity and a fragment is copied only from within the GL pool's first
// `pool_fragments` and into the capacity, so lists that did not fit stay
// within their arrays; status[1] says they did not fit (or the batch's scan
// carried out of 32 bits: src[total_at + 1]). Three launches in stream
// order; the host reads nothing.
template <class Ex>
void take_gl_part(Ex& ex, const uint32_t* src, uint64_t at, uint64_t count, uint64_t total_at, const Fragment* pool,
                  uint64_t pool_fragments, uint32_t* dst, uint64_t first, Fragment* frags, uint64_t capacity,
                  unsigned long long* status) {
  ex.parallel_for(
      "lists: offsets from GL", count + 1, CDSM_LAMBDA(uint64_t i) {
        const uint64_t v = status[0] + uint64_t(src[at + i] - src[at]);
        dst[first + i] = uint32_t(v < capacity ? v : capacity);
      });
  ex.parallel_for(
      "lists: fragments from GL", capacity < pool_fragments ? capacity : pool_fragments, CDSM_LAMBDA(uint64_t k) {
        const uint64_t from = uint64_t(src[at]) + k, to = status[0] + k;
        if (from < uint64_t(src[at + count]) && from < pool_fragments && to < capacity) frags[to] = pool[from];
      });
  ex.parallel_for(
      "lists: count from GL", 1, CDSM_LAMBDA(uint64_t) {
        const uint64_t end = src[at + count];
        status[0] += end - uint64_t(src[at]);
        if (src[total_at + 1] != 0u || end > pool_fragments || status[0] > capacity) status[1] = 1ull;
      });
}

}  // namespace cdsm::exec
