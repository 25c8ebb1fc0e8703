// The light pass over an executor (shadows/exec/exec.h): one map into one
// of the three layouts (DESIGN.md §3), built so that no thread holds more
// than a few nodes — the form a GPU needs.
//
// Why two passes. The cpu backend builds each texel into a buffer of
// K = 1024 nodes per thread (8 KiB; 32 KiB with its removal heap). On a GPU
// every resident thread would need it: an H200 keeps 132 SMs x 2048 =
// 270,336 threads resident, so 2.2 GiB of local memory for the nodes alone
// (8.9 GiB with the heaps), all of it streaming through L1/L2. A small
// buffer instead (K = 64: 512 B per thread, 138 MB) must re-compress every
// texel with more than node_limit(64) = 56 nodes — common in smoke — and then
// differs from the cpu backend's nodes, which breaks CPU/GPU parity (>= 99.9%
// of texels identical). So the DSM build here runs the wedge twice:
//
//   1. count   per texel, the wedge into a FixedSlotSink without slots: it
//              keeps only the last two nodes (16 bytes), counts the rest;
//   2. reserve per 8x8 tile, a tile-local prefix sum of the counts and one
//              atomic reservation of the tile's exact node total (packed
//              headers written here; chunked: the tile's chunks too);
//   3. write   per texel, the wedge again straight into its reserved nodes
//              (a FixedSlotSink over exactly `count` slots: it can never
//              write past them). Texels over node_limit(K) — where the cpu
//              backend's bounded buffer re-compresses — are built in exactly
//              that buffer (K nodes and the removal heap) in a spill area
//              allocated for those texels only, so the result is the cpu
//              backend's bit for bit in every texel;
//   4. fixed / chunked: write_fixed_texel / write_chunked_tile from the
//              packed nodes of step 3.
//
// Cost: the segment walk twice. The alternative (one pass into K-node
// buffers, LightPassMode::Staged) is kept for the baselines, whose node
// count is bounded by their parameter, and for the GPU kit's benchmark,
// which measures both on the device (scripts/gpu/run_kit.sh).
#pragma once

#include <limits>
#include <stdexcept>
#include <string>

#include "cpu/backend.h"
#include "exec/exec.h"
#include "hd/light_pass.h"

namespace cdsm::exec {

// Counters of one build, accumulated in executor memory and read back once.
struct BuildCounters {
  unsigned long long nodes;         // node slots reserved by the tiles
  unsigned long long chunks;        // chunked: chunks reserved
  unsigned long long stored;        // nodes stored in the layout
  uint32_t spill_texels;            // two-pass: texels over node_limit(K), built in the spill area
  uint32_t layout_overflow_texels;  // fixed: re-compressed to fit L
  uint32_t recompressed_texels;     // by the per-texel bound or the layout (DsmBuildStats::overflow_texels)
  uint32_t max_nodes;               // stored, per texel
  uint32_t max_built_nodes;         // per texel, before the layout
  uint32_t max_extra_error_bits;    // float bits of the largest error re-compression added
  uint32_t mismatches;              // write pass != count pass: a broken invariant, must stay 0
  uint32_t walk[4];                 // WalkStats: enclosing, match, unmatched, lengthened
};

enum class LightPassMode : uint32_t {
  TwoPass,  // count -> reserve -> write (deep shadow maps; the default)
  Staged,   // one pass into per-texel buffers of `node_capacity` nodes (re-compression beyond)
};

struct LightPassOptions {
  LightPassMode mode = LightPassMode::TwoPass;
  int node_capacity = kTexelNodeCapacity;  // K: two-pass, where a texel spills; staged, its buffer
};

// Per node kind: the chunk slot, the bounded buffer and its memory.
template <class Node>
struct NodeKind;
// A bounded buffer of K nodes in executor memory: the nodes, (scalar
// nodes, with `heap`) the removal heap's six arrays, then the nodes' tags;
// buffer_bytes() long, a multiple of 16 so buffers can follow each other.
template <>
struct NodeKind<DsmNode> {
  using Chunk = ChunkNode;
  using Buffer = NodeBuffer;
  using Visitor = DsmVisitor;
  static constexpr size_t heap_bytes_per_slot = 4 * sizeof(uint32_t) + 2 * sizeof(float);
  static CDSM_HD uint64_t buffer_bytes(int k, bool heap) {
    const uint64_t b = uint64_t(k) * (sizeof(DsmNode) + (heap ? heap_bytes_per_slot : 0) + sizeof(SurfaceTag));
    return (b + 15) & ~uint64_t(15);
  }
  static CDSM_HD NodeBuffer buffer(unsigned char* p, int k, bool heap) {
    NodeBuffer b{reinterpret_cast<DsmNode*>(p), k};
    unsigned char* after = p + size_t(k) * sizeof(DsmNode);
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
template <>
struct NodeKind<DsmNodeRgb> {
  using Chunk = ChunkNodeRgb;
  using Buffer = RgbNodeBuffer;
  using Visitor = DsmVisitorRgb;
  static CDSM_HD uint64_t buffer_bytes(int k, bool) {
    const uint64_t b = uint64_t(k) * (sizeof(DsmNodeRgb) + sizeof(SurfaceTag));
    return (b + 15) & ~uint64_t(15);
  }
  static CDSM_HD RgbNodeBuffer buffer(unsigned char* p, int k, bool) {
    RgbNodeBuffer b{reinterpret_cast<DsmNodeRgb*>(p), k};
    b.tags = reinterpret_cast<SurfaceTag*>(p + size_t(k) * sizeof(DsmNodeRgb));
    return b;
  }
};

// One node kind's arrays of a map store in executor memory (as DsmArrays).
template <class Node, class Ex>
struct KindStore {
  using Chunk = typename NodeKind<Node>::Chunk;
  explicit KindStore(Ex& ex) : texels(ex), nodes(ex), chunks(ex), tags(ex) {}
  ExecArray<TexelRange, Ex> texels;  // packed, chunked: headers, map by map
  ExecArray<Node, Ex> nodes;         // packed: exact pool; fixed: L slots per texel
  ExecArray<Chunk, Ex> chunks;       // chunked: the slot pool
  ExecArray<SurfaceTag, Ex> tags;    // per slot of `nodes` (packed, fixed) or of `chunks` (chunked)
  uint64_t texel_count = 0;          // this kind's texels (fixed keeps no headers)
};

// Working memory of the light pass, kept across builds (it only grows).
template <class Ex>
struct LightPassScratch {
  explicit LightPassScratch(Ex& ex)
      : counts(ex), overflow(ex), extra(ex), heads(ex), tile_first(ex), staging(ex), staging_tags(ex), staged(ex),
        spill(ex), spill_texels(ex), counters(ex), offsets(ex), fragments(ex), inside(ex) {}
  ExecArray<uint32_t, Ex> counts;      // per texel: nodes it stores before the layout
  ExecArray<uint32_t, Ex> overflow;    // per texel: 0, or re-compressed (staged: 1; two-pass: spill slot + 1)
  ExecArray<float, Ex> extra;          // per texel: error the per-texel bound added
  ExecArray<TexelRange, Ex> heads;     // fixed, chunked: each texel's nodes in `staging`
  ExecArray<uint32_t, Ex> tile_first;  // chunked: each tile's first chunk (relative to the map's)
  ExecArray<unsigned char, Ex> staging;  // fixed, chunked: the packed nodes the layout is written from
  ExecArray<SurfaceTag, Ex> staging_tags;  // their tags
  ExecArray<unsigned char, Ex> staged;   // staged mode: node_capacity nodes per texel
  ExecArray<unsigned char, Ex> spill;    // two-pass: a K-node buffer per spilled texel
  ExecArray<uint32_t, Ex> spill_texels;  // two-pass: the spilled texels, by spill slot
  ExecArray<BuildCounters, Ex> counters;
  ExecArray<uint32_t, Ex> offsets;       // the map's fragment lists, in executor memory
  ExecArray<Fragment, Ex> fragments;
  ExecArray<uint32_t, Ex> inside;
};

// Nodes a baseline texel can hold at once (hd/baselines.h), so a buffer of
// baseline_capacity() slots never re-compresses: the cpu backend's result.
inline int baseline_capacity(uint32_t method, float param) {
  int bound = 2;
  if (method == kMethodOpacitySlices) bound = (param >= 1.0f ? int(param) : kDefaultOpacitySlices) + 1;
  if (method == kMethodFixedNodes) bound = (param >= 2.0f ? int(param) : kDefaultFixedNodes) + 1;
  int cap = bound + 2 < 4 ? 4 : bound + 2;
  while (node_limit(cap) < bound + 1) ++cap;
  return cap;
}

inline void check_u32_total(uint64_t v, const char* what) {
  if (v > std::numeric_limits<uint32_t>::max())
    throw std::length_error(std::string("DSM ") + what + " exceed 2^32 entries");
}

// A texel's nodes are in place (n of them before the layout): the build's
// counters. `layout_counts`: packed and chunked store them as they are
// (fixed counts after its own pass); `recompressed`: by the per-texel bound.
CDSM_HD CDSM_INLINE void account_texel(BuildCounters* ctr, bool layout_counts, bool recompressed, uint32_t n, float added) {
  atomic_max(&ctr->max_built_nodes, n);
  if (!layout_counts) return;
  atomic_add(&ctr->stored, (unsigned long long)n);
  atomic_max(&ctr->max_nodes, n);
  if (recompressed) {
    atomic_add(&ctr->recompressed_texels, 1u);
    atomic_max(&ctr->max_extra_error_bits, float_bits(added));
  }
}

// The per-texel work of the light pass, one launch kind per node kind (a
// functor rather than lambdas: one kernel holds the walker once for the
// count and write steps and once for the bounded-buffer steps, which keeps
// nvcc's compile time and code size down).
enum class TexelStep : uint32_t {
  Count,    // the wedge into a sink without slots: counts[i], overflow[i] (> node_limit(K))
  Write,    // the wedge again into the texel's reserved nodes (texels with overflow[i] == 0)
  Staged,   // build_texel into a per-texel buffer of K nodes (index: texel)
  Spilled,  // build_texel into the cpu backend's bounded buffer, then into the pool (index: spill slot)
};

template <class Node>
struct TexelWork {
  using Kind = NodeKind<Node>;
  SceneView scene;
  LightPassParams params;
  FragmentLists frags;
  TexelStep step = TexelStep::Count;
  int res = 0;
  int K = 0;                       // the per-texel bound
  uint32_t limit = 0;              // node_limit(K)
  bool layout_counts = true;       // account_texel()'s layout_counts
  uint32_t* counts = nullptr;
  uint32_t* overflow = nullptr;
  float* extra = nullptr;
  BuildCounters* ctr = nullptr;
  const TexelRange* heads = nullptr;
  Node* target = nullptr;          // the packed nodes (the store's, or the staging array)
  SurfaceTag* target_tags = nullptr;  // their tags
  unsigned char* bounded = nullptr;  // Staged: K nodes per texel; Spilled: one buffer per spill slot
  uint64_t slot_bytes = 0;
  const uint32_t* spill_texels = nullptr;

  CDSM_HD void add_walk(const WalkStats& st) const {
    if (st.enclosing_overflow) atomic_add(&ctr->walk[0], st.enclosing_overflow);
    if (st.match_overflow) atomic_add(&ctr->walk[1], st.match_overflow);
    if (st.unmatched) atomic_add(&ctr->walk[2], st.unmatched);
    if (st.march_lengthened) atomic_add(&ctr->walk[3], st.march_lengthened);
  }

  CDSM_HD void operator()(uint64_t idx) const {
    if (step == TexelStep::Staged || step == TexelStep::Spilled) {
      bounded_texel(idx);
      return;
    }
    const uint64_t i = idx;
    const bool write = step == TexelStep::Write;
    if (write && overflow[i] != 0u) return;  // spilled: its own step
    const int tx = int(i % uint64_t(res)), ty = int(i / uint64_t(res));
    const TexelRange h = write ? heads[i] : TexelRange{0u, 0u};
    FixedSlotSink<Node> sink(write ? target + h.offset : nullptr, write ? int(h.count) : 0,
                             write ? target_tags + h.offset : nullptr);
    WalkStats st;
    build_texel_into(scene, params, frags.pixel(tx, ty), tx, ty, sink, st);
    const uint32_t n = uint32_t(sink.count);
    if (!write) {
      counts[i] = n > limit ? limit : n;  // a bounded buffer ends with node_limit(K) nodes
      if (n > limit) overflow[i] = 1u;
      add_walk(st);
      return;
    }
    if (n != h.count) atomic_add(&ctr->mismatches, 1u);
    account_texel(ctr, layout_counts, false, h.count, 0.0f);
  }

  CDSM_HD void bounded_texel(uint64_t idx) const {
    const bool staged = step == TexelStep::Staged;
    const uint64_t i = staged ? idx : uint64_t(spill_texels[idx]);
    const int tx = int(i % uint64_t(res)), ty = int(i / uint64_t(res));
    // Scalar spilled texels remove through the heap, as the cpu backend's
    // buffer does; the staged buffers (and RGB ones) by scan.
    auto buf = Kind::buffer(bounded + idx * slot_bytes, K, !staged && sizeof(Node) == sizeof(DsmNode));
    WalkStats st;
    build_texel(scene, params, frags.pixel(tx, ty), tx, ty, buf, st);
    if (staged) {
      counts[i] = uint32_t(buf.count);
      if (buf.removed > 0) {
        overflow[i] = 1u;
        extra[i] = buf.extra_error;
      }
      add_walk(st);
      return;
    }
    const TexelRange h = heads[i];
    if (uint32_t(buf.count) != h.count) atomic_add(&ctr->mismatches, 1u);
    const uint32_t n = uint32_t(buf.count) < h.count ? uint32_t(buf.count) : h.count;
    for (uint32_t j = 0; j < n; ++j) {
      target[h.offset + j] = buf.nodes[j];
      target_tags[h.offset + j] = buf.tags[j];
    }
    extra[i] = buf.extra_error;
    account_texel(ctr, layout_counts, true, h.count, buf.extra_error);
  }
};

// Builds one map from its light-view fragment lists (exec memory; sorted in
// place) into `out` in `layout`. `scene`, `params.inside` and `frags` are
// spans in executor memory. The map's header goes to `map`.
template <class Node, class Ex>
DsmBuildStats build_map_exec(Ex& ex, const SceneView& scene, const LightPassParams& params, FragmentLists frags,
                             const DsmLayoutParams& layout, const LightPassOptions& opt, KindStore<Node, Ex>& out,
                             DsmMap& map, LightPassScratch<Ex>& s) {
  using Kind = NodeKind<Node>;
  using Chunk = typename Kind::Chunk;
  const uint32_t kind = layout.layout;
  const int res = params.view.width, height = params.view.height;
  const int tiles_x = (res + kDsmTile - 1) / kDsmTile, tiles_y = (height + kDsmTile - 1) / kDsmTile;
  const uint64_t n_texels = uint64_t(res) * uint64_t(height);
  const uint64_t n_tiles = uint64_t(tiles_x) * uint64_t(tiles_y);
  const uint32_t L = uint32_t(layout.fixed_layers), C = uint32_t(layout.chunk_nodes);
  const bool baseline = params.method != kMethodDsm;
  const bool staged = baseline || opt.mode == LightPassMode::Staged;
  const int K = baseline ? baseline_capacity(params.method, params.method_param) : opt.node_capacity;
  if (K < 4) throw std::invalid_argument("light pass: the per-texel node bound must be >= 4");
  const uint32_t limit = uint32_t(node_limit(K));

  map = DsmMap{};
  map.view = params.view;
  map.res = uint32_t(res);
  map.rgb = params.rgb ? 1u : 0u;
  map.texel_offset = out.texel_count;

  s.counts.resize_discard(n_texels);
  s.overflow.resize_discard(n_texels);
  s.extra.resize_discard(n_texels);
  s.counters.resize_discard(1);
  ex.fill_zero(s.overflow.data(), s.overflow.bytes());
  ex.fill_zero(s.extra.data(), s.extra.bytes());
  ex.fill_zero(s.counters.data(), s.counters.bytes());
  const uint64_t staged_bytes = Kind::buffer_bytes(K, false);  // per texel
  if (staged) {
    const uint64_t bytes = n_texels * staged_bytes;
    if (bytes > (uint64_t(4) << 30))
      throw std::length_error("light pass: " + std::to_string(bytes >> 20) + " MiB of per-texel buffers (" +
                              std::to_string(K) + " nodes per texel); lower the resolution or the method's parameter");
    s.staged.resize_discard(bytes);
  }

  uint32_t* counts = s.counts.data();
  uint32_t* overflow = s.overflow.data();
  float* extra = s.extra.data();
  BuildCounters* ctr = s.counters.data();
  unsigned char* staged_mem = s.staged.data();

  // 1. count (staged: build into the per-texel buffers).
  TexelWork<Node> work;
  work.scene = scene;
  work.params = params;
  work.frags = frags;
  work.res = res;
  work.K = K;
  work.limit = limit;
  work.layout_counts = kind != kDsmFixed;  // fixed counts after its layout pass
  work.counts = counts;
  work.overflow = overflow;
  work.extra = extra;
  work.ctr = ctr;
  if (staged) {
    work.step = TexelStep::Staged;
    work.bounded = staged_mem;
    work.slot_bytes = staged_bytes;
    ex.parallel_for("light pass: build (staged)", n_texels, work);
  } else {
    work.step = TexelStep::Count;
    ex.parallel_for("light pass: count", n_texels, work);
  }

  // 2. reserve: tile-local prefix sum, one atomic reservation per tile.
  // Packed maps get their headers here (offsets into the store's nodes);
  // fixed and chunked ones the places of their nodes in the staging array.
  const uint64_t pool_base = kind == kDsmPacked ? out.nodes.size() : 0;
  if (kind != kDsmFixed) out.texels.resize(out.texels.size() + n_texels);
  if (kind != kDsmPacked) s.heads.resize_discard(n_texels);
  if (kind == kDsmChunked) s.tile_first.resize_discard(n_tiles);
  if (!staged) s.spill_texels.resize_discard(n_texels);
  uint32_t* spill_texels = s.spill_texels.data();
  TexelRange* heads = kind == kDsmPacked ? out.texels.data() + map.texel_offset : s.heads.data();
  uint32_t* tile_first = s.tile_first.data();
  ex.parallel_for("light pass: reserve tiles", n_tiles, CDSM_LAMBDA(uint64_t tile) {
    const int x0 = int(tile % uint64_t(tiles_x)) * kDsmTile, y0 = int(tile / uint64_t(tiles_x)) * kDsmTile;
    uint32_t total = 0;
    for (int k = 0; k < kDsmTile * kDsmTile; ++k) {
      const int tx = x0 + k % kDsmTile, ty = y0 + k / kDsmTile;
      if (tx < res && ty < height) total += counts[uint64_t(ty) * res + tx];
    }
    unsigned long long at = atomic_add(&ctr->nodes, (unsigned long long)total);
    if (kind == kDsmChunked) tile_first[tile] = uint32_t(atomic_add(&ctr->chunks, (unsigned long long)tile_chunks(total, C)));
    for (int k = 0; k < kDsmTile * kDsmTile; ++k) {
      const int tx = x0 + k % kDsmTile, ty = y0 + k / kDsmTile;
      if (tx >= res || ty >= height) continue;
      const uint64_t t = uint64_t(ty) * res + tx;
      heads[t] = TexelRange{uint32_t(pool_base + at), counts[t]};
      at += counts[t];
      if (!staged && overflow[t] != 0u) {
        const uint32_t slot = atomic_add(&ctr->spill_texels, 1u);
        spill_texels[slot] = uint32_t(t);
        overflow[t] = slot + 1u;
      }
    }
  });

  BuildCounters c{};
  ex.download(&c, ctr, sizeof c);
  const uint64_t total = c.nodes;
  if (kind == kDsmPacked) check_u32_total(pool_base + total, "nodes");
  if (kind == kDsmChunked) check_u32_total((out.chunks.size() / (C ? C : 1) + c.chunks) * C, "chunk slots");
  if (kind != kDsmPacked) check_u32_total(total, "staged nodes");

  // 3. write: the nodes into the packed pool (fixed, chunked: the staging array).
  Node* target;
  SurfaceTag* target_tags;
  if (kind == kDsmPacked) {
    out.nodes.resize(pool_base + total);
    out.tags.resize(pool_base + total);
    target = out.nodes.data();
    target_tags = out.tags.data();
  } else {
    s.staging.resize_discard(total * sizeof(Node));
    s.staging_tags.resize_discard(total);
    target = reinterpret_cast<Node*>(s.staging.data());
    target_tags = s.staging_tags.data();
  }
  const uint64_t slot_bytes = Kind::buffer_bytes(K, sizeof(Node) == sizeof(DsmNode));
  if (!staged) s.spill.resize_discard(uint64_t(c.spill_texels) * slot_bytes);
  const bool count_here = kind != kDsmFixed;
  if (staged) {
    ex.parallel_for("light pass: copy (staged)", n_texels, CDSM_LAMBDA(uint64_t i) {
      const TexelRange h = heads[i];
      const auto buf = Kind::buffer(staged_mem + i * staged_bytes, K, false);
      for (uint32_t j = 0; j < h.count; ++j) {
        target[h.offset + j] = buf.nodes[j];
        target_tags[h.offset + j] = buf.tags[j];
      }
      account_texel(ctr, count_here, overflow[i] != 0u, h.count, extra[i]);
    });
  } else {
    work.heads = heads;
    work.target = target;
    work.target_tags = target_tags;
    work.step = TexelStep::Write;
    ex.parallel_for("light pass: write", n_texels, work);
    // Texels over node_limit(K): the cpu backend's bounded buffer (K nodes,
    // the removal heap for scalar nodes), so the same removals, the same nodes.
    work.step = TexelStep::Spilled;
    work.bounded = s.spill.data();
    work.slot_bytes = slot_bytes;
    work.spill_texels = spill_texels;
    ex.parallel_for("light pass: spilled texels", c.spill_texels, work);
  }

  // 4. the layout.
  const uint64_t chunk_base = kind == kDsmChunked ? out.chunks.size() : 0;  // slots
  if (kind == kDsmFixed) {
    out.nodes.resize(out.nodes.size() + n_texels * L);
    out.tags.resize(out.nodes.size());
    Node* slots = out.nodes.data() + map.texel_offset * L;
    SurfaceTag* slot_tags = out.tags.data() + map.texel_offset * L;
    const float eps = params.epsilon;
    const Node* staging = target;
    const SurfaceTag* staging_tags = target_tags;
    ex.parallel_for("light pass: fixed layout", n_texels, CDSM_LAMBDA(uint64_t i) {
      const TexelRange h = heads[i];
      FixedFit fit = write_fixed_texel(Span<const Node>{staging + h.offset, h.count}, staging_tags + h.offset, eps,
                                       slots + i * L, slot_tags + i * L, int(L));
      atomic_add(&ctr->stored, (unsigned long long)fit.count);
      atomic_max(&ctr->max_nodes, uint32_t(fit.count));
      if (fit.recompressed) atomic_add(&ctr->layout_overflow_texels, 1u);
      if (fit.recompressed || overflow[i] != 0u) {
        atomic_add(&ctr->recompressed_texels, 1u);
        atomic_max(&ctr->max_extra_error_bits, float_bits(extra[i] + fit.extra_error));
      }
    });
  } else if (kind == kDsmChunked) {
    out.chunks.resize(chunk_base + c.chunks * C);
    out.tags.resize(out.chunks.size());
    Chunk* pool = out.chunks.data();
    SurfaceTag* pool_tags = out.tags.data();
    TexelRange* store_heads = out.texels.data() + map.texel_offset;
    const Node* staging = target;
    const SurfaceTag* staging_tags = target_tags;
    ex.parallel_for("light pass: chunked layout", n_tiles, CDSM_LAMBDA(uint64_t tile) {
      const int x0 = int(tile % uint64_t(tiles_x)) * kDsmTile, y0 = int(tile / uint64_t(tiles_x)) * kDsmTile;
      uint32_t tile_counts[kChunkTileTexels];
      uint64_t texel[kChunkTileTexels];
      TexelRange tile_heads[kChunkTileTexels];
      for (int k = 0; k < kChunkTileTexels; ++k) {
        const int tx = x0 + k % kDsmTile, ty = y0 + k / kDsmTile;
        const bool in = tx < res && ty < height;
        texel[k] = in ? uint64_t(ty) * res + tx : 0;
        tile_counts[k] = in ? heads[texel[k]].count : 0u;
      }
      write_chunked_tile(
          tile_counts, kChunkTileTexels, [&](int k) { return staging + heads[texel[k]].offset; },
          [&](int k) { return staging_tags + heads[texel[k]].offset; },
          uint32_t(chunk_base + uint64_t(tile_first[tile]) * C), C, pool, pool_tags, tile_heads);
      for (int k = 0; k < kChunkTileTexels; ++k) {
        const int tx = x0 + k % kDsmTile, ty = y0 + k / kDsmTile;
        if (tx < res && ty < height) store_heads[texel[k]] = tile_heads[k];
      }
    });
  }
  out.texel_count += n_texels;

  ex.download(&c, ctr, sizeof c);
  if (c.mismatches != 0)
    throw std::logic_error("light pass: " + std::to_string(c.mismatches) +
                           " texels wrote a different node count than they counted (the two passes disagree)");
  DsmBuildStats stats;
  stats.layout = kind;
  stats.rgb = params.rgb;
  stats.texels = n_texels;
  stats.nodes = c.stored;
  stats.max_nodes = c.max_nodes;
  stats.max_built_nodes = c.max_built_nodes;
  stats.overflow_texels = c.recompressed_texels;
  stats.layout_overflow_texels = c.layout_overflow_texels;
  stats.max_extra_error = bits_float(c.max_extra_error_bits);
  stats.walk.enclosing_overflow = c.walk[0];
  stats.walk.match_overflow = c.walk[1];
  stats.walk.unmatched = c.walk[2];
  stats.walk.march_lengthened = c.walk[3];
  switch (kind) {
    case kDsmFixed:
      stats.node_bytes_allocated = n_texels * L * sizeof(Node);
      stats.node_bytes_used = stats.nodes * sizeof(Node);
      stats.tag_bytes = n_texels * L * sizeof(SurfaceTag);
      break;
    case kDsmChunked:
      stats.chunks = c.chunks;
      stats.index_bytes = n_texels * sizeof(TexelRange);
      stats.node_bytes_allocated = stats.chunks * C * sizeof(Chunk);
      stats.node_bytes_used = stats.nodes * sizeof(Chunk);
      stats.tag_bytes = stats.chunks * C * sizeof(SurfaceTag);
      break;
    default:
      stats.index_bytes = n_texels * sizeof(TexelRange);
      stats.node_bytes_allocated = stats.nodes * sizeof(Node);
      stats.node_bytes_used = stats.nodes * sizeof(Node);
      stats.tag_bytes = stats.nodes * sizeof(SurfaceTag);
  }
  stats.slack_bytes = stats.node_bytes_allocated - stats.node_bytes_used;
  return stats;
}

}  // namespace cdsm::exec
