// A map's blocker pyramid (shadows/hd/blocker_pyramid.h) recomputed from
// its texels: the tests' one check that every cell the light pass built is
// the least opacity depth of its square.
#pragma once

#include <algorithm>
#include <string>

#include "hd/blocker_pyramid.h"

namespace cdsm_test {

// How many of map m's pyramid cells in `st` are not their texels' least
// opacity depth, and the first of them (level, cell, value, expected).
struct PyramidMismatch {
  int wrong = 0;
  std::string first;
};

template <int N>
PyramidMismatch pyramid_mismatch_of(const cdsm::DsmStorage& st, const cdsm::DsmMap& m) {
  using namespace cdsm;
  const NodeArrays<N> a = st.arrays<N>();
  const uint32_t w = m.res, h = uint32_t(m.view.height);
  PyramidMismatch out;
  for (int k = 1; k <= pyramid_top(w, h); ++k) {
    const PyramidLevel l = pyramid_level(m, k);
    for (uint32_t cy = 0; cy < l.h; ++cy)
      for (uint32_t cx = 0; cx < l.w; ++cx) {
        float least = kNoOpacityDepth;
        for (uint32_t y = cy << k; y < ((cy + 1) << k) && y < h; ++y)
          for (uint32_t x = cx << k; x < ((cx + 1) << k) && x < w; ++x)
            least = std::min(least, texel_opacity_depth<N>(st, m, int(x), int(y)));
        const float cell = a.pyramid[l.offset + uint64_t(cy) * l.w + cx];
        if (cell == least) continue;
        if (out.wrong++ == 0)
          out.first = "level " + std::to_string(k) + " cell (" + std::to_string(cx) + ", " + std::to_string(cy) +
                      ") holds " + std::to_string(cell) + ", its texels' least opacity depth is " +
                      std::to_string(least);
      }
  }
  return out;
}

// Either node kind (m.rgb).
inline PyramidMismatch pyramid_mismatch(const cdsm::DsmStorage& st, const cdsm::DsmMap& m) {
  return m.rgb ? pyramid_mismatch_of<3>(st, m) : pyramid_mismatch_of<1>(st, m);
}

}  // namespace cdsm_test
