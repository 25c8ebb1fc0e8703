// The light pass over an executor (shadows/exec/exec.h): a frame's maps
// into one of the three layouts (DESIGN.md §3), the same algorithm on CPU
// threads and on a GPU. Each texel's light ray is walked once, into a small
// buffer of K nodes; only a texel with more nodes than that buffer holds is
// walked again, into the large buffer that re-compresses beyond its bound.
// Every map is walked before the host looks at any count, the counters of
// all of them come back in one read, then the maps are placed:
//
//   1. walk     per texel of a batch of tile rows: build_texel into its own
//               buffer of K = LightPassOptions::walk_nodes (64) nodes and
//               their tags, no removal (hd/compress.h stop_when_full); a
//               texel that would need more is listed for step 2;
//   2. rewalk   the listed texels only, each into a buffer of max_nodes
//               (1024) nodes with the removal heap (where a long ray is
//               re-compressed, the error bound recorded); each reserves
//               exactly its node count in the pool with one atomic add and
//               writes its nodes there;
//   3. reserve  per 8x8 tile of the batch: a tile-local prefix sum over its
//               other texels and one atomic reservation of their total;
//   4. copy     those texels' nodes from their walk buffers into the pool:
//               packed, the store's node array itself; fixed and chunked,
//               a staging array;
//   5. layout   fixed: write_fixed_texel from staging into the store's L
//               slots per texel (their number known beforehand); chunked:
//               each tile's chunks counted;
//   6. read     every map's counters, one download (the one host
//               synchronization of a frame that builds maps);
//   7. place    packed: the store's size set to its nodes; chunked:
//               write_chunked_tile from staging; then the blocker pyramids.
//
// The pool keeps its capacity across frames (the store's, or staging: one
// array per node kind); the maps follow each other in it, each map's first
// node set on the executor from the previous map's count. A write that
// would pass the capacity is skipped, the count still taken: when the read
// shows a map past it, the pool grows to what the counts say and the walks
// are done again from that map on (a second read: the first build, or maps
// that outgrow what the pool held before).
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
#include <vector>

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
  unsigned long long base;          // the map's first node in its kind's staging (the previous map's base + nodes)
  unsigned long long nodes;         // node slots reserved in staging (cumulative over the batches)
  unsigned long long chunks;        // chunked: chunks reserved
  unsigned long long stored;        // fixed: nodes stored in the layout (packed, chunked: `nodes`)
  uint32_t spilled;                 // this batch: texels listed for the second walk
  uint32_t spilled_total;           // the map: texels listed for the second walk
  uint32_t rewalked;                // texels walked twice (the map)
  uint32_t layout_overflow_texels;  // fixed: re-compressed to fit L
  uint32_t recompressed_texels;     // by the large buffer's bound or the layout (DsmBuildStats::overflow_texels)
  uint32_t max_nodes;               // stored, per texel
  uint32_t max_built_nodes;         // per texel, before the layout
  uint32_t max_extra_error_bits;    // float bits of the largest error re-compression added
  uint32_t walk[4];                 // WalkStats: enclosing, match, unmatched, lengthened
  // The map's lists when unchecked (MapBuildInput::lists_status), copied in
  // on the executor to come back with this read: their true count, and
  // whether they did not fit.
  unsigned long long lists_fragments;
  unsigned long long lists_short;
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
        stage_grey(ex),
        stage_rgb(ex),
        stage_tags_grey(ex),
        stage_tags_rgb(ex),
        walk(ex),
        spill(ex),
        spill_texels(ex),
        counters(ex),
        inside(ex) {}
  ExecArray<uint32_t, Ex> counts;             // per texel of the map: its nodes before the layout
  ExecArray<uint32_t, Ex> spilled;            // per texel of the map: 1 walked again, 2 and re-compressed
  ExecArray<float, Ex> extra;                 // per texel of the map: error the large buffer's bound added
  ExecArray<TexelRange, Ex> heads;            // every map's texels: their nodes in staging (from the map's base)
  ExecArray<uint32_t, Ex> tile_first;         // chunked, every map's tiles: the first chunk (from the map's)
  ExecArray<unsigned char, Ex> stage_grey;    // the walked nodes of the frame's grey maps, map after map
  ExecArray<unsigned char, Ex> stage_rgb;     // ... and of its RGB maps
  ExecArray<SurfaceTag, Ex> stage_tags_grey;  // their tags
  ExecArray<SurfaceTag, Ex> stage_tags_rgb;
  ExecArray<unsigned char, Ex> walk;      // the first walk's buffers of one batch
  ExecArray<unsigned char, Ex> spill;     // the second walk's buffers (none until a texel needs one)
  ExecArray<uint32_t, Ex> spill_texels;   // the batch's texels listed for the second walk
  ExecArray<BuildCounters, Ex> counters;  // per map of the frame
  ExecArray<uint32_t, Ex> inside;         // the objects containing each map's light (over device memory)
  // Nodes per texel of the last build, per node kind: the guess of how many
  // the next needs (before any build: two).
  double nodes_per_texel[2] = {2.0, 2.0};

  ExecArray<unsigned char, Ex>& stage(bool rgb) { return rgb ? stage_rgb : stage_grey; }
  ExecArray<SurfaceTag, Ex>& stage_tags(bool rgb) { return rgb ? stage_tags_rgb : stage_tags_grey; }
  // The staging capacity in nodes of `Node` (node and tag arrays alike).
  template <class Node>
  uint64_t stage_capacity() {
    const bool rgb = Node::kChannels == 3;
    return std::min<uint64_t>(stage(rgb).capacity() / sizeof(Node), stage_tags(rgb).capacity());
  }
  // Staging of `Node` grown to hold `nodes` (by half at least), the nodes
  // already staged kept: the maps before the first that did not fit are
  // not walked again.
  template <class Node>
  void grow_stage(uint64_t nodes) {
    const bool rgb = Node::kChannels == 3;
    ExecArray<unsigned char, Ex>& a = stage(rgb);
    ExecArray<SurfaceTag, Ex>& t = stage_tags(rgb);
    a.resize(a.capacity());  // everything within the capacity is content
    t.resize(t.capacity());
    a.resize(nodes * sizeof(Node));
    t.resize(nodes);
  }
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
  uint64_t first = 0;         // first walks: the batch's first tile
  uint32_t threads = 0;       // second walks: the buffers (each walks every threads-th listed texel)
  bool layout_counts = true;  // packed and chunked store the nodes as built (fixed counts in its own pass)
  uint64_t capacity = 0;      // the pool's nodes (a write past them is skipped, its count kept)
  bool absolute = false;      // packed: heads hold pool offsets (the store's); else offsets from ctr->base
  uint32_t* counts = nullptr;
  uint32_t* spilled = nullptr;  // per texel: 0, 1 walked again, 2 walked again and re-compressed
  float* extra = nullptr;
  TexelRange* heads = nullptr;
  BuildCounters* ctr = nullptr;
  unsigned char* buffers = nullptr;  // first walks: the batch's; second: one per thread
  uint64_t slot_bytes = 0;
  uint32_t* spill_texels = nullptr;
  Node* pool = nullptr;  // second walk: the pool (the map's nodes from ctr->base)
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
      atomic_add(&ctr->spilled_total, 1u);
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

// Second walks of the batch's listed texels (their number is on the
// executor: thread idx walks every threads-th of them with buffer idx) into
// the large buffer (either kind removes through the heap: one overflow
// policy), each reserved exactly in staging and written there.
template <class Node>
struct SecondWalk {
  TexelWalks<Node> w;
  CDSM_HD void operator()(uint64_t idx) const {
    for (uint64_t k = idx; k < w.ctr->spilled; k += w.threads) walk_one(idx, w.spill_texels[k]);
  }
  CDSM_HD void walk_one(uint64_t idx, uint64_t i) const {
    const int tx = int(i % uint64_t(w.res)), ty = int(i / uint64_t(w.res));
    auto buf = NodeKind<Node>::buffer(w.buffers + idx * w.slot_bytes, w.K, true);
    WalkStats st;
    build_texel(w.scene, w.params, w.frags.pixel(tx, ty), tx, ty, buf, st);
    const uint32_t n = uint32_t(buf.count);
    const bool recompressed = buf.removed > 0;
    w.counts[i] = n;
    w.extra[i] = buf.extra_error;
    w.spilled[i] = recompressed ? 2u : 1u;
    const uint64_t rel = atomic_add(&w.ctr->nodes, (unsigned long long)n);
    const uint64_t at = w.ctr->base + rel;
    w.heads[i] = TexelRange{uint32_t(w.absolute ? at : rel), n};
    if (at + n <= w.capacity)
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

// One map of a frame's builds: its inputs (spans in executor memory; the
// lists are sorted in place).
struct MapBuildInput {
  LightPassParams params;
  FragmentLists frags;
  // Lists made without the host reading their count (exec/scan.h
  // take_gl_part): their two status words on the executor; null when the
  // count is known.
  const unsigned long long* lists_status = nullptr;
};

// Where a map of the batch keeps its parts between the walk and its
// placement (host side).
struct BatchEntry {
  bool rgb = false;
  int prev = -1;              // the previous map of the same kind in the batch (its base + nodes is this one's base)
  uint64_t heads_at = 0;      // its texels in LightPassScratch::heads
  uint64_t tiles_at = 0;      // chunked: its tiles in LightPassScratch::tile_first
  uint64_t texel_offset = 0;  // packed, fixed: its first texel in the store (the walk places them)
  // The kind's store as it was before this map's walk (packed and fixed
  // grow it): where a second round of walks cuts it back to.
  uint64_t store_nodes = 0, store_tags = 0, store_texels = 0, store_headers = 0;
};

// A map's texels in 8x8 tiles, and its layout's L and C (the walk's and
// the placement's shared terms).
struct MapGrid {
  int res, height, tiles_x, tiles_y;
  uint64_t texels, tiles;
  uint32_t L, C;
  MapGrid(const PinholeView& v, const DsmLayoutParams& layout)
      : res(v.width),
        height(v.height),
        tiles_x((v.width + kDsmTile - 1) / kDsmTile),
        tiles_y((v.height + kDsmTile - 1) / kDsmTile),
        texels(uint64_t(v.width) * uint64_t(v.height)),
        tiles(uint64_t(tiles_x) * uint64_t(tiles_y)),
        L(uint32_t(layout.fixed_layers)),
        C(uint32_t(layout.chunk_nodes)) {}
};

// Steps 1-5 of one map (its counters at `ctr`, zeroed; the previous map's
// of the same kind at `prev`, or null). No read-back: every count stays on
// the executor.
template <class Node, class Ex>
void walk_map_exec(Ex& ex, const SceneView& scene, const LightPassParams& params, FragmentLists frags,
                   const DsmLayoutParams& layout, const LightPassOptions& opt, KindStore<Node, Ex>& out,
                   LightPassScratch<Ex>& s, BatchEntry& b, BuildCounters* ctr, const BuildCounters* prev) {
  using Kind = NodeKind<Node>;
  const DsmLayout kind = layout.layout;
  const bool rgb = Node::kChannels == 3;
  const MapGrid g(params.view, layout);
  const int res = g.res, height = g.height, tiles_x = g.tiles_x, tiles_y = g.tiles_y;
  const uint64_t n_texels = g.texels, n_tiles = g.tiles;
  const uint32_t L = g.L, C = g.C;
  const bool baseline = params.method != ShadowMethod::Dsm;
  const int K = baseline ? baseline_capacity(params.method, params.method_param) : opt.walk_nodes;
  const int K2 = opt.max_nodes;
  if (K < 4 || K2 < K)
    throw std::invalid_argument("light pass: the walk buffers must hold >= 4 nodes, the second >= the first");

  b.store_nodes = out.nodes.size();
  b.store_tags = out.tags.size();
  b.store_texels = out.texel_count;
  b.store_headers = out.texels.size();

  s.counts.resize_discard(n_texels);
  s.spilled.resize_discard(n_texels);
  s.extra.resize_discard(n_texels);
  ex.fill_zero(s.spilled.data(), s.spilled.bytes());
  ex.fill_zero(s.extra.data(), s.extra.bytes());
  uint32_t* counts = s.counts.data();
  uint32_t* spilled = s.spilled.data();
  float* extra = s.extra.data();
  // The pool the walks write: packed, the store's nodes from its end (the
  // headers the store's, with store offsets); fixed and chunked, staging
  // (the headers the scratch's, offsets from the map's base).
  const bool in_store = kind == DsmLayout::Packed;
  TexelRange* heads = s.heads.data() + b.heads_at;
  if (in_store) {
    b.texel_offset = out.texel_count;
    out.texels.resize(out.texels.size() + n_texels);
    out.texel_count += n_texels;
    heads = out.texels.data() + b.texel_offset;
  }
  const uint64_t capacity =
      in_store ? std::min(out.nodes.capacity(), out.tags.capacity()) : s.template stage_capacity<Node>();
  Node* pool = in_store ? out.nodes.data() : reinterpret_cast<Node*>(s.stage(rgb).data());
  SurfaceTag* pool_tags = in_store ? out.tags.data() : s.stage_tags(rgb).data();

  // The map's first node in the pool: after the previous map's, on the executor.
  const unsigned long long first_base = in_store ? out.nodes.size() : 0ull;
  ex.parallel_for(
      "light pass: pool base", 1, CDSM_LAMBDA(uint64_t) { ctr->base = prev ? prev->base + prev->nodes : first_base; });

  TexelWalks<Node> work;
  work.scene = scene;
  work.params = params;
  work.frags = frags;
  work.res = res;
  work.height = height;
  work.tiles_x = tiles_x;
  work.layout_counts = kind != DsmLayout::Fixed;
  work.capacity = capacity;
  work.absolute = in_store;
  work.counts = counts;
  work.spilled = spilled;
  work.extra = extra;
  work.heads = heads;
  work.ctr = ctr;
  work.pool = pool;
  work.pool_tags = pool_tags;

  const uint64_t walk_bytes = Kind::buffer_bytes(K, false);
  const uint64_t rewalk_bytes = Kind::buffer_bytes(K2, true);
  const uint64_t row_texels = uint64_t(tiles_x) * kDsmTile * kDsmTile;  // a row of tiles, its edge included
  const uint64_t batch_bytes = opt.batch_bytes ? opt.batch_bytes : Ex::kLightPassBatchBytes;
  const uint64_t rows_per_batch = std::max<uint64_t>(1, batch_bytes / std::max<uint64_t>(1, row_texels * walk_bytes));
  // Second-walk buffers: as many as the spill array holds (at least one:
  // build_maps_exec grows it to the texels a frame walked again).
  const uint64_t spill_threads = s.spill.capacity() / rewalk_bytes;
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
    // 2. walk the listed texels again (their number is on the executor).
    if (spill_threads > 0) {
      TexelWalks<Node> again = work;
      again.K = K2;
      again.slot_bytes = rewalk_bytes;
      again.buffers = s.spill.data();
      again.threads = uint32_t(spill_threads);
      ex.parallel_for("light pass: walk again", spill_threads, SecondWalk<Node>{again});
    }
    // 3. reserve the tiles' other texels (offsets from the map's base).
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
          uint64_t at = atomic_add(&ctr->nodes, (unsigned long long)total);
          for (int j = 0; j < kDsmTile * kDsmTile; ++j) {
            const int tx = x0 + j % kDsmTile, ty = y0 + j / kDsmTile;
            const uint64_t t = uint64_t(ty) * res + tx;
            if (tx >= res || ty >= height || spilled[t] != 0u) continue;
            heads[t] = TexelRange{uint32_t(in_store ? ctr->base + at : at), counts[t]};
            at += counts[t];
          }
        });
    // 4. copy the walked texels' nodes into staging (within its capacity).
    const unsigned char* walk_mem = s.walk.data();
    const TexelWalks<Node> at = work;
    ex.parallel_for(
        "light pass: copy", batch, CDSM_LAMBDA(uint64_t k) {
          int tx, ty;
          if (!at.batch_texel(tile0, k, tx, ty)) return;
          const uint64_t t = uint64_t(ty) * uint64_t(res) + uint64_t(tx);
          if (spilled[t] != 0u) return;
          const TexelRange h = heads[t];
          const uint64_t first = in_store ? uint64_t(h.offset) : ctr->base + h.offset;
          if (first + h.count > capacity) return;
          const auto buf = Kind::buffer(const_cast<unsigned char*>(walk_mem) + k * walk_bytes, K, false);
          for (uint32_t j = 0; j < h.count; ++j) {
            pool[first + j] = buf.nodes[j];
            pool_tags[first + j] = buf.tags[j];
          }
        });
  }

  // 5. the layout's part that needs no count from the host.
  if (kind == DsmLayout::Fixed) {
    b.texel_offset = out.texel_count;
    const uint64_t first_slot = out.nodes.size();
    out.nodes.resize(first_slot + n_texels * L);
    out.tags.resize(out.nodes.size());
    out.texel_count += n_texels;
    Node* slots = out.nodes.data() + first_slot;
    SurfaceTag* slot_tags = out.tags.data() + first_slot;
    const float eps = params.epsilon;
    ex.parallel_for(
        "light pass: fixed layout", n_texels, CDSM_LAMBDA(uint64_t i) {
          const TexelRange h = heads[i];
          const uint64_t first = ctr->base + h.offset;
          if (first + h.count > capacity) {  // staging overflowed: the map is walked again
            counts[i] = 0;
            return;
          }
          FixedFit fit = write_fixed_texel(Span<const Node>{pool + first, h.count}, pool_tags + first, eps,
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
    uint32_t* tile_first = s.tile_first.data() + b.tiles_at;
    ex.parallel_for(
        "light pass: reserve chunks", n_tiles, CDSM_LAMBDA(uint64_t tile) {
          const int x0 = int(tile % uint64_t(tiles_x)) * kDsmTile, y0 = int(tile / uint64_t(tiles_x)) * kDsmTile;
          uint32_t n = 0;
          for (int j = 0; j < kDsmTile * kDsmTile; ++j) {
            const int tx = x0 + j % kDsmTile, ty = y0 + j / kDsmTile;
            if (tx < res && ty < height) n += heads[uint64_t(ty) * res + tx].count;
          }
          tile_first[tile] = uint32_t(atomic_add(&ctr->chunks, (unsigned long long)tile_chunks(n, C)));
        });
  }
}

// Whether map `c`'s walk has to be done again: staging was too small for it.
inline bool walk_overflowed(const BuildCounters& c, uint64_t capacity) { return c.base + c.nodes > capacity; }

// Step 7 of one map whose counters `c` were read: placed into `out`, its
// header into `map`; its stats.
template <class Node, class Ex>
DsmBuildStats place_map_exec(Ex& ex, const LightPassParams& params, const DsmLayoutParams& layout,
                             KindStore<Node, Ex>& out, LightPassScratch<Ex>& s, const BatchEntry& b,
                             const BuildCounters& c, DsmMap& map) {
  using Chunk = typename NodeKind<Node>::Chunk;
  const DsmLayout kind = layout.layout;
  const bool rgb = Node::kChannels == 3;
  const MapGrid g(params.view, layout);
  const int res = g.res, height = g.height, tiles_x = g.tiles_x;
  const uint64_t n_texels = g.texels, n_tiles = g.tiles;
  const uint32_t L = g.L, C = g.C;
  // Chunked: the map's nodes in staging (packed maps are in the store
  // already; fixed maps were placed by the walk).
  const Node* staging = nullptr;
  const SurfaceTag* staging_tags = nullptr;
  if (kind == DsmLayout::Chunked) {
    staging = reinterpret_cast<const Node*>(s.stage(rgb).data()) + c.base;
    staging_tags = s.stage_tags(rgb).data() + c.base;
  }
  const TexelRange* heads = s.heads.data() + b.heads_at;

  map = DsmMap{};
  map.view = params.view;
  map.res = uint32_t(res);
  map.rgb = params.rgb ? 1u : 0u;
  map.texel_offset = kind == DsmLayout::Chunked ? out.texel_count : b.texel_offset;

  if (kind == DsmLayout::Packed) {  // the walks wrote the store: its size now covers the map's nodes
    check_u32_total(c.base + c.nodes, "nodes");
    out.nodes.resize(c.base + c.nodes);
    out.tags.resize(c.base + c.nodes);
  } else if (kind == DsmLayout::Chunked) {
    const uint64_t chunk_base = out.chunks.size(), texel_base = out.texels.size();  // slots
    check_u32_total(chunk_base + c.chunks * C, "chunk slots");
    out.texels.resize(texel_base + n_texels);
    out.chunks.resize(chunk_base + c.chunks * C);
    out.tags.resize(out.chunks.size());
    Chunk* pool = out.chunks.data();
    SurfaceTag* chunk_tags = out.tags.data();
    TexelRange* store_heads = out.texels.data() + texel_base;
    const uint32_t* tile_first = s.tile_first.data() + b.tiles_at;
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
    out.texel_count += n_texels;
  }

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
      stats.node_bytes_allocated = c.nodes * sizeof(Node);
      stats.node_bytes_used = stats.nodes * sizeof(Node);
      stats.tag_bytes = c.nodes * sizeof(SurfaceTag);
  }
  stats.slack_bytes = stats.node_bytes_allocated - stats.node_bytes_used;
  stats.pyramid_bytes = build_blocker_pyramid(ex, out, map, kind, L, params.blocker_pyramid);
  return stats;
}

// Builds `n` maps (grey and RGB, one layout) into the stores: every map
// walked, every counter read in one download, every map placed (the steps
// above). maps[i] and stats[i] are map i's header and stats. Throws on
// bad options or a failed allocation or launch; the caller cuts the
// stores back (ExecBackend::build_maps). With unchecked lists
// (MapBuildInput::lists_status) their status comes back with the same
// read, into lists_fragments[i] and lists_short[i] (when not null); false,
// nothing placed, when one did not fit (the caller cuts the stores back).
template <class Ex>
bool build_maps_exec(Ex& ex, const SceneView& scene, const MapBuildInput* in, size_t n, const DsmLayoutParams& layout,
                     const LightPassOptions& opt, KindStore<DsmNode, Ex>& grey, KindStore<DsmNodeRgb, Ex>& rgb,
                     LightPassScratch<Ex>& s, DsmMap* maps, DsmBuildStats* stats, uint64_t* lists_fragments = nullptr,
                     uint8_t* lists_short = nullptr) {
  if (n == 0) return true;
  std::vector<BatchEntry> batch(n);
  uint64_t texels = 0, tiles = 0, guess[2] = {0, 0}, texels_of[2] = {0, 0};
  int last[2] = {-1, -1};
  for (size_t i = 0; i < n; ++i) {
    const PinholeView& v = in[i].params.view;
    const uint64_t w = uint64_t(v.width), h = uint64_t(v.height);
    BatchEntry& b = batch[i];
    b.rgb = in[i].params.rgb;
    b.prev = last[b.rgb];
    last[b.rgb] = int(i);
    b.heads_at = texels;
    b.tiles_at = tiles;
    texels += w * h;
    tiles += ((w + kDsmTile - 1) / kDsmTile) * ((h + kDsmTile - 1) / kDsmTile);
    texels_of[b.rgb] += w * h;
  }
  // The guess: the last build's nodes per texel (a read corrects it).
  for (int k = 0; k < 2; ++k) guess[k] = uint64_t(double(texels_of[k]) * s.nodes_per_texel[k]);
  s.heads.resize_discard(texels);
  // One second-walk buffer at least (a texel that needs it is walked, one
  // at a time, before the read shows how many there were).
  const uint64_t rewalk_bytes = std::max(NodeKind<DsmNode>::buffer_bytes(opt.max_nodes, true),
                                         NodeKind<DsmNodeRgb>::buffer_bytes(opt.max_nodes, true));
  if (s.spill.capacity() < rewalk_bytes) s.spill.resize_discard(rewalk_bytes);
  if (layout.layout == DsmLayout::Chunked) s.tile_first.resize_discard(tiles);
  s.counters.resize_discard(n);
  std::vector<BuildCounters> c(n);
  // Where the walks write (exec/light_pass.h step 4): packed, the store
  // itself; fixed and chunked, staging.
  const bool packed = layout.layout == DsmLayout::Packed;
  const auto capacity_of = [&](bool is_rgb) -> uint64_t {
    if (packed)
      return is_rgb ? std::min(rgb.nodes.capacity(), rgb.tags.capacity())
                    : std::min(grey.nodes.capacity(), grey.tags.capacity());
    return is_rgb ? s.template stage_capacity<DsmNodeRgb>() : s.template stage_capacity<DsmNode>();
  };
  const auto capacity = [&](size_t i) { return capacity_of(batch[i].rgb); };
  const auto cut_back = [&](auto& store, const BatchEntry& b) {
    store.nodes.resize(b.store_nodes);
    store.tags.resize(b.store_tags);
    store.texels.resize(b.store_headers);
    store.texel_count = b.store_texels;
  };
  // An array grown to `n` entries (by half at least), everything within its
  // capacity kept: the maps before the first that did not fit are not
  // walked again.
  const auto grow_keeping = [](auto& a, uint64_t n) {
    a.resize(a.capacity());
    a.resize(n);
  };
  // Where the guess of the batch's nodes does not fit (the first build,
  // maps added to a full store), room for it and a quarter more; a steady
  // frame fits.
  const auto room_for = [&](bool is_rgb, uint64_t nodes) {
    if (nodes == 0) return;  // no map of the kind
    const uint64_t ample = nodes + nodes / 4;
    if (packed) {
      const auto grow = [&](auto& store) {
        const uint64_t size = store.nodes.size();
        if (capacity_of(is_rgb) >= size + nodes) return;
        check_u32_total(size + ample, "nodes");
        grow_keeping(store.nodes, size + ample);
        grow_keeping(store.tags, size + ample);
        store.nodes.resize(size);
        store.tags.resize(size);
      };
      if (is_rgb)
        grow(rgb);
      else
        grow(grey);
    } else if (capacity_of(is_rgb) < nodes) {
      if (is_rgb)
        s.template grow_stage<DsmNodeRgb>(ample);
      else
        s.template grow_stage<DsmNode>(ample);
    }
  };
  room_for(false, guess[0]);
  room_for(true, guess[1]);
  size_t from = 0;  // the first map to walk (again)
  for (int round = 0;; ++round) {
    ex.fill_zero(s.counters.data() + from, (n - from) * sizeof(BuildCounters));
    for (size_t i = from; i < n; ++i)
      if (in[i].lists_status)
        ex.copy(&s.counters.data()[i].lists_fragments, in[i].lists_status, 2 * sizeof(unsigned long long));
    for (size_t i = from; i < n; ++i) {
      BuildCounters* ctr = s.counters.data() + i;
      const BuildCounters* prev = batch[i].prev >= 0 ? s.counters.data() + batch[i].prev : nullptr;
      if (batch[i].rgb)
        walk_map_exec(ex, scene, in[i].params, in[i].frags, layout, opt, rgb, s, batch[i], ctr, prev);
      else
        walk_map_exec(ex, scene, in[i].params, in[i].frags, layout, opt, grey, s, batch[i], ctr, prev);
    }
    ex.download(c.data(), s.counters.data(), n * sizeof(BuildCounters));  // 6. the one read
    bool any_short = false;
    for (size_t i = from; i < n; ++i)
      if (in[i].lists_status) {
        if (lists_fragments) lists_fragments[i] = c[i].lists_fragments;
        if (lists_short) lists_short[i] = c[i].lists_short != 0 ? 1 : 0;
        any_short = any_short || c[i].lists_short != 0;
      }
    if (any_short) return false;
    size_t bad = n;
    for (size_t i = from; i < n && bad == n; ++i)
      if (walk_overflowed(c[i], capacity(i))) bad = i;
    if (bad == n) break;
    if (round == 2)
      throw std::logic_error("light pass: map " + std::to_string(bad) + " still overflows its pool after it grew");
    // Grow what was short (to the counts, or by half) and walk again from
    // the first map that did not fit; the store back to where it was then.
    uint64_t need[2] = {0, 0};
    for (size_t i = 0; i < n; ++i) need[batch[i].rgb] = std::max<uint64_t>(need[batch[i].rgb], c[i].base + c[i].nodes);
    check_u32_total(std::max(need[0], need[1]), "nodes");
    if (need[0] > capacity_of(false)) {
      if (packed) {
        grow_keeping(grey.nodes, need[0]);
        grow_keeping(grey.tags, need[0]);
      } else {
        s.template grow_stage<DsmNode>(need[0]);
      }
    }
    if (need[1] > capacity_of(true)) {
      if (packed) {
        grow_keeping(rgb.nodes, need[1]);
        grow_keeping(rgb.tags, need[1]);
      } else {
        s.template grow_stage<DsmNodeRgb>(need[1]);
      }
    }
    for (int k = 0; k < 2; ++k)
      for (size_t i = bad; i < n; ++i)
        if (int(batch[i].rgb) == k) {
          if (k)
            cut_back(rgb, batch[i]);
          else
            cut_back(grey, batch[i]);
          break;
        }
    from = bad;
  }
  // Second-walk buffers for as many texels as a map's batch listed (up to
  // the batch's bytes), for the next build.
  uint64_t spilled = 0;
  for (const BuildCounters& k : c) spilled = std::max<uint64_t>(spilled, k.spilled_total);
  const uint64_t batch_bytes = opt.batch_bytes ? opt.batch_bytes : Ex::kLightPassBatchBytes;
  const uint64_t threads = std::min<uint64_t>(spilled, std::max<uint64_t>(1, batch_bytes / rewalk_bytes));
  if (s.spill.capacity() < threads * rewalk_bytes) s.spill.resize_discard(threads * rewalk_bytes);
  uint64_t nodes_of[2] = {0, 0};
  for (size_t i = 0; i < n; ++i) nodes_of[batch[i].rgb] += c[i].nodes;
  for (int k = 0; k < 2; ++k)
    if (texels_of[k] > 0) s.nodes_per_texel[k] = double(nodes_of[k]) / double(texels_of[k]);
  for (size_t i = 0; i < n; ++i) {  // 7. place
    if (batch[i].rgb)
      stats[i] = place_map_exec(ex, in[i].params, layout, rgb, s, batch[i], c[i], maps[i]);
    else
      stats[i] = place_map_exec(ex, in[i].params, layout, grey, s, batch[i], c[i], maps[i]);
  }
  return true;
}

}  // namespace cdsm::exec
