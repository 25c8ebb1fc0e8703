// The light pass over an executor (shadows/exec/exec.h): one map into one
// of the three layouts (DESIGN.md §3), the same algorithm on CPU threads
// and on a GPU. Each texel's light ray is walked once, into a small buffer
// of K nodes; only a texel with more nodes than that buffer holds is walked
// again, into the large buffer that re-compresses beyond its bound:
//
//   1. walk     per texel of a batch of tile rows: build_texel into its own
//               buffer of K = LightPassOptions::walk_nodes (64) nodes and
//               their tags, no removal (hd/compress.h stop_when_full); a
//               texel that would need more is listed for step 2;
//   2. rewalk   the listed texels only, in chunks, each into a buffer of
//               max_nodes (1024) nodes with the removal heap (where a long
//               ray is re-compressed, the error bound recorded); each
//               reserves exactly its node count in the pool with one atomic
//               add and writes its nodes there;
//   3. reserve  per 8x8 tile of the batch: a tile-local prefix sum over its
//               other texels and one atomic reservation of their total;
//   4. copy     those texels' nodes from their walk buffers into the pool;
//   5. layout   packed: the pool is the store's; fixed and chunked: the
//               pool is a staging array that write_fixed_texel /
//               write_chunked_tile turn into the layout.
//
// A texel's nodes are those of one walk into a buffer of max_nodes nodes
// whatever K is: a texel that fits node_limit(K) nodes never removes any,
// in either buffer. So the executors agree by construction, and K only
// trades the walk buffers' memory (batch texels x K x 10 bytes, at most
// LightPassOptions::batch_bytes) against texels walked twice. Measured on
// the shipped scenes: none has a texel over 18 nodes (the default K = 64:
// 0 texels walked again).
#pragma once

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

#include "exec/exec.h"
#include "exec/light_pass_options.h"
#include "hd/blocker_pyramid.h"
#include "hd/dsm_chunked.h"
#include "hd/dsm_fixed.h"
#include "hd/light_pass.h"
#include "hd/map_build.h"

namespace cdsm::exec {

// Counters of one build, accumulated in executor memory.
struct BuildCounters {
  unsigned long long nodes;         // node slots reserved in the pool (cumulative over the batches)
  unsigned long long chunks;        // chunked: chunks reserved
  unsigned long long stored;        // fixed: nodes stored in the layout (packed, chunked: `nodes`)
  uint32_t spilled;                 // this batch: texels listed for the second walk
  uint32_t rewalked;                // texels walked twice (the map)
  uint32_t layout_overflow_texels;  // fixed: re-compressed to fit L
  uint32_t recompressed_texels;     // by the large buffer's bound or the layout (DsmBuildStats::overflow_texels)
  uint32_t max_nodes;               // stored, per texel
  uint32_t max_built_nodes;         // per texel, before the layout
  uint32_t max_extra_error_bits;    // float bits of the largest error re-compression added
  uint32_t walk[4];                 // WalkStats: enclosing, match, unmatched, lengthened
};

// Per node kind (DsmNodeN<N>): the chunk slot, the bounded buffer and its
// memory. A bounded buffer of K nodes in executor memory: the nodes, (with
// `heap`) the removal heap's six arrays, then the nodes' tags;
// buffer_bytes() long, a multiple of 16 so buffers can follow each other.
template <class Node>
struct NodeKind {
  static constexpr int N = Node::kChannels;
  using Chunk = ChunkNodeN<N>;
  using Buffer = NodeBufferN<N>;
  using Visitor = DsmVisitorOf<Buffer>;
  static constexpr size_t heap_bytes_per_slot = 4 * sizeof(uint32_t) + 2 * sizeof(float);
  static CDSM_HD uint64_t buffer_bytes(int k, bool heap) {
    const uint64_t b = uint64_t(k) * (sizeof(Node) + (heap ? heap_bytes_per_slot : 0) + sizeof(SurfaceTag));
    return (b + 15) & ~uint64_t(15);
  }
  static CDSM_HD Buffer buffer(unsigned char* p, int k, bool heap) {
    Buffer b{reinterpret_cast<Node*>(p), k};
    unsigned char* after = p + size_t(k) * sizeof(Node);
    if (heap) {
      uint32_t* w = reinterpret_cast<uint32_t*>(after);
      float* f = reinterpret_cast<float*>(w + 4 * size_t(k));
      b.scratch = RemovalScratch{w, w + k, w + 2 * k, w + 3 * k, f, f + k};
      after += size_t(k) * heap_bytes_per_slot;
    }
    b.tags = reinterpret_cast<SurfaceTag*>(after);
    return b;
  }
};

// One node kind's arrays of a map store in executor memory.
template <class Node, class Ex>
struct KindStore {
  using Chunk = typename NodeKind<Node>::Chunk;
  explicit KindStore(Ex& ex) : texels(ex), nodes(ex), chunks(ex), tags(ex), pyramid(ex) {}
  ExecArray<TexelRange, Ex> texels;  // packed, chunked: headers, map by map
  ExecArray<Node, Ex> nodes;         // packed: exact pool; fixed: L slots per texel
  ExecArray<Chunk, Ex> chunks;       // chunked: the slot pool
  ExecArray<SurfaceTag, Ex> tags;    // per slot of `nodes` (packed, fixed) or of `chunks` (chunked)
  ExecArray<float, Ex> pyramid;      // the maps' blocker pyramids (hd/blocker_pyramid.h); empty: no map has one
  uint64_t texel_count = 0;          // this kind's texels (fixed keeps no headers)

  // The arrays as the lookups read them (views of executor memory).
  NodeArrays<Node::kChannels> arrays() const {
    return {texels.cspan(), nodes.cspan(), chunks.cspan(), tags.cspan(), pyramid.cspan()};
  }
};

// Working memory of the light pass, kept across builds (it only grows).
template <class Ex>
struct LightPassScratch {
  explicit LightPassScratch(Ex& ex)
      : counts(ex),
        spilled(ex),
        extra(ex),
        heads(ex),
        tile_first(ex),
        staging(ex),
        staging_tags(ex),
        walk(ex),
        spill(ex),
        spill_texels(ex),
        counters(ex),
        inside(ex) {}
  ExecArray<uint32_t, Ex> counts;          // per texel of the map: its nodes before the layout
  ExecArray<uint32_t, Ex> spilled;         // per texel of the map: 1 walked again, 2 and re-compressed
  ExecArray<float, Ex> extra;              // per texel of the map: error the large buffer's bound added
  ExecArray<TexelRange, Ex> heads;         // fixed, chunked: each texel's nodes in `staging`
  ExecArray<uint32_t, Ex> tile_first;      // chunked: each tile's first chunk (relative to the map's)
  ExecArray<unsigned char, Ex> staging;    // fixed, chunked: the packed nodes the layout is written from
  ExecArray<SurfaceTag, Ex> staging_tags;  // their tags
  ExecArray<unsigned char, Ex> walk;       // the first walk's buffers of one batch
  ExecArray<unsigned char, Ex> spill;      // the second walk's buffers of one chunk
  ExecArray<uint32_t, Ex> spill_texels;    // the batch's texels listed for the second walk
  ExecArray<BuildCounters, Ex> counters;
  ExecArray<uint32_t, Ex> inside;  // the objects containing the light (over device memory)
};

// Nodes a baseline texel can hold at once (hd/baselines.h): a first walk
// into this many never needs a second.
inline int baseline_capacity(ShadowMethod method, float param) {
  const int bound = baseline_node_bound(method, param);
  int cap = bound + 2 < 4 ? 4 : bound + 2;
  while (node_limit(cap) < bound + 1) ++cap;
  return cap;
}

inline void check_u32_total(uint64_t v, const char* what) {
  if (v > std::numeric_limits<uint32_t>::max())
    throw std::length_error(std::string("DSM ") + what + " exceed 2^32 entries");
}

// The per-texel walks of the light pass. Each walk is its own functor, so
// its own kernel on a GPU holding one walker: the first walk of a deep
// shadow map (the DSM visitor into a small buffer), the first walk of a
// baseline (its builder), the second walk (the DSM visitor into the large
// buffer with the removal heap). Their shared state:
template <class Node>
struct TexelWalks {
  using Kind = NodeKind<Node>;
  SceneView scene;
  LightPassParams params;
  FragmentLists frags;
  int res = 0, height = 0, tiles_x = 0;
  int K = 0;                  // the buffer's nodes
  uint64_t first = 0;         // first walks: the batch's first tile; second: the chunk's first listed texel
  bool layout_counts = true;  // packed and chunked store the nodes as built (fixed counts in its own pass)
  uint64_t pool_base = 0;     // the pool's nodes before this map (packed: the store's)
  uint32_t* counts = nullptr;
  uint32_t* spilled = nullptr;  // per texel: 0, 1 walked again, 2 walked again and re-compressed
  float* extra = nullptr;
  TexelRange* heads = nullptr;
  BuildCounters* ctr = nullptr;
  unsigned char* buffers = nullptr;  // first walks: the batch's; second: the chunk's
  uint64_t slot_bytes = 0;
  uint32_t* spill_texels = nullptr;
  Node* pool = nullptr;  // second walk: the pool (its capacity holds the chunk's worst case)
  SurfaceTag* pool_tags = nullptr;

  // Texel k of the batch whose first tile is `tile0`, in tile order (64
  // texels an 8x8 tile: neighbouring rays walk together, in a warp on a
  // GPU); false past the map's edge.
  CDSM_HD bool batch_texel(uint64_t tile0, uint64_t k, int& tx, int& ty) const {
    const uint64_t tile = tile0 + k / uint64_t(kDsmTile * kDsmTile);
    const int j = int(k % uint64_t(kDsmTile * kDsmTile));
    tx = int(tile % uint64_t(tiles_x)) * kDsmTile + j % kDsmTile;
    ty = int(tile / uint64_t(tiles_x)) * kDsmTile + j / kDsmTile;
    return tx < res && ty < height;
  }

  CDSM_HD void add_walk(const WalkStats& st) const {
    if (st.enclosing_overflow) atomic_add(&ctr->walk[0], st.enclosing_overflow);
    if (st.match_overflow) atomic_add(&ctr->walk[1], st.match_overflow);
    if (st.unmatched) atomic_add(&ctr->walk[2], st.unmatched);
    if (st.march_lengthened) atomic_add(&ctr->walk[3], st.march_lengthened);
  }

  // After a first walk of texel i into `buf`: its count, or listed for the second walk.
  template <class Buffer>
  CDSM_HD void first_done(uint64_t i, const Buffer& buf, const WalkStats& st) const {
    add_walk(st);  // (a texel walked twice counts its walk once)
    if (buf.removed > 0) {
      spilled[i] = 1u;
      spill_texels[atomic_add(&ctr->spilled, 1u)] = uint32_t(i);
      return;
    }
    // (no per-texel sums here: an atomic add on one counter from every
    // thread costs more than the walk of an empty texel; the nodes stored
    // are the pool's reservations)
    counts[i] = uint32_t(buf.count);
    atomic_max(&ctr->max_built_nodes, uint32_t(buf.count));
    if (layout_counts) atomic_max(&ctr->max_nodes, uint32_t(buf.count));
  }
};

// First walk of a deep shadow map's texel into its buffer of K nodes.
template <class Node>
struct FirstWalk {
  TexelWalks<Node> w;
  CDSM_HD void operator()(uint64_t idx) const {
    int tx, ty;
    if (!w.batch_texel(w.first, idx, tx, ty)) return;
    auto buf = NodeKind<Node>::buffer(w.buffers + idx * w.slot_bytes, w.K, false);
    buf.stop_when_full = true;
    WalkStats st;
    walk_texel<typename NodeKind<Node>::Visitor>(w.scene, w.params, w.frags.pixel(tx, ty), tx, ty, buf, st);
    w.first_done(uint64_t(ty) * uint64_t(w.res) + uint64_t(tx), buf, st);
  }
};

// First walk of a baseline's texel (hd/baselines.h: grey, its node count
// bounded by its parameter: never walked twice).
struct BaselineWalk {
  TexelWalks<DsmNode> w;
  CDSM_HD void operator()(uint64_t idx) const {
    int tx, ty;
    if (!w.batch_texel(w.first, idx, tx, ty)) return;
    NodeBuffer buf = NodeKind<DsmNode>::buffer(w.buffers + idx * w.slot_bytes, w.K, false);
    buf.stop_when_full = true;
    WalkStats st;
    const Vec3 d = pixel_ray(w.params.view, tx, ty);
    const float t_end = w.params.view.far / fmaxf(dot(d, w.params.view.forward), 1e-6f);
    build_baseline_texel(w.scene, w.params.method, w.params.method_param, w.params.layer_thickness, w.params.inside,
                         w.frags.pixel(tx, ty), pixel_origin(w.params.view, tx, ty), d, t_end, buf, st);
    w.first_done(uint64_t(ty) * uint64_t(w.res) + uint64_t(tx), buf, st);
  }
};

// Second walk of a listed texel into the large buffer (either kind removes
// through the heap: one overflow policy), reserved exactly in the pool and
// written there.
template <class Node>
struct SecondWalk {
  TexelWalks<Node> w;
  CDSM_HD void operator()(uint64_t idx) const {
    const uint64_t i = w.spill_texels[w.first + idx];
    const int tx = int(i % uint64_t(w.res)), ty = int(i / uint64_t(w.res));
    auto buf = NodeKind<Node>::buffer(w.buffers + idx * w.slot_bytes, w.K, true);
    WalkStats st;
    build_texel(w.scene, w.params, w.frags.pixel(tx, ty), tx, ty, buf, st);
    const uint32_t n = uint32_t(buf.count);
    const bool recompressed = buf.removed > 0;
    w.counts[i] = n;
    w.extra[i] = buf.extra_error;
    w.spilled[i] = recompressed ? 2u : 1u;
    const uint32_t at = uint32_t(w.pool_base + atomic_add(&w.ctr->nodes, (unsigned long long)n));
    w.heads[i] = TexelRange{at, n};
    for (uint32_t j = 0; j < n; ++j) {
      w.pool[at + j] = buf.nodes[j];
      w.pool_tags[at + j] = buf.tags[j];
    }
    atomic_add(&w.ctr->rewalked, 1u);
    atomic_max(&w.ctr->max_built_nodes, n);
    if (w.layout_counts) {
      atomic_max(&w.ctr->max_nodes, n);
      if (recompressed) {
        atomic_add(&w.ctr->recompressed_texels, 1u);
        atomic_max(&w.ctr->max_extra_error_bits, float_bits(buf.extra_error));
      }
    }
  }
};

// The blocker pyramid of `map`, the last map of `out` (hd/blocker_pyramid.h),
// when `wanted` and the map is large enough to have one; its bytes. The
// kind's array covers every map once one has a pyramid: the slots it
// grows by are marked unknown (-kNoOpacityDepth: every search goes on),
// so a map without a pyramid reads as one. Launches of four levels each, a
// thread per cell of the group's top level building the block under it:
// levels 1-4 from the texels, 5-8 from level 4, ... (a 512^2 map: 3).
template <class Node, class Ex>
uint64_t build_blocker_pyramid(Ex& ex, KindStore<Node, Ex>& out, const DsmMap& map, DsmLayout layout, uint32_t layers,
                               bool wanted) {
  constexpr int N = Node::kChannels;
  const uint32_t w = map.res, h = uint32_t(map.view.height);
  const bool build = wanted && pyramid_cells(w, h) <= uint64_t(w) * h / 2u;
  if (out.pyramid.size() == 0 && !build) return 0;
  const uint64_t before = out.pyramid.size();
  out.pyramid.resize(pyramid_array_size(out.texel_count));
  float* cells = out.pyramid.data();
  ex.parallel_for(
      "light pass: blocker pyramid slots", out.pyramid.size() - before,
      CDSM_LAMBDA(uint64_t i) { cells[before + i] = -kNoOpacityDepth; });
  if (!build) return 0;
  const int top = pyramid_top(w, h);
  DsmStorage st;
  st.layout = layout;
  st.layers = layout == DsmLayout::Fixed ? layers : 0u;
  if constexpr (N == 3)
    st.rgb = out.arrays();
  else
    st.grey = out.arrays();
  const DsmMap m = map;
  for (int first = 1; first <= top; first += 4) {
    const int last = first + 3 < top ? first + 3 : top;
    const PyramidLevel l = pyramid_level(map, last);
    const uint32_t lw = l.w;
    ex.parallel_for(
        "light pass: blocker pyramid", uint64_t(l.w) * l.h, CDSM_LAMBDA(uint64_t i) {
          build_pyramid_block<N>(st, m, cells, first, last, uint32_t(i % lw), uint32_t(i / lw));
        });
  }
  return pyramid_cells(w, h) * sizeof(float);
}

// Builds one map from its light-view fragment lists (exec memory; sorted in
// place) into `out` in `layout`. `scene`, `params.inside` and `frags` are
// spans in executor memory. The map's header goes to `map`.
template <class Node, class Ex>
DsmBuildStats build_map_exec(Ex& ex, const SceneView& scene, const LightPassParams& params, FragmentLists frags,
                             const DsmLayoutParams& layout, const LightPassOptions& opt, KindStore<Node, Ex>& out,
                             DsmMap& map, LightPassScratch<Ex>& s) {
  using Kind = NodeKind<Node>;
  using Chunk = typename Kind::Chunk;
  const DsmLayout kind = layout.layout;
  const int res = params.view.width, height = params.view.height;
  const int tiles_x = (res + kDsmTile - 1) / kDsmTile, tiles_y = (height + kDsmTile - 1) / kDsmTile;
  const uint64_t n_texels = uint64_t(res) * uint64_t(height);
  const uint64_t n_tiles = uint64_t(tiles_x) * uint64_t(tiles_y);
  const uint32_t L = uint32_t(layout.fixed_layers), C = uint32_t(layout.chunk_nodes);
  const bool baseline = params.method != ShadowMethod::Dsm;
  const int K = baseline ? baseline_capacity(params.method, params.method_param) : opt.walk_nodes;
  const int K2 = opt.max_nodes;
  if (K < 4 || K2 < K)
    throw std::invalid_argument("light pass: the walk buffers must hold >= 4 nodes, the second >= the first");

  map = DsmMap{};
  map.view = params.view;
  map.res = uint32_t(res);
  map.rgb = params.rgb ? 1u : 0u;
  map.texel_offset = out.texel_count;

  s.counts.resize_discard(n_texels);
  s.spilled.resize_discard(n_texels);
  s.extra.resize_discard(n_texels);
  s.counters.resize_discard(1);
  ex.fill_zero(s.spilled.data(), s.spilled.bytes());
  ex.fill_zero(s.extra.data(), s.extra.bytes());
  ex.fill_zero(s.counters.data(), s.counters.bytes());
  uint32_t* counts = s.counts.data();
  uint32_t* spilled = s.spilled.data();
  float* extra = s.extra.data();
  BuildCounters* ctr = s.counters.data();

  // The pool the walks write: packed, the store's nodes; fixed and chunked,
  // the staging array. Headers: packed, the store's; else the scratch's.
  const uint64_t pool_base = kind == DsmLayout::Packed ? out.nodes.size() : 0;
  if (kind != DsmLayout::Fixed) out.texels.resize(out.texels.size() + n_texels);
  if (kind != DsmLayout::Packed) {
    s.heads.resize_discard(n_texels);
    s.staging.resize_discard(0);
    s.staging_tags.resize_discard(0);
  }
  TexelRange* heads = kind == DsmLayout::Packed ? out.texels.data() + map.texel_offset : s.heads.data();
  uint64_t pool_used = 0;  // nodes reserved in the pool so far (beyond pool_base)
  // The pool grown to hold `nodes` beyond pool_base (contents kept).
  const auto pool_size = [&](uint64_t nodes) {
    if (kind == DsmLayout::Packed) {
      check_u32_total(pool_base + nodes, "nodes");
      out.nodes.resize(pool_base + nodes);
      out.tags.resize(pool_base + nodes);
    } else {
      check_u32_total(nodes, "staged nodes");
      s.staging.resize(nodes * sizeof(Node));
      s.staging_tags.resize(nodes);
    }
  };
  const auto pool_nodes = [&]() -> Node* {
    return kind == DsmLayout::Packed ? out.nodes.data() : reinterpret_cast<Node*>(s.staging.data());
  };
  const auto pool_tags = [&]() -> SurfaceTag* {
    return kind == DsmLayout::Packed ? out.tags.data() : s.staging_tags.data();
  };

  TexelWalks<Node> work;
  work.scene = scene;
  work.params = params;
  work.frags = frags;
  work.res = res;
  work.height = height;
  work.tiles_x = tiles_x;
  work.layout_counts = kind != DsmLayout::Fixed;
  work.pool_base = pool_base;
  work.counts = counts;
  work.spilled = spilled;
  work.extra = extra;
  work.heads = heads;
  work.ctr = ctr;

  const uint64_t walk_bytes = Kind::buffer_bytes(K, false);
  const uint64_t rewalk_bytes = Kind::buffer_bytes(K2, true);
  const uint64_t row_texels = uint64_t(tiles_x) * kDsmTile * kDsmTile;  // a row of tiles, its edge included
  const uint64_t batch_bytes = opt.batch_bytes ? opt.batch_bytes : Ex::kLightPassBatchBytes;
  const uint64_t rows_per_batch = std::max<uint64_t>(1, batch_bytes / std::max<uint64_t>(1, row_texels * walk_bytes));
  const uint64_t chunk_texels = std::max<uint64_t>(1, batch_bytes / rewalk_bytes);
  BuildCounters c{};
  for (int row0 = 0; row0 < tiles_y; row0 += int(rows_per_batch)) {
    const int row1 = std::min<int>(tiles_y, row0 + int(rows_per_batch));
    const uint64_t tile0 = uint64_t(row0) * uint64_t(tiles_x), tiles = uint64_t(row1 - row0) * uint64_t(tiles_x);
    const uint64_t batch = tiles * uint64_t(kDsmTile * kDsmTile);  // texels, tile by tile (the map's edge included)
    // 1. walk
    s.walk.resize_discard(batch * walk_bytes);
    s.spill_texels.resize_discard(batch);
    ex.fill_zero(&ctr->spilled, sizeof(uint32_t));
    work.K = K;
    work.first = tile0;
    work.buffers = s.walk.data();
    work.slot_bytes = walk_bytes;
    work.spill_texels = s.spill_texels.data();
    if constexpr (sizeof(Node) == sizeof(DsmNode)) {
      if (baseline)
        ex.parallel_for("light pass: walk (baseline)", batch, BaselineWalk{work});
      else
        ex.parallel_for("light pass: walk", batch, FirstWalk<Node>{work});
    } else {
      ex.parallel_for("light pass: walk", batch, FirstWalk<Node>{work});
    }
    ex.download(&c, ctr, sizeof c);
    // 2. rewalk the listed texels, a chunk at a time, into the pool.
    if (c.spilled > 0) {
      work.K = K2;
      work.slot_bytes = rewalk_bytes;
      for (uint64_t f = 0; f < c.spilled; f += chunk_texels) {
        const uint64_t n = std::min<uint64_t>(chunk_texels, c.spilled - f);
        s.spill.resize_discard(n * rewalk_bytes);
        pool_size(pool_used + n * uint64_t(node_limit(K2)));  // the chunk's worst case; trimmed below
        work.first = f;
        work.buffers = s.spill.data();
        work.pool = pool_nodes();
        work.pool_tags = pool_tags();
        ex.parallel_for("light pass: walk again", n, SecondWalk<Node>{work});
        ex.download(&c, ctr, sizeof c);
        pool_used = c.nodes;
      }
    }
    // 3. reserve the tiles' other texels.
    ex.parallel_for(
        "light pass: reserve tiles", tiles, CDSM_LAMBDA(uint64_t k) {
          const uint64_t tile = tile0 + k;
          const int x0 = int(tile % uint64_t(tiles_x)) * kDsmTile, y0 = int(tile / uint64_t(tiles_x)) * kDsmTile;
          uint32_t total = 0;
          for (int j = 0; j < kDsmTile * kDsmTile; ++j) {
            const int tx = x0 + j % kDsmTile, ty = y0 + j / kDsmTile;
            const uint64_t t = uint64_t(ty) * res + tx;
            if (tx < res && ty < height && spilled[t] == 0u) total += counts[t];
          }
          uint64_t at = pool_base + atomic_add(&ctr->nodes, (unsigned long long)total);
          for (int j = 0; j < kDsmTile * kDsmTile; ++j) {
            const int tx = x0 + j % kDsmTile, ty = y0 + j / kDsmTile;
            const uint64_t t = uint64_t(ty) * res + tx;
            if (tx >= res || ty >= height || spilled[t] != 0u) continue;
            heads[t] = TexelRange{uint32_t(at), counts[t]};
            at += counts[t];
          }
        });
    ex.download(&c, ctr, sizeof c);
    pool_used = c.nodes;
    pool_size(pool_used);
    // 4. copy the walked texels' nodes.
    Node* pn = pool_nodes();
    SurfaceTag* pt = pool_tags();
    const unsigned char* walk_mem = s.walk.data();
    const TexelWalks<Node> at = work;
    ex.parallel_for(
        "light pass: copy", batch, CDSM_LAMBDA(uint64_t k) {
          int tx, ty;
          if (!at.batch_texel(tile0, k, tx, ty)) return;
          const uint64_t t = uint64_t(ty) * uint64_t(res) + uint64_t(tx);
          if (spilled[t] != 0u) return;
          const TexelRange h = heads[t];
          const auto buf = Kind::buffer(const_cast<unsigned char*>(walk_mem) + k * walk_bytes, K, false);
          for (uint32_t j = 0; j < h.count; ++j) {
            pn[h.offset + j] = buf.nodes[j];
            pt[h.offset + j] = buf.tags[j];
          }
        });
  }
  const uint64_t total = pool_used;

  // 5. the layout.
  if (kind == DsmLayout::Fixed) {
    const uint64_t first_slot = out.nodes.size();
    out.nodes.resize(first_slot + n_texels * L);
    out.tags.resize(out.nodes.size());
    Node* slots = out.nodes.data() + first_slot;
    SurfaceTag* slot_tags = out.tags.data() + first_slot;
    const float eps = params.epsilon;
    const Node* staging = reinterpret_cast<const Node*>(s.staging.data());
    const SurfaceTag* staging_tags = s.staging_tags.data();
    ex.parallel_for(
        "light pass: fixed layout", n_texels, CDSM_LAMBDA(uint64_t i) {
          const TexelRange h = heads[i];
          FixedFit fit = write_fixed_texel(Span<const Node>{staging + h.offset, h.count}, staging_tags + h.offset, eps,
                                           slots + i * L, slot_tags + i * L, int(L));
          counts[i] = uint32_t(fit.count);  // summed per tile below
          atomic_max(&ctr->max_nodes, uint32_t(fit.count));
          if (fit.recompressed) atomic_add(&ctr->layout_overflow_texels, 1u);
          if (fit.recompressed || spilled[i] == 2u) {
            atomic_add(&ctr->recompressed_texels, 1u);
            atomic_max(&ctr->max_extra_error_bits, float_bits(extra[i] + fit.extra_error));
          }
        });
    ex.parallel_for(
        "light pass: count stored", n_tiles, CDSM_LAMBDA(uint64_t tile) {
          const int x0 = int(tile % uint64_t(tiles_x)) * kDsmTile, y0 = int(tile / uint64_t(tiles_x)) * kDsmTile;
          unsigned long long n = 0;
          for (int j = 0; j < kDsmTile * kDsmTile; ++j) {
            const int tx = x0 + j % kDsmTile, ty = y0 + j / kDsmTile;
            if (tx < res && ty < height) n += counts[uint64_t(ty) * res + tx];
          }
          if (n) atomic_add(&ctr->stored, n);
        });
  } else if (kind == DsmLayout::Chunked) {
    // Each tile reserves the chunks of all its nodes (Alg. 4.1, hd/dsm_chunked.h).
    s.tile_first.resize_discard(n_tiles);
    uint32_t* tile_first = s.tile_first.data();
    ex.parallel_for(
        "light pass: reserve chunks", n_tiles, CDSM_LAMBDA(uint64_t tile) {
          const int x0 = int(tile % uint64_t(tiles_x)) * kDsmTile, y0 = int(tile / uint64_t(tiles_x)) * kDsmTile;
          uint32_t n = 0;
          for (int j = 0; j < kDsmTile * kDsmTile; ++j) {
            const int tx = x0 + j % kDsmTile, ty = y0 + j / kDsmTile;
            if (tx < res && ty < height) n += counts[uint64_t(ty) * res + tx];
          }
          tile_first[tile] = uint32_t(atomic_add(&ctr->chunks, (unsigned long long)tile_chunks(n, C)));
        });
    ex.download(&c, ctr, sizeof c);
    const uint64_t chunk_base = out.chunks.size();  // slots
    check_u32_total(chunk_base + c.chunks * C, "chunk slots");
    out.chunks.resize(chunk_base + c.chunks * C);
    out.tags.resize(out.chunks.size());
    Chunk* pool = out.chunks.data();
    SurfaceTag* chunk_tags = out.tags.data();
    TexelRange* store_heads = out.texels.data() + map.texel_offset;
    const Node* staging = reinterpret_cast<const Node*>(s.staging.data());
    const SurfaceTag* staging_tags = s.staging_tags.data();
    // A thread per texel (write_chunked_texel: the tile writer's slots).
    ex.parallel_for(
        "light pass: chunked layout", n_tiles * kChunkTileTexels, CDSM_LAMBDA(uint64_t idx) {
          const uint64_t tile = idx / kChunkTileTexels;
          const int k = int(idx % kChunkTileTexels);
          const int x0 = int(tile % uint64_t(tiles_x)) * kDsmTile, y0 = int(tile / uint64_t(tiles_x)) * kDsmTile;
          uint32_t tile_counts[kChunkTileTexels];
          for (int j = 0; j < kChunkTileTexels; ++j) {
            const int tx = x0 + j % kDsmTile, ty = y0 + j / kDsmTile;
            tile_counts[j] = tx < res && ty < height ? heads[uint64_t(ty) * res + tx].count : 0u;
          }
          const int tx = x0 + k % kDsmTile, ty = y0 + k / kDsmTile;
          const bool in = tx < res && ty < height;
          const uint64_t t = in ? uint64_t(ty) * res + tx : 0;
          const uint32_t at = in ? heads[t].offset : 0u;
          TexelRange head;
          write_chunked_texel(tile_counts, kChunkTileTexels, k, staging + at, staging_tags + at,
                              uint32_t(chunk_base + uint64_t(tile_first[tile]) * C), C, pool, chunk_tags, head);
          if (in) store_heads[t] = head;
        });
  }
  out.texel_count += n_texels;

  ex.download(&c, ctr, sizeof c);
  DsmBuildStats stats;
  stats.layout = kind;
  stats.rgb = params.rgb;
  stats.texels = n_texels;
  stats.nodes = kind == DsmLayout::Fixed ? c.stored : c.nodes;  // packed, chunked: every node reserved is stored
  stats.max_nodes = c.max_nodes;
  stats.max_built_nodes = c.max_built_nodes;
  stats.overflow_texels = c.recompressed_texels;
  stats.layout_overflow_texels = c.layout_overflow_texels;
  stats.rewalked_texels = c.rewalked;
  stats.max_extra_error = bits_float(c.max_extra_error_bits);
  stats.walk.enclosing_overflow = c.walk[0];
  stats.walk.match_overflow = c.walk[1];
  stats.walk.unmatched = c.walk[2];
  stats.walk.march_lengthened = c.walk[3];
  switch (kind) {
    case DsmLayout::Fixed:
      stats.node_bytes_allocated = n_texels * L * sizeof(Node);
      stats.node_bytes_used = stats.nodes * sizeof(Node);
      stats.tag_bytes = n_texels * L * sizeof(SurfaceTag);
      break;
    case DsmLayout::Chunked:
      stats.chunks = c.chunks;
      stats.index_bytes = n_texels * sizeof(TexelRange);
      stats.node_bytes_allocated = stats.chunks * C * sizeof(Chunk);
      stats.node_bytes_used = stats.nodes * sizeof(Chunk);
      stats.tag_bytes = stats.chunks * C * sizeof(SurfaceTag);
      break;
    default:
      stats.index_bytes = n_texels * sizeof(TexelRange);
      stats.node_bytes_allocated = total * sizeof(Node);
      stats.node_bytes_used = stats.nodes * sizeof(Node);
      stats.tag_bytes = total * sizeof(SurfaceTag);
  }
  stats.slack_bytes = stats.node_bytes_allocated - stats.node_bytes_used;
  stats.pyramid_bytes = build_blocker_pyramid(ex, out, map, kind, L, params.blocker_pyramid);
  return stats;
}

}  // namespace cdsm::exec
