// The blocker pyramid of a map: for every square of 2^k x 2^k texels
// (k = 1, 2, ... up to one cell over the map) the least depth in front of
// which any of its texels holds opacity, built with the map in the light
// pass (exec/light_pass.h build_blocker_pyramid) on every executor. A soft
// lookup asks it first whether its blocker search can find anything, and
// how far out (hd/lights.h blockers_within_reach): a receiver with no
// blocker within a penumbra's reach costs about a hard lookup instead of up
// to 8 kPenumbraSearchRings + 1 node walks; the search walks only the rings
// within that reach, and passes a ring texel whose cell of level 1 holds no
// blocker that could reach the receiver without reading the texel
// (blocker_search). The answers are conservative — "no" only where the
// search would count nothing — so the estimate reads the
// same, to the bit, with or without the pyramid (the GL lookup, cdsm.glsl,
// searches without one).
//
// Storage: one float array per node kind (NodeArrays::pyramid), a map's
// cells from texel_offset / 2 on (level 1 first, then 2, ...): they need
// about a third of its texel count, so each map fits the half of a slot
// its texels give it, whatever maps precede it. A map too small for that
// (under 6 x 6 texels) has no pyramid and searches as without one.
#pragma once

#include "hd/dsm.h"

namespace cdsm {

// A texel with no opacity at any depth.
inline constexpr float kNoOpacityDepth = 3.402823466e+38f;

// The cells of level k of a w x h map: ceil(w / 2^k) x ceil(h / 2^k).
struct PyramidLevel {
  uint64_t offset = 0;  // the level's first cell in the kind's array
  uint32_t w = 0, h = 0;
};

// Levels 1 .. top of a w x h map, top the first of one cell.
CDSM_HD CDSM_INLINE int pyramid_top(uint32_t w, uint32_t h) {
  int k = 1;
  while ((((w - 1u) >> k) + 1u) > 1u || (((h - 1u) >> k) + 1u) > 1u) ++k;
  return k;
}
CDSM_HD CDSM_INLINE uint64_t pyramid_cells(uint32_t w, uint32_t h) {
  uint64_t n = 0;
  for (int k = 1, top = pyramid_top(w, h); k <= top; ++k) n += uint64_t(((w - 1u) >> k) + 1u) * (((h - 1u) >> k) + 1u);
  return n;
}
// Whether map m has a pyramid in arrays `a` (the kind's array holds one,
// and the map's cells fit its slot), with its levels' first cells found in
// the same pass (a lookup's): offset[k] for k = 1 .. top, top returned; 0
// when m has none.
template <int N>
CDSM_HD CDSM_INLINE int pyramid_offsets(const NodeArrays<N>& a, const DsmMap& m, uint64_t offset[33]) {
  if (a.pyramid.size() == 0) return 0;
  const uint32_t w = m.res, h = uint32_t(m.view.height);
  const uint64_t first = m.texel_offset / 2u, half = uint64_t(w) * uint64_t(h) / 2u;
  uint64_t at = first;
  int k = 1;
  for (;; ++k) {
    const uint32_t lw = ((w - 1u) >> k) + 1u, lh = ((h - 1u) >> k) + 1u;
    offset[k] = at;
    at += uint64_t(lw) * lh;
    if (lw == 1u && lh == 1u) break;
  }
  return at - first <= half && first + half <= a.pyramid.size() ? k : 0;
}
template <int N>
CDSM_HD CDSM_INLINE bool has_pyramid(const NodeArrays<N>& a, const DsmMap& m) {
  uint64_t offset[33];
  return pyramid_offsets(a, m, offset) != 0;
}
// Level k (>= 1) of map m.
CDSM_HD CDSM_INLINE PyramidLevel pyramid_level(const DsmMap& m, int k) {
  const uint32_t w = m.res, h = uint32_t(m.view.height);
  PyramidLevel l;
  l.offset = m.texel_offset / 2u;
  for (int j = 1; j < k; ++j) l.offset += uint64_t(((w - 1u) >> j) + 1u) * (((h - 1u) >> j) + 1u);
  l.w = ((w - 1u) >> k) + 1u;
  l.h = ((h - 1u) >> k) + 1u;
  return l;
}
// The size of a kind's pyramid array for `texels` texels of maps.
CDSM_HD CDSM_INLINE uint64_t pyramid_array_size(uint64_t texels) { return texels / 2u; }

// The least depth in front of which texel (tx, ty) holds opacity (its
// alpha(z), as lookups and the blocker search interpolate it, is 0 for
// every z up to it): the node before its first with opacity (grey_of > 0),
// or that node's depth when it is the first; kNoOpacityDepth for none.
template <int N>
CDSM_HD inline float texel_opacity_depth(const DsmStorage& st, const DsmMap& m, int tx, int ty) {
  const NodeArrays<N> a = st.arrays<N>();
  const uint64_t t = texel_index(m, tx, ty);
  float prev = 0.0f;
  if (st.layout == DsmLayout::Chunked) {
    const TexelRange h = a.texels[t];
    uint32_t slot = h.offset;
    for (uint32_t i = 0; i < h.count; ++i) {
      const ChunkNodeN<N> c = a.chunks[slot];
      if (grey_of(to_rgb(c.alpha)) > 0.0f) return i == 0 ? c.z : prev;
      prev = c.z;
      slot = c.next;
    }
    return kNoOpacityDepth;
  }
  const Span<const DsmNodeN<N>> n = texel_nodes<N>(st, m, tx, ty);
  for (uint64_t i = 0; i < n.size(); ++i) {
    if (grey_of(to_rgb(n[i].alpha)) > 0.0f) return i == 0 ? n[i].z : prev;
    prev = n[i].z;
  }
  return kNoOpacityDepth;
}

// Cell (cx, cy) of level k from the level below it (texels for k = 1): the
// least of its up to four children. `cells` is the kind's pyramid array.
template <int N>
CDSM_HD inline float pyramid_cell_value(const DsmStorage& st, const DsmMap& m, const float* cells, int k, uint32_t cx,
                                        uint32_t cy) {
  float v = kNoOpacityDepth;
  if (k == 1) {
    const uint32_t w = m.res, h = uint32_t(m.view.height);
    for (uint32_t y = 2u * cy; y < 2u * cy + 2u && y < h; ++y)
      for (uint32_t x = 2u * cx; x < 2u * cx + 2u && x < w; ++x)
        v = fminf(v, texel_opacity_depth<N>(st, m, int(x), int(y)));
    return v;
  }
  const PyramidLevel below = pyramid_level(m, k - 1);
  for (uint32_t y = 2u * cy; y < 2u * cy + 2u && y < below.h; ++y)
    for (uint32_t x = 2u * cx; x < 2u * cx + 2u && x < below.w; ++x)
      v = fminf(v, cells[below.offset + uint64_t(y) * below.w + x]);
  return v;
}

// Levels first .. last of the block under cell (bx, by) of level `last`,
// bottom up (one thread of build_blocker_pyramid's launch for that group of
// levels; the levels below `first` are built).
template <int N>
CDSM_HD inline void build_pyramid_block(const DsmStorage& st, const DsmMap& m, float* cells, int first, int last,
                                        uint32_t bx, uint32_t by) {
  for (int k = first; k <= last; ++k) {
    const PyramidLevel l = pyramid_level(m, k);
    const uint32_t span = 1u << (last - k);  // this level's cells per side of the block
    for (uint32_t y = by * span; y < (by + 1u) * span && y < l.h; ++y)
      for (uint32_t x = bx * span; x < (bx + 1u) * span && x < l.w; ++x)
        cells[l.offset + uint64_t(y) * l.w + x] = pyramid_cell_value<N>(st, m, cells, k, x, y);
  }
}

}  // namespace cdsm
