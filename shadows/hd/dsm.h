// Deep shadow map storage and lookup (DESIGN.md §3 and §2.5; thesis §4.2,
// eq. 3.7, 4.18-4.19). One interface, three layouts chosen at run time:
//
//   packed  per texel {offset, count} into a node pool allocated exactly
//           (tile-local prefix sum, one reservation per tile); binary search.
//   fixed   thesis §4.2.1, the "3D texture": res x res x L node slots, L
//           fixed, a texel's L slots consecutive (layer fastest); its nodes
//           first, then pads; no per-texel header; binary search over all L
//           slots.
//   chunked thesis §4.2.2: chunks of C node slots, filled by the texels of
//           an 8x8 tile; every node links to its texel's next node, so a
//           lookup walks the texel's list linearly from its header.
//
// This header is the read side of all three (what the camera pass sees);
// the write sides are hd/dsm_fixed.h, hd/dsm_chunked.h and, for packed, a
// copy in the driver. The layout is a tag dispatched by a switch (STYLE.md 5).
#pragma once

#include "hd/compress.h"
#include "hd/compress_rgb.h"
#include "hd/view.h"

namespace cdsm {

// Layout tags; the values equal cdsm::DsmLayout (engine/include/cdsm/scene.h).
inline constexpr uint32_t kDsmPacked = 0u;
inline constexpr uint32_t kDsmFixed = 1u;
inline constexpr uint32_t kDsmChunked = 2u;

// Per-texel header. std430: 8 bytes.
//   packed:  the texel's nodes are nodes[offset .. offset + count).
//   chunked: offset = pool slot of the texel's first node (kChunkEnd when
//            count == 0); count = its nodes (the list's length).
//   fixed:   none (the layout has no per-texel header).
struct TexelRange {
  uint32_t offset;
  uint32_t count;
};
static_assert(sizeof(TexelRange) == 8, "TexelRange is 8 bytes");

// One slot of the chunked pool: a node and the slot of the same texel's next
// node. The thesis's C_next / L_next pair is one slot index u = C c + l
// (eq. 4.13). std430: three scalars, stride 12 (no vec3).
struct ChunkNode {
  float z;        // radial depth from the light, world units
  float alpha;    // accumulated opacity in [0, 1]
  uint32_t next;  // pool slot of the texel's next node; kChunkEnd after its last
};
static_assert(sizeof(ChunkNode) == 12, "ChunkNode is 12 bytes");
static_assert(alignof(ChunkNode) == 4, "ChunkNode is three scalars");
inline constexpr uint32_t kChunkEnd = 0xffffffffu;

// The chunked slot of an RGB map. std430: five scalars, stride 20.
struct ChunkNodeRgb {
  float z;
  float r, g, b;
  uint32_t next;
};
static_assert(sizeof(ChunkNodeRgb) == 20, "ChunkNodeRgb is 20 bytes");
static_assert(alignof(ChunkNodeRgb) == 4, "ChunkNodeRgb is five scalars");

// A node's slot in the chunked pool, and back (both kinds).
CDSM_HD CDSM_INLINE ChunkNode chunk_of(const DsmNode& n, uint32_t next) { return {n.z, n.alpha, next}; }
CDSM_HD CDSM_INLINE ChunkNodeRgb chunk_of(const DsmNodeRgb& n, uint32_t next) { return {n.z, n.r, n.g, n.b, next}; }
CDSM_HD CDSM_INLINE DsmNode node_of(const ChunkNode& c) { return {c.z, c.alpha}; }
CDSM_HD CDSM_INLINE DsmNodeRgb node_of(const ChunkNodeRgb& c) { return {c.z, c.r, c.g, c.b}; }

// Depth of the pads that fill a fixed-layout texel's unused slots (FLT_MAX);
// a pad's alpha repeats the texel's last alpha (0 for an empty texel), so a
// search over all L slots stops at the first pad and interpolating from the
// last node towards it gives that node's alpha exactly.
inline constexpr float kFixedPadZ = 3.402823466e+38f;

// One deep shadow map: a view from the light (a spot cone, a cube face or a
// focused cluster frustum) and where its texels live in the shared pools.
// Grey maps (scalar nodes) and RGB maps (a coloured caster among their
// members) live in separate pools of the same layout; texel_offset counts
// the texels of the map's own kind.
struct DsmMap {
  PinholeView view;       // res x res texels
  uint64_t texel_offset;  // index of the map's first texel among its kind's texels (packed,
                          // chunked: its first TexelRange; fixed: slots from texel_offset * L)
  uint32_t res;
  uint32_t rgb;           // 1: RGB nodes (DsmStorage::rgb_*), 0: scalar nodes
};
static_assert(sizeof(DsmMap) == 96, "DsmMap is 96 bytes");

// All maps' texels and nodes in one layout (views; the owner is the backend).
struct DsmStorage {
  Span<const TexelRange> texels;  // packed, chunked: per-texel headers, map by map; fixed: empty
  Span<const DsmNode> nodes;      // packed: the exact pool; fixed: `layers` slots per texel
  Span<const ChunkNode> chunks;   // chunked: the slot pool, chunk after chunk
  // The same three for RGB maps.
  Span<const TexelRange> rgb_texels;
  Span<const DsmNodeRgb> rgb_nodes;
  Span<const ChunkNodeRgb> rgb_chunks;
  uint32_t layout = kDsmPacked;   // kDsmPacked / kDsmFixed / kDsmChunked
  uint32_t layers = 0;            // fixed: L, node slots per texel
};

// ---- one texel's node list -------------------------------------------------

// First index i with nodes[i].z >= z (binary search; scalar or RGB nodes).
template <class Node>
CDSM_HD CDSM_INLINE uint32_t lower_bound_z(Span<const Node> n, float z) {
  uint32_t lo = 0, hi = uint32_t(n.size());
  while (lo < hi) {
    uint32_t mid = (lo + hi) >> 1;
    if (n[mid].z < z) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}

// alpha at z on the line between consecutive nodes a.z < z < b.z.
CDSM_HD CDSM_INLINE float alpha_between(DsmNode a, DsmNode b, float z) {
  return lerpf(a.alpha, b.alpha, (z - a.z) / (b.z - a.z));
}

// alpha(z) of one texel's visibility function: 0 before the first node, the
// last value after the last, linear between; exactly at a node depth the
// first node there (for a step: the value before it — a surface exactly at
// a step is lit by the light arriving at it). Zero-width intervals are never
// interpolated. j is the first node with z_j >= z. Scalar nodes give a
// float, RGB nodes the same rules per channel (a Vec3).
template <class Node>
CDSM_HD CDSM_INLINE auto alpha_at_index(Span<const Node> n, float z, uint32_t j) {
  using Alpha = decltype(node_alpha(n[0]));
  if (j >= n.size()) return n.size() ? node_alpha(n[n.size() - 1]) : Alpha{};
  if (n[j].z == z) return node_alpha(n[j]);
  if (j == 0) return Alpha{};
  return Alpha(alpha_between(n[j - 1], n[j], z));
}

template <class Node>
CDSM_HD CDSM_INLINE auto lookup_alpha(Span<const Node> n, float z) {
  return alpha_at_index(n, z, lower_bound_z(n, z));
}

// alpha just after z (the right limit): after a step at z, its upper value.
CDSM_HD CDSM_INLINE float alpha_after(Span<const DsmNode> n, float z) {
  uint32_t lo = 0, hi = uint32_t(n.size());  // first node with z_j > z
  while (lo < hi) {
    uint32_t mid = (lo + hi) >> 1;
    if (n[mid].z <= z) lo = mid + 1;
    else hi = mid;
  }
  if (lo == 0) return 0.0f;
  if (lo == n.size() || n[lo - 1].z == z) return n[lo - 1].alpha;
  return alpha_between(n[lo - 1], n[lo], z);
}

// sup over z of |f(z) - g(z)| for two node lists: both are piecewise
// linear with breakpoints at their nodes, so the largest difference of the
// values before (lookup_alpha) or after (alpha_after) some node's depth.
CDSM_HD inline float max_change(Span<const DsmNode> f, Span<const DsmNode> g) {
  float worst = 0.0f;
  for (int list = 0; list < 2; ++list) {
    Span<const DsmNode> n = list == 0 ? f : g;
    for (uint64_t i = 0; i < n.size(); ++i) {
      float z = n[i].z;
      worst = fmaxf(worst, fabsf(lookup_alpha(f, z) - lookup_alpha(g, z)));
      worst = fmaxf(worst, fabsf(alpha_after(f, z) - alpha_after(g, z)));
    }
  }
  return worst;
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

// The same function read from a chunked texel: a linear walk along the
// texel's links (the thesis's layout allows no binary search). Same
// arithmetic as alpha_at_index, so the layouts agree bit for bit. Scalar
// (ChunkNode) or RGB (ChunkNodeRgb) pools.
template <class Chunk>
CDSM_HD CDSM_INLINE auto lookup_alpha_chunked(Span<const Chunk> pool, TexelRange head, float z) {
  using Node = decltype(node_of(pool[0]));
  using Alpha = decltype(node_alpha(Node{}));
  Node prev{};
  uint32_t slot = head.offset;
  for (uint32_t i = 0; i < head.count; ++i) {
    const Chunk c = pool[slot];
    if (c.z >= z) {
      if (c.z == z) return node_alpha(node_of(c));
      if (i == 0) return Alpha{};
      return Alpha(alpha_between(prev, node_of(c), z));
    }
    prev = node_of(c);
    slot = c.next;
  }
  return node_alpha(prev);  // beyond the last node; 0 for an empty texel
}

// ---- a texel of a map, any layout -------------------------------------------

CDSM_HD CDSM_INLINE uint64_t texel_index(const DsmMap& m, int tx, int ty) {
  return m.texel_offset + uint64_t(ty) * m.res + uint64_t(tx);
}

// The L slots of a fixed-layout texel (nodes, then pads).
CDSM_HD CDSM_INLINE Span<const DsmNode> fixed_slots(const DsmStorage& st, uint64_t texel) {
  return st.nodes.subspan(texel * st.layers, st.layers);
}

// A texel's nodes as one contiguous span: packed and fixed only (fixed: all
// L slots, pads included — lookups on it are exact).
CDSM_HD CDSM_INLINE Span<const DsmNode> texel_nodes(const DsmStorage& st, const DsmMap& m, int tx,
                                                    int ty) {
  CDSM_HD_ASSERT(st.layout != kDsmChunked);
  uint64_t t = texel_index(m, tx, ty);
  if (st.layout == kDsmFixed) return fixed_slots(st, t);
  TexelRange r = st.texels[t];
  return st.nodes.subspan(r.offset, r.count);
}

// alpha(z) of texel (tx, ty) of map m.
CDSM_HD CDSM_INLINE float texel_alpha(const DsmStorage& st, const DsmMap& m, int tx, int ty, float z) {
  uint64_t t = texel_index(m, tx, ty);
  switch (st.layout) {
    case kDsmFixed:
      return lookup_alpha(fixed_slots(st, t), z);
    case kDsmChunked:
      return lookup_alpha_chunked(st.chunks, st.texels[t], z);
    default: {
      TexelRange r = st.texels[t];
      return lookup_alpha(st.nodes.subspan(r.offset, r.count), z);
    }
  }
}

// Copies texel (tx, ty)'s nodes (pads excluded) to out[0 .. min(count, cap))
// and returns the texel's node count, in any layout (tests, CPU/GPU parity).
CDSM_HD inline uint32_t read_texel(const DsmStorage& st, const DsmMap& m, int tx, int ty, DsmNode* out,
                                   uint32_t cap) {
  uint64_t t = texel_index(m, tx, ty);
  if (st.layout == kDsmChunked) {
    TexelRange h = st.texels[t];
    uint32_t slot = h.offset;
    for (uint32_t i = 0; i < h.count; ++i) {
      ChunkNode c = st.chunks[slot];
      if (i < cap) out[i] = DsmNode{c.z, c.alpha};
      slot = c.next;
    }
    return h.count;
  }
  Span<const DsmNode> n = texel_nodes(st, m, tx, ty);
  uint32_t count = st.layout == kDsmFixed ? lower_bound_z(n, kFixedPadZ) : uint32_t(n.size());
  for (uint32_t i = 0; i < count && i < cap; ++i) out[i] = n[i];
  return count;
}

// The taps of a lookup at light-space position (u, v) in texels: the
// bilinear taps (thesis eq. 4.18-4.19) with their weights, or the nearest
// texel (weight 1) when filtering is off; taps outside the map are skipped
// (they count as alpha = 0). f(tx, ty, weight).
template <class F>
CDSM_HD CDSM_INLINE void for_each_tap(const DsmMap& m, float u, float v, bool filtering, F&& f) {
  int res = int(m.res);
  if (!filtering) {
    int tx = int(floorf(u)), ty = int(floorf(v));
    if (tx < 0 || ty < 0 || tx >= res || ty >= res) return;
    f(tx, ty, 1.0f);
    return;
  }
  float lx = u - 0.5f, ly = v - 0.5f;
  float fx = floorf(lx), fy = floorf(ly);
  float wx = lx - fx, wy = ly - fy;
  int x0 = int(fx), y0 = int(fy);
  for (int k = 0; k < 4; ++k) {
    int tx = x0 + (k & 1), ty = y0 + (k >> 1);
    float w = ((k & 1) ? wx : 1.0f - wx) * ((k >> 1) ? wy : 1.0f - wy);
    if (w <= 0.0f || tx < 0 || ty < 0 || tx >= res || ty >= res) continue;
    f(tx, ty, w);
  }
}

// alpha at light-space position (u, v) in texels, radial depth z (every tap
// at the same depth).
CDSM_HD CDSM_INLINE float lookup_map(const DsmStorage& st, const DsmMap& m, float u, float v, float z,
                                     bool filtering) {
  float acc = 0.0f;
  for_each_tap(m, u, v, filtering, [&](int tx, int ty, float w) { acc += w * texel_alpha(st, m, tx, ty, z); });
  return acc;
}

// ---- RGB maps: the same functions per channel --------------------------------
// Every channel reads exactly as a scalar map would (alpha_at_index and
// lookup_alpha_chunked above are written for both kinds), so a grey RGB map
// reads what its scalar map reads.

CDSM_HD CDSM_INLINE Vec3 alpha_between(const DsmNodeRgb& a, const DsmNodeRgb& b, float z) {
  const float w = (z - a.z) / (b.z - a.z);
  return {lerpf(a.r, b.r, w), lerpf(a.g, b.g, w), lerpf(a.b, b.b, w)};
}

// alpha just after z, per channel (hd/dsm.h alpha_after).
CDSM_HD inline Vec3 alpha_after(Span<const DsmNodeRgb> n, float z) {
  uint32_t lo = 0, hi = uint32_t(n.size());
  while (lo < hi) {
    uint32_t mid = (lo + hi) >> 1;
    if (n[mid].z <= z) lo = mid + 1;
    else hi = mid;
  }
  if (lo == 0) return Vec3{0, 0, 0};
  if (lo == n.size() || n[lo - 1].z == z) return rgb_of(n[lo - 1]);
  return alpha_between(n[lo - 1], n[lo], z);
}

// sup over z and channels of |f_k(z) - g_k(z)|.
CDSM_HD inline float max_change(Span<const DsmNodeRgb> f, Span<const DsmNodeRgb> g) {
  float worst = 0.0f;
  for (int list = 0; list < 2; ++list) {
    Span<const DsmNodeRgb> n = list == 0 ? f : g;
    for (uint64_t i = 0; i < n.size(); ++i) {
      const float z = n[i].z;
      const Vec3 d0 = lookup_alpha(f, z) - lookup_alpha(g, z), d1 = alpha_after(f, z) - alpha_after(g, z);
      worst = fmaxf(worst, fmaxf(max_channel(vmax(d0, -d0)), max_channel(vmax(d1, -d1))));
    }
  }
  return worst;
}

// alpha(z) of texel (tx, ty) of map m per channel: RGB maps channel by
// channel, grey maps their one value in every channel.
CDSM_HD CDSM_INLINE Vec3 texel_alpha_rgb(const DsmStorage& st, const DsmMap& m, int tx, int ty, float z) {
  if (m.rgb == 0u) return vec3(texel_alpha(st, m, tx, ty, z));
  const uint64_t t = texel_index(m, tx, ty);
  switch (st.layout) {
    case kDsmFixed:
      return lookup_alpha(st.rgb_nodes.subspan(t * st.layers, st.layers), z);
    case kDsmChunked:
      return lookup_alpha_chunked(st.rgb_chunks, st.rgb_texels[t], z);
    default: {
      const TexelRange r = st.rgb_texels[t];
      return lookup_alpha(st.rgb_nodes.subspan(r.offset, r.count), z);
    }
  }
}

// Copies texel (tx, ty)'s nodes of an RGB map (pads excluded) like read_texel.
CDSM_HD inline uint32_t read_texel_rgb(const DsmStorage& st, const DsmMap& m, int tx, int ty, DsmNodeRgb* out,
                                       uint32_t cap) {
  const uint64_t t = texel_index(m, tx, ty);
  if (st.layout == kDsmChunked) {
    const TexelRange h = st.rgb_texels[t];
    uint32_t slot = h.offset;
    for (uint32_t i = 0; i < h.count; ++i) {
      const ChunkNodeRgb c = st.rgb_chunks[slot];
      if (i < cap) out[i] = node_of(c);
      slot = c.next;
    }
    return h.count;
  }
  Span<const DsmNodeRgb> n;
  uint32_t count;
  if (st.layout == kDsmFixed) {
    n = st.rgb_nodes.subspan(t * st.layers, st.layers);
    count = lower_bound_z(n, kFixedPadZ);
  } else {
    const TexelRange r = st.rgb_texels[t];
    n = st.rgb_nodes.subspan(r.offset, r.count);
    count = r.count;
  }
  for (uint32_t i = 0; i < count && i < cap; ++i) out[i] = n[i];
  return count;
}

// alpha per channel at light-space position (u, v), radial depth z.
CDSM_HD CDSM_INLINE Vec3 lookup_map_rgb(const DsmStorage& st, const DsmMap& m, float u, float v, float z,
                                        bool filtering) {
  Vec3 acc{0, 0, 0};
  for_each_tap(m, u, v, filtering, [&](int tx, int ty, float w) { acc = acc + texel_alpha_rgb(st, m, tx, ty, z) * w; });
  return acc;
}

}  // namespace cdsm
