// In-place, bounded sort of one pixel's fragments by (depth, primitive,
// facing) — a total order, so the result is deterministic (DESIGN.md §2.2).
// Insertion sort for short lists, heap sort beyond: no recursion, no memory.
#pragma once

#include "hd/fragment.h"

namespace cdsm {

inline constexpr uint64_t kShortSort = 64;

CDSM_HD CDSM_INLINE void insertion_sort(Span<Fragment> f) {
  for (uint64_t i = 1; i < f.size(); ++i) {
    Fragment v = f[i];
    uint64_t j = i;
    while (j > 0 && frag_less(v, f[j - 1])) {
      f[j] = f[j - 1];
      --j;
    }
    f[j] = v;
  }
}

CDSM_HD CDSM_INLINE void sift_down(Span<Fragment> f, uint64_t root, uint64_t n) {
  Fragment v = f[root];
  for (;;) {
    uint64_t child = 2 * root + 1;
    if (child >= n) break;
    if (child + 1 < n && frag_less(f[child], f[child + 1])) ++child;
    if (!frag_less(v, f[child])) break;
    f[root] = f[child];
    root = child;
  }
  f[root] = v;
}

CDSM_HD CDSM_INLINE void heap_sort(Span<Fragment> f) {
  uint64_t n = f.size();
  for (uint64_t i = n / 2; i-- > 0;) sift_down(f, i, n);
  for (uint64_t end = n; end-- > 1;) {
    Fragment t = f[0];
    f[0] = f[end];
    f[end] = t;
    sift_down(f, 0, end);
  }
}

CDSM_HD CDSM_INLINE void sort_fragments(Span<Fragment> f) {
  if (f.size() <= kShortSort)
    insertion_sort(f);
  else
    heap_sort(f);
}

}  // namespace cdsm
