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
#include "hd/view.h"

namespace cdsm {

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
// (eq. 4.13). std430: scalars only, stride 12 (grey) or 20 (RGB; no vec3).
template <int N>
struct ChunkNodeN {
  static constexpr int kChannels = N;
  float z;            // radial depth from the light, world units
  Channels<N> alpha;  // accumulated opacity per channel, in [0, 1]
  uint32_t next;      // pool slot of the texel's next node; kChunkEnd after its last
};
using ChunkNode = ChunkNodeN<1>;
using ChunkNodeRgb = ChunkNodeN<3>;
static_assert(sizeof(ChunkNode) == 12, "ChunkNode is 12 bytes");
static_assert(alignof(ChunkNode) == 4, "ChunkNode is three scalars");
static_assert(sizeof(ChunkNodeRgb) == 20, "ChunkNodeRgb is 20 bytes");
static_assert(alignof(ChunkNodeRgb) == 4, "ChunkNodeRgb is five scalars");
inline constexpr uint32_t kChunkEnd = 0xffffffffu;

// A node's slot in the chunked pool, and back.
template <int N>
CDSM_HD CDSM_INLINE ChunkNodeN<N> chunk_of(const DsmNodeN<N>& n, uint32_t next) {
  return {n.z, n.alpha, next};
}
template <int N>
CDSM_HD CDSM_INLINE DsmNodeN<N> node_of(const ChunkNodeN<N>& c) {
  return {c.z, c.alpha};
}

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
  uint32_t rgb;  // 1: RGB nodes (DsmStorage::rgb), 0: scalar nodes
};
static_assert(sizeof(DsmMap) == 112, "DsmMap is 112 bytes");

// One node kind's arrays of a storage (views).
template <int N>
struct NodeArrays {
  Span<const TexelRange> texels;     // packed, chunked: per-texel headers, map by map; fixed: empty
  Span<const DsmNodeN<N>> nodes;     // packed: the exact pool; fixed: `layers` slots per texel
  Span<const ChunkNodeN<N>> chunks;  // chunked: the slot pool, chunk after chunk
  Span<const SurfaceTag> tags;       // per slot of nodes (packed, fixed) or chunks (chunked); empty: none
  Span<const float> pyramid;         // the maps' blocker pyramids (hd/blocker_pyramid.h); empty: none
};

// All maps' texels and nodes in one layout (views; the owner is the backend):
// the arrays of each node kind, the grey maps' and the RGB maps'.
struct DsmStorage {
  NodeArrays<1> grey;
  NodeArrays<3> rgb;
  DsmLayout layout = DsmLayout::Packed;
  uint32_t layers = 0;  // fixed: L, node slots per texel

  template <int N>
  CDSM_HD inline const NodeArrays<N>& arrays() const;  // one node kind's arrays (N = 1 grey, 3 RGB)
};
template <>
CDSM_HD inline const NodeArrays<1>& DsmStorage::arrays<1>() const {
  return grey;
}
template <>
CDSM_HD inline const NodeArrays<3>& DsmStorage::arrays<3>() const {
  return rgb;
}

// Slot i's tag (kNoSurface where the storage keeps none).
CDSM_HD CDSM_INLINE SurfaceTag tag_of(Span<const SurfaceTag> tags, uint64_t i) {
  return i < tags.size() ? tags[i] : kNoSurface;
}

// ---- one texel's node list -------------------------------------------------

// First index i with nodes[i].z >= z (binary search; scalar or RGB nodes).
template <class Node>
CDSM_HD CDSM_INLINE uint32_t lower_bound_z(Span<const Node> n, float z) {
  uint32_t lo = 0, hi = uint32_t(n.size());
  while (lo < hi) {
    uint32_t mid = (lo + hi) >> 1;
    if (n[mid].z < z)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo;
}

// alpha at z on the line between consecutive nodes a.z < z < b.z (per channel).
template <int N>
CDSM_HD CDSM_INLINE Channels<N> alpha_between(const DsmNodeN<N>& a, const DsmNodeN<N>& b, float z) {
  return lerpf(a.alpha, b.alpha, (z - a.z) / (b.z - a.z));
}

// alpha(z) of one texel's visibility function: 0 before the first node, the
// last value after the last, linear between; exactly at a node depth the
// first node there (for a step: the value before it — a surface exactly at
// a step is lit by the light arriving at it). Zero-width intervals are never
// interpolated. j is the first node with z_j >= z. Per channel.
template <int N>
CDSM_HD CDSM_INLINE Channels<N> alpha_at_index(Span<const DsmNodeN<N>> n, float z, uint32_t j) {
  if (j >= n.size()) return n.size() ? n[n.size() - 1].alpha : Channels<N>{};
  if (n[j].z == z) return n[j].alpha;
  if (j == 0) return Channels<N>{};
  return alpha_between(n[j - 1], n[j], z);
}

template <int N>
CDSM_HD CDSM_INLINE Channels<N> lookup_alpha(Span<const DsmNodeN<N>> n, float z) {
  return alpha_at_index(n, z, lower_bound_z(n, z));
}

// alpha just after z (the right limit): after a step at z, its upper value.
template <int N>
CDSM_HD CDSM_INLINE Channels<N> alpha_after(Span<const DsmNodeN<N>> n, float z) {
  uint32_t lo = 0, hi = uint32_t(n.size());  // first node with z_j > z
  while (lo < hi) {
    uint32_t mid = (lo + hi) >> 1;
    if (n[mid].z <= z)
      lo = mid + 1;
    else
      hi = mid;
  }
  if (lo == 0) return Channels<N>{};
  if (lo == n.size() || n[lo - 1].z == z) return n[lo - 1].alpha;
  return alpha_between(n[lo - 1], n[lo], z);
}

// sup over z (and channels) of |f(z) - g(z)| for two node lists: both are
// piecewise linear with breakpoints at their nodes, so the largest
// difference of the values before (lookup_alpha) or after (alpha_after)
// some node's depth.
template <int N>
CDSM_HD inline float max_change(Span<const DsmNodeN<N>> f, Span<const DsmNodeN<N>> g) {
  float worst = 0.0f;
  for (int list = 0; list < 2; ++list) {
    Span<const DsmNodeN<N>> n = list == 0 ? f : g;
    for (uint64_t i = 0; i < n.size(); ++i) {
      float z = n[i].z;
      worst = fmaxf(worst, max_channel(abs_channels(lookup_alpha(f, z) - lookup_alpha(g, z))));
      worst = fmaxf(worst, max_channel(abs_channels(alpha_after(f, z) - alpha_after(g, z))));
    }
  }
  return worst;
}

// The same, starting a galloping search at a hint (the previous sample's
// index when marching along a ray); updates the hint.
template <int N>
CDSM_HD CDSM_INLINE Channels<N> lookup_alpha_from(Span<const DsmNodeN<N>> n, float z, uint32_t& hint) {
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
// arithmetic as alpha_at_index, so the layouts agree bit for bit.
template <int N>
CDSM_HD CDSM_INLINE Channels<N> lookup_alpha_chunked(Span<const ChunkNodeN<N>> pool, TexelRange head, float z) {
  DsmNodeN<N> prev{};
  uint32_t slot = head.offset;
  for (uint32_t i = 0; i < head.count; ++i) {
    const ChunkNodeN<N> c = pool[slot];
    if (c.z >= z) {
      if (c.z == z) return c.alpha;
      if (i == 0) return Channels<N>{};
      return alpha_between(prev, node_of(c), z);
    }
    prev = node_of(c);
    slot = c.next;
  }
  return prev.alpha;  // beyond the last node; 0 for an empty texel
}

// ---- what a surface receives: its own step left out, by identity ------------
//
// DESIGN.md §8. A receiver on a surface reads a texel at depth `depth`
// (where the tap's light ray crosses its plane):
//   - its own step is the step of its object (`own`: tag_object() of it, 0
//     for none) nearest to `depth` within +-`window`, which covers the facets
//     of a curved surface and the producers' depth differences
//     (ShadowSettings' bias_constant and bias_slope size this search and
//     skip nothing else); it is left out;
//   - every other node before depth - coplanar counts (whatever the gap);
//   - within +-coplanar of depth (surfaces that touch it), another object's
//     step counts when its rank is below the receiver's (hd/compress.h
//     SurfaceRank: its own step's, an entry without one): a glass's exit
//     face resting on a slab, a decal on the ground are in front of them;
//     two coplanar tops side by side are not; media there count;
//   - nothing behind depth + coplanar counts (a medium's stretch crossing
//     it, up to it).
// The nodes that count are composited by their own layers, 1 - (1 -
// alpha_j) / (1 - alpha_{j-1}), over the alpha of the last node before
// the band or the own step (taken as it is): with nothing else at the
// receiver, exactly the alpha just before its own step.
struct TexelRead {
  float depth;     // the receiver's plane along the tap's ray
  float window;    // its own step is searched within +-window of depth
  float coplanar;  // surfaces within +-coplanar of depth touch it (<= window)
  uint32_t own;    // tag_object() of its object; 0: no step of its own (receive-only)
};

// The opacity of one more layer between alpha_prev and alpha (the node
// before and the node), per channel; 0 where nothing is left to absorb.
CDSM_HD CDSM_INLINE float layer_between(float prev, float a) {
  return 1.0f - prev > 0.0f ? 1.0f - (1.0f - a) / (1.0f - prev) : 0.0f;
}
CDSM_HD CDSM_INLINE Vec3 layer_between(Vec3 prev, Vec3 a) {
  return {layer_between(prev.x, a.x), layer_between(prev.y, a.y), layer_between(prev.z, a.z)};
}
CDSM_HD CDSM_INLINE float over_layer(float alpha, float a) { return alpha + a * (1.0f - alpha); }
CDSM_HD CDSM_INLINE Vec3 over_layer(Vec3 alpha, Vec3 a) {
  return {over_layer(alpha.x, a.x), over_layer(alpha.y, a.y), over_layer(alpha.z, a.z)};
}

// Pass 1 of a read, fed the texel's nodes in depth order from any node at
// or before depth - window: the receiver's own step.
struct OwnStepSearch {
  TexelRead r;
  uint32_t index = 0xffffffffu;  // the own step's upper node (count from the first node fed)
  float z = 0.0f, best = 0.0f;
  uint32_t rank = kRankEntry;  // the receiver's: its own step's, an entry without one
  uint32_t seen = 0;
  CDSM_HD explicit OwnStepSearch(const TexelRead& tr) : r(tr) {}
  // false once past depth + window.
  CDSM_HD bool visit(float nz, SurfaceTag tag) {
    if (nz > r.depth + r.window) return false;
    if (r.own != 0u && tag_object_of(tag) == r.own && nz >= r.depth - r.window &&
        (index == 0xffffffffu || fabsf(nz - r.depth) < best)) {
      index = seen;
      z = nz;
      best = fabsf(nz - r.depth);
      rank = tag_rank_of(tag);
    }
    ++seen;
    return true;
  }
};

// Pass 2, fed the same nodes from the same first one.
template <class Node>
struct ReceiverScan {
  using Alpha = Channels<Node::kChannels>;
  TexelRead r;
  OwnStepSearch own;
  float lo, hi;      // the band of surfaces touching the receiver
  float prefix_end;  // nodes before this are taken whole
  Node prev{};
  bool have_prev = false;
  Alpha alpha{};
  uint32_t seen = 0;

  CDSM_HD ReceiverScan(const TexelRead& tr, const OwnStepSearch& o) : r(tr), own(o) {
    lo = tr.depth - tr.coplanar;
    hi = tr.depth + tr.coplanar;
    prefix_end = own.index != 0xffffffffu ? fminf(lo, own.z) : lo;
  }

  CDSM_HD bool visit(const Node& n, SurfaceTag tag) {
    const uint32_t i = seen++;
    const Alpha a = n.alpha;
    bool counts;
    if (n.z > hi) {  // past the band: a stretch crossing its end counts up to it
      if (have_prev && prev.z < hi) alpha = over_layer(alpha, layer_between(prev.alpha, alpha_between(prev, n, hi)));
      return false;
    }
    if (n.z < prefix_end) {  // in front of everything the rules below decide: the value itself
      alpha = a;
      prev = n;
      have_prev = true;
      return true;
    }
    if (i == own.index) {
      counts = false;
    } else if (tag != kNoSurface && n.z >= lo) {  // a step touching the receiver
      counts = tag_object_of(tag) != r.own && tag_rank_of(tag) < own.rank;
    } else {
      counts = true;
    }
    if (counts) alpha = over_layer(alpha, layer_between(have_prev ? prev.alpha : Alpha{}, a));
    prev = n;
    have_prev = true;
    return true;
  }
};

// A read over a contiguous node list (packed, fixed) with its tags at
// slots first_slot + i.
template <class Node>
CDSM_HD inline auto receiver_read(Span<const Node> n, Span<const SurfaceTag> tags, uint64_t first_slot,
                                  const TexelRead& tr) {
  uint32_t from = lower_bound_z(n, fminf(tr.depth - tr.window, tr.depth - tr.coplanar));
  from = from > 0 ? from - 1 : 0;
  OwnStepSearch own(tr);
  if (tr.own != 0u)
    for (uint32_t i = from; i < n.size(); ++i)
      if (!own.visit(n[i].z, tag_of(tags, first_slot + i))) break;
  ReceiverScan<Node> scan(tr, own);
  for (uint32_t i = from; i < n.size(); ++i)
    if (!scan.visit(n[i], tag_of(tags, first_slot + i))) break;
  return scan.alpha;
}

// The same along a chunked texel's links.
template <class Chunk>
CDSM_HD inline auto receiver_read_chunked(Span<const Chunk> pool, Span<const SurfaceTag> tags, TexelRange head,
                                          const TexelRead& tr) {
  using Node = decltype(node_of(pool[0]));
  OwnStepSearch own(tr);
  uint32_t slot = head.offset;
  if (tr.own != 0u)
    for (uint32_t i = 0; i < head.count; ++i) {
      const Chunk c = pool[slot];
      if (!own.visit(c.z, tag_of(tags, slot))) break;
      slot = c.next;
    }
  ReceiverScan<Node> scan(tr, own);
  slot = head.offset;
  for (uint32_t i = 0; i < head.count; ++i) {
    const Chunk c = pool[slot];
    if (!scan.visit(node_of(c), tag_of(tags, slot))) break;
    slot = c.next;
  }
  return scan.alpha;
}

// ---- a texel of a map, any layout -------------------------------------------
// Templated on the map's node kind N (1: grey, DsmStorage's grey arrays;
// 3: RGB); texel_alpha_in_colour and friends below read either kind in colour.

CDSM_HD CDSM_INLINE uint64_t texel_index(const DsmMap& m, int tx, int ty) {
  return m.texel_offset + uint64_t(ty) * m.res + uint64_t(tx);
}

// The L slots of a fixed-layout texel (nodes, then pads).
template <int N>
CDSM_HD CDSM_INLINE Span<const DsmNodeN<N>> fixed_slots(const NodeArrays<N>& a, const DsmStorage& st, uint64_t texel) {
  return a.nodes.subspan(texel * st.layers, st.layers);
}

// A texel's nodes as one contiguous span: packed and fixed only (fixed: all
// L slots, pads included — lookups on it are exact).
template <int N>
CDSM_HD CDSM_INLINE Span<const DsmNodeN<N>> texel_nodes(const DsmStorage& st, const DsmMap& m, int tx, int ty) {
  CDSM_HD_ASSERT(st.layout != DsmLayout::Chunked);
  const NodeArrays<N> a = st.arrays<N>();
  uint64_t t = texel_index(m, tx, ty);
  if (st.layout == DsmLayout::Fixed) return fixed_slots(a, st, t);
  TexelRange r = a.texels[t];
  return a.nodes.subspan(r.offset, r.count);
}

// alpha(z) of texel (tx, ty) of map m (of node kind N).
template <int N>
CDSM_HD CDSM_INLINE Channels<N> texel_alpha(const DsmStorage& st, const DsmMap& m, int tx, int ty, float z) {
  const NodeArrays<N> a = st.arrays<N>();
  uint64_t t = texel_index(m, tx, ty);
  switch (st.layout) {
    case DsmLayout::Fixed: return lookup_alpha(fixed_slots(a, st, t), z);
    case DsmLayout::Chunked: return lookup_alpha_chunked(a.chunks, a.texels[t], z);
    default: {
      TexelRange r = a.texels[t];
      return lookup_alpha(a.nodes.subspan(r.offset, r.count), z);
    }
  }
}

// The depth of texel (tx, ty)'s first node (kFixedPadZ when it has none):
// every step of its alpha lies at or behind it.
template <int N>
CDSM_HD CDSM_INLINE float texel_first_depth(const DsmStorage& st, const DsmMap& m, int tx, int ty) {
  const NodeArrays<N> a = st.arrays<N>();
  const uint64_t t = texel_index(m, tx, ty);
  switch (st.layout) {
    case DsmLayout::Fixed: return a.nodes[t * st.layers].z;  // a pad when it has none
    case DsmLayout::Chunked: {
      const TexelRange h = a.texels[t];
      return h.count ? a.chunks[h.offset].z : kFixedPadZ;
    }
    default: {
      const TexelRange h = a.texels[t];
      return h.count ? a.nodes[h.offset].z : kFixedPadZ;
    }
  }
}

// What receiver read `tr` gives from texel (tx, ty) of map m (of kind N).
// A texel whose first node lies behind the band of surfaces touching the
// receiver holds nothing for it: 0 without the read (ReceiverScan's first
// visit).
template <int N>
CDSM_HD CDSM_INLINE Channels<N> texel_receive(const DsmStorage& st, const DsmMap& m, int tx, int ty,
                                              const TexelRead& tr) {
  const NodeArrays<N> a = st.arrays<N>();
  uint64_t t = texel_index(m, tx, ty);
  if (texel_first_depth<N>(st, m, tx, ty) > tr.depth + tr.coplanar) return Channels<N>{};
  switch (st.layout) {
    case DsmLayout::Fixed: return receiver_read(fixed_slots(a, st, t), a.tags, t * st.layers, tr);
    case DsmLayout::Chunked: return receiver_read_chunked(a.chunks, a.tags, a.texels[t], tr);
    default: {
      TexelRange r = a.texels[t];
      return receiver_read(a.nodes.subspan(r.offset, r.count), a.tags, r.offset, tr);
    }
  }
}

// Copies texel (tx, ty)'s nodes (pads excluded) to out[0 .. min(count, cap))
// and their tags to out_tags (when not null), and returns the texel's node
// count, in any layout (tests, inspection, CPU/GPU parity). `out` may be
// null with cap 0 (only the count).
template <int N>
CDSM_HD inline uint32_t read_texel(const DsmStorage& st, const DsmMap& m, int tx, int ty, DsmNodeN<N>* out,
                                   uint32_t cap, SurfaceTag* out_tags = nullptr) {
  const NodeArrays<N> a = st.arrays<N>();
  uint64_t t = texel_index(m, tx, ty);
  if (st.layout == DsmLayout::Chunked) {
    TexelRange h = a.texels[t];
    uint32_t slot = h.offset;
    for (uint32_t i = 0; i < h.count; ++i) {
      const ChunkNodeN<N> c = a.chunks[slot];
      if (i < cap) out[i] = node_of(c);
      if (i < cap && out_tags) out_tags[i] = tag_of(a.tags, slot);
      slot = c.next;
    }
    return h.count;
  }
  Span<const DsmNodeN<N>> n = texel_nodes<N>(st, m, tx, ty);
  uint32_t count = st.layout == DsmLayout::Fixed ? lower_bound_z(n, kFixedPadZ) : uint32_t(n.size());
  const uint64_t first = st.layout == DsmLayout::Fixed ? t * st.layers : uint64_t(a.texels[t].offset);
  for (uint32_t i = 0; i < count && i < cap; ++i) {
    out[i] = n[i];
    if (out_tags) out_tags[i] = tag_of(a.tags, first + i);
  }
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
    int tx = floor_int(u), ty = floor_int(v);
    if (tx < 0 || ty < 0 || tx >= res || ty >= res) return;
    f(tx, ty, 1.0f);
    return;
  }
  float lx = u - 0.5f, ly = v - 0.5f;
  int x0 = floor_int(lx), y0 = floor_int(ly);
  float wx = lx - float(x0), wy = ly - float(y0);
  for (int k = 0; k < 4; ++k) {
    int tx = x0 + (k & 1), ty = y0 + (k >> 1);
    float w = ((k & 1) ? wx : 1.0f - wx) * ((k >> 1) ? wy : 1.0f - wy);
    if (w <= 0.0f || tx < 0 || ty < 0 || tx >= res || ty >= res) continue;
    f(tx, ty, w);
  }
}

// alpha at light-space position (u, v) in texels, radial depth z (every tap
// at the same depth), of a map of kind N.
template <int N>
CDSM_HD CDSM_INLINE Channels<N> lookup_map(const DsmStorage& st, const DsmMap& m, float u, float v, float z,
                                           bool filtering) {
  Channels<N> acc{};
  for_each_tap(m, u, v, filtering, [&](int tx, int ty, float w) { acc = acc + texel_alpha<N>(st, m, tx, ty, z) * w; });
  return acc;
}

// ---- either kind in colour -----------------------------------------------------
// A grey map's one value in every channel; a grey RGB map reads what its
// scalar map reads (every function above is the same arithmetic per channel).

CDSM_HD CDSM_INLINE Vec3 texel_alpha_in_colour(const DsmStorage& st, const DsmMap& m, int tx, int ty, float z) {
  return m.rgb ? texel_alpha<3>(st, m, tx, ty, z) : to_rgb(texel_alpha<1>(st, m, tx, ty, z));
}
CDSM_HD CDSM_INLINE Vec3 texel_receive_in_colour(const DsmStorage& st, const DsmMap& m, int tx, int ty,
                                                 const TexelRead& tr) {
  return m.rgb ? texel_receive<3>(st, m, tx, ty, tr) : to_rgb(texel_receive<1>(st, m, tx, ty, tr));
}
// A texel's node count, either kind.
CDSM_HD CDSM_INLINE uint32_t texel_node_count(const DsmStorage& st, const DsmMap& m, int tx, int ty) {
  return m.rgb ? read_texel<3>(st, m, tx, ty, nullptr, 0) : read_texel<1>(st, m, tx, ty, nullptr, 0);
}

}  // namespace cdsm
