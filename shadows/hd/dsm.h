// Deep shadow map storage (`packed` layout, DESIGN.md §3) and lookup
// (DESIGN.md §2.5, thesis eq. 3.7, 4.18-4.19).
#pragma once

#include "hd/compress.h"
#include "hd/view.h"

namespace cdsm {

// Per-texel header of the packed layout: the texel's nodes are
// nodes[offset .. offset+count). std430: 8 bytes.
struct TexelRange {
  uint32_t offset;
  uint32_t count;
};
static_assert(sizeof(TexelRange) == 8, "TexelRange is 8 bytes");

// One deep shadow map: a view from the light (a spot cone, a cube face or a
// focused cluster frustum) and where its texels live in the shared pools.
struct DsmMap {
  PinholeView view;       // res x res texels
  uint64_t texel_offset;  // first TexelRange of this map in DsmStorage::texels
  uint32_t res;
  uint32_t pad;
};

struct DsmStorage {
  Span<const TexelRange> texels;
  Span<const DsmNode> nodes;
};

CDSM_HD CDSM_INLINE Span<const DsmNode> texel_nodes(const DsmStorage& st, const DsmMap& m, int tx,
                                                    int ty) {
  TexelRange r = st.texels[m.texel_offset + uint64_t(ty) * m.res + uint64_t(tx)];
  return st.nodes.subspan(r.offset, r.count);
}

// First index i with nodes[i].z >= z (binary search).
CDSM_HD CDSM_INLINE uint32_t lower_bound_z(Span<const DsmNode> n, float z) {
  uint32_t lo = 0, hi = uint32_t(n.size());
  while (lo < hi) {
    uint32_t mid = (lo + hi) >> 1;
    if (n[mid].z < z) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}

// alpha(z) of one texel's visibility function: 0 before the first node, the
// last value after the last, linear between; exactly at a node depth the
// first node there (for a step: the value before it — a surface exactly at
// a step is lit by the light arriving at it). Zero-width intervals are never
// interpolated.
CDSM_HD CDSM_INLINE float alpha_at_index(Span<const DsmNode> n, float z, uint32_t j) {
  if (j >= n.size()) return n.size() ? n[n.size() - 1].alpha : 0.0f;
  if (n[j].z == z) return n[j].alpha;
  if (j == 0) return 0.0f;
  DsmNode a = n[j - 1], b = n[j];
  float w = (z - a.z) / (b.z - a.z);
  return lerpf(a.alpha, b.alpha, w);
}

CDSM_HD CDSM_INLINE float lookup_alpha(Span<const DsmNode> n, float z) {
  return alpha_at_index(n, z, lower_bound_z(n, z));
}

// The same, starting a galloping search at a hint (the previous sample's
// index when marching along a ray); updates the hint.
CDSM_HD CDSM_INLINE float lookup_alpha_from(Span<const DsmNode> n, float z, uint32_t& hint) {
  uint32_t size = uint32_t(n.size());
  uint32_t j = hint > size ? size : hint;
  if (j < size && n[j].z < z) {
    while (j < size && n[j].z < z) ++j;  // forward (usual: depth grows along a ray)
  } else {
    while (j > 0 && n[j - 1].z >= z) --j;  // backward
  }
  hint = j;
  return alpha_at_index(n, z, j);
}

// alpha at light-space position (u, v) in texels, radial depth z; taps
// outside the map count as alpha = 0. Bilinear per thesis eq. 4.18-4.19, or
// the nearest texel when filtering is off.
CDSM_HD CDSM_INLINE float lookup_map(const DsmStorage& st, const DsmMap& m, float u, float v, float z,
                                     bool filtering) {
  int res = int(m.res);
  if (!filtering) {
    int tx = int(floorf(u)), ty = int(floorf(v));
    if (tx < 0 || ty < 0 || tx >= res || ty >= res) return 0.0f;
    return lookup_alpha(texel_nodes(st, m, tx, ty), z);
  }
  float lx = u - 0.5f, ly = v - 0.5f;
  float fx = floorf(lx), fy = floorf(ly);
  float wx = lx - fx, wy = ly - fy;
  int x0 = int(fx), y0 = int(fy);
  float acc = 0.0f;
  for (int k = 0; k < 4; ++k) {
    int tx = x0 + (k & 1), ty = y0 + (k >> 1);
    float w = ((k & 1) ? wx : 1.0f - wx) * ((k >> 1) ? wy : 1.0f - wy);
    if (w <= 0.0f || tx < 0 || ty < 0 || tx >= res || ty >= res) continue;
    acc += w * lookup_alpha(texel_nodes(st, m, tx, ty), z);
  }
  return acc;
}

}  // namespace cdsm
