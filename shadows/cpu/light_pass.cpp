// cpu driver of the light pass: one map into one of the three DSM layouts
// (DESIGN.md §3). Tiles of 8x8 texels run in parallel; each texel's nodes go
// to a bounded per-texel buffer first, then into the layout.
#include <tbb/combinable.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <limits>
#include <stdexcept>
#include <string>

#include "cpu/backend.h"

namespace cdsm {
namespace {

bool same_layout(const DsmLayoutParams& a, const DsmLayoutParams& b) {
  if (a.layout != b.layout) return false;
  if (a.layout == kDsmFixed) return a.fixed_layers == b.fixed_layers;
  if (a.layout == kDsmChunked) return a.chunk_nodes == b.chunk_nodes;
  return true;
}

void check_layout(const DsmLayoutParams& p) {
  if (p.layout > kDsmChunked) throw std::invalid_argument("build_dsm: unknown DSM layout " + std::to_string(p.layout));
  if (p.layout == kDsmFixed && (p.fixed_layers < 2 || p.fixed_layers > 4096))
    throw std::invalid_argument("build_dsm: fixed_layers must be within [2, 4096]");
  if (p.layout == kDsmChunked && (p.chunk_nodes < 1 || p.chunk_nodes > 4096))
    throw std::invalid_argument("build_dsm: chunk_nodes must be within [1, 4096]");
}

// The first map after clear() sets the buffers' layout; all maps share it.
void adopt_layout(DsmBuffers& out, const DsmLayoutParams& p) {
  if (out.maps.empty()) {
    out.layout = p;
  } else if (!same_layout(out.layout, p)) {
    throw std::logic_error("DsmBuffers: maps of different layouts cannot share buffers");
  }
}

void check_u32(uint64_t v, const char* what) {
  if (v > std::numeric_limits<uint32_t>::max())
    throw std::length_error(std::string("DSM ") + what + " exceed 2^32 entries");
}

// Per-thread scratch: the node buffers of one tile's texels, and the
// working memory of node removal when a texel overflows (one at a time).
struct Scratch {
  std::vector<DsmNode> nodes;       // kDsmTile^2 buffers of K nodes
  std::vector<DsmNodeRgb> rgb;      // the same for RGB maps (allocated when one is built)
  std::vector<SurfaceTag> tags;     // the buffers' node tags (K per texel)
  std::vector<uint32_t> counts;     // nodes per texel, tile order
  std::vector<TexelRange> heads;    // chunked: headers, tile order
  std::vector<uint32_t> rm_words;   // 4 K: prev, next, heap, heap position
  std::vector<float> rm_floats;     // 2 K: cost, span error
  RemovalScratch removal(int k) {
    return {rm_words.data(), rm_words.data() + k, rm_words.data() + 2 * k, rm_words.data() + 3 * k,
            rm_floats.data(), rm_floats.data() + k};
  }
  // Texel k's buffer in the tile (scalar: with the removal heap; RGB: scan).
  NodeBuffer buffer(int k, int cap, DsmNode*) {
    NodeBuffer b{nodes.data() + size_t(k) * cap, cap};
    b.scratch = removal(cap);
    b.tags = tags_of(k, cap);
    return b;
  }
  RgbNodeBuffer buffer(int k, int cap, DsmNodeRgb*) {
    if (rgb.empty()) rgb.resize(size_t(kDsmTile) * kDsmTile * size_t(cap));
    RgbNodeBuffer b{rgb.data() + size_t(k) * cap, cap};
    b.tags = tags_of(k, cap);
    return b;
  }
  SurfaceTag* tags_of(int k, int cap) { return tags.data() + size_t(k) * cap; }
  DsmNode* nodes_of(int k, int cap, DsmNode*) { return nodes.data() + size_t(k) * cap; }
  DsmNodeRgb* nodes_of(int k, int cap, DsmNodeRgb*) { return rgb.data() + size_t(k) * cap; }
};


// Appends one kind's arrays of src to dst (headers, links re-based).
template <class Node, class Chunk>
void append_arrays(const DsmLayoutParams& layout, const std::vector<TexelRange>& src_texels,
                   const std::vector<Node>& src_nodes, const std::vector<Chunk>& src_chunks,
                   const std::vector<SurfaceTag>& src_tags, uint64_t src_texel_count, DsmArraysRef<Node, Chunk> dst) {
  dst.texel_count += src_texel_count;
  dst.tags.insert(dst.tags.end(), src_tags.begin(), src_tags.end());
  switch (layout.layout) {
    case kDsmFixed:
      dst.nodes.insert(dst.nodes.end(), src_nodes.begin(), src_nodes.end());
      break;
    case kDsmChunked: {
      const uint32_t base = uint32_t(dst.chunks.size());
      check_u32(uint64_t(dst.chunks.size()) + src_chunks.size(), "chunk slots");
      for (TexelRange r : src_texels) {
        if (r.offset != kChunkEnd) r.offset += base;
        dst.texels.push_back(r);
      }
      dst.chunks.reserve(dst.chunks.size() + src_chunks.size());
      for (Chunk c : src_chunks) {
        if (c.next != kChunkEnd) c.next += base;
        dst.chunks.push_back(c);
      }
      break;
    }
    default: {
      const uint32_t base = uint32_t(dst.nodes.size());
      check_u32(uint64_t(dst.nodes.size()) + src_nodes.size(), "nodes");
      for (TexelRange r : src_texels) {
        r.offset += base;
        dst.texels.push_back(r);
      }
      dst.nodes.insert(dst.nodes.end(), src_nodes.begin(), src_nodes.end());
    }
  }
}


}  // namespace

void DsmBuffers::append(const DsmBuffers& src) {
  if (src.maps.empty()) return;
  adopt_layout(*this, src.layout);
  for (DsmMap m : src.maps) {
    m.texel_offset += m.rgb ? rgb.texel_count : texel_count;
    maps.push_back(m);
  }
  append_arrays(layout, src.texels, src.nodes, src.chunks, src.tags, src.texel_count, grey_arrays(*this));
  append_arrays(layout, src.rgb.texels, src.rgb.nodes, src.rgb.chunks, src.rgb.tags, src.rgb.texel_count,
                rgb_arrays(*this));
}

namespace {

// One map of either node kind into its kind's arrays `out`.
template <class Node, class Chunk>
DsmBuildStats build_kind(const SceneView& scene, const LightPassParams& params, FragmentLists frags,
                         DsmArraysRef<Node, Chunk> out, DsmMap& map, const DsmLayoutParams& layout, int node_capacity) {
  const uint32_t kind = layout.layout;
  const int res = params.view.width;
  const int height = params.view.height;
  const int tiles_x = (res + kDsmTile - 1) / kDsmTile;
  const int tiles_y = (height + kDsmTile - 1) / kDsmTile;
  const size_t n_texels = size_t(res) * size_t(height);
  const uint32_t L = uint32_t(layout.fixed_layers);
  const uint32_t C = uint32_t(layout.chunk_nodes);

  map.view = params.view;
  map.res = uint32_t(res);
  map.rgb = params.rgb ? 1u : 0u;
  map.texel_offset = out.texel_count;
  out.texel_count += n_texels;
  TexelRange* headers = nullptr;
  if (kind != kDsmFixed) {
    out.texels.resize(out.texels.size() + n_texels, TexelRange{kind == kDsmChunked ? kChunkEnd : 0u, 0u});
    headers = out.texels.data() + map.texel_offset;
  }
  Node* fixed_slots = nullptr;
  SurfaceTag* fixed_tags = nullptr;
  if (kind == kDsmFixed) {
    out.nodes.resize(out.nodes.size() + n_texels * L);
    out.tags.resize(out.nodes.size());
    fixed_slots = out.nodes.data() + map.texel_offset * L;
    fixed_tags = out.tags.data() + map.texel_offset * L;
  }

  // The pool of packed nodes or chunked slots: a first guess of a few nodes
  // per texel, grown to the exact need (and the pass redone) when short.
  if (kind == kDsmChunked && out.chunks.size() % C != 0) throw std::logic_error("DsmBuffers: chunk pool not whole chunks");
  const size_t pool_base = kind == kDsmChunked ? out.chunks.size() / C : out.nodes.size();  // nodes or chunks
  size_t capacity = 0;  // packed: nodes; chunked: chunks
  if (kind == kDsmPacked) capacity = std::max<size_t>(n_texels * 4, 1024);
  if (kind == kDsmChunked) capacity = std::max<size_t>(n_texels * 4 / C + size_t(tiles_x) * tiles_y, 16);

  DsmBuildStats stats;
  stats.layout = kind;
  stats.texels = n_texels;

  tbb::enumerable_thread_specific<Scratch> scratch([&] {
    Scratch s;
    if (!params.rgb) s.nodes.resize(size_t(kDsmTile) * kDsmTile * size_t(node_capacity));
    s.tags.resize(size_t(kDsmTile) * kDsmTile * size_t(node_capacity));
    s.counts.resize(size_t(kDsmTile) * kDsmTile);
    s.heads.resize(size_t(kDsmTile) * kDsmTile);
    s.rm_words.resize(4 * size_t(node_capacity));
    s.rm_floats.resize(2 * size_t(node_capacity));
    return s;
  });

  for (;;) {
    if (kind == kDsmPacked) {
      out.nodes.resize(pool_base + capacity);
      out.tags.resize(pool_base + capacity);
    }
    if (kind == kDsmChunked) {
      check_u32(uint64_t(pool_base + capacity) * C, "chunk slots");
      out.chunks.resize((pool_base + capacity) * C, empty_chunk<Chunk>());
      out.tags.resize((pool_base + capacity) * C, kNoSurface);
    }
    std::atomic<uint64_t> used{0};  // packed: nodes; chunked: chunks (the thesis's g_c)
    tbb::combinable<DsmBuildStats> partial;
    tbb::parallel_for(tbb::blocked_range<int>(0, tiles_x * tiles_y), [&](const tbb::blocked_range<int>& r) {
      Scratch& s = scratch.local();
      DsmBuildStats& st = partial.local();
      for (int tile = r.begin(); tile < r.end(); ++tile) {
        const int x0 = (tile % tiles_x) * kDsmTile, y0 = (tile / tiles_x) * kDsmTile;
        uint32_t tile_total = 0;
        for (int k = 0; k < kDsmTile * kDsmTile; ++k) {
          const int tx = x0 + k % kDsmTile, ty = y0 + k / kDsmTile;
          s.counts[k] = 0;
          if (tx >= res || ty >= height) continue;
          auto buf = s.buffer(k, node_capacity, static_cast<Node*>(nullptr));
          build_texel(scene, params, frags.pixel(tx, ty), tx, ty, buf, st.walk);
          st.max_built_nodes = std::max(st.max_built_nodes, uint32_t(buf.count));
          float extra = buf.extra_error;
          bool recompressed = buf.removed > 0;
          uint32_t count = uint32_t(buf.count);
          if (kind == kDsmFixed) {
            const size_t slot = (size_t(ty) * res + tx) * L;
            FixedFit fit = write_fixed_texel(Span<const Node>{buf.nodes, uint64_t(buf.count)}, buf.tags, params.epsilon,
                                             fixed_slots + slot, fixed_tags + slot, int(L));
            count = uint32_t(fit.count);
            if (fit.recompressed) {
              ++st.layout_overflow_texels;
              recompressed = true;
              extra += fit.extra_error;
            }
          }
          if (recompressed) {
            ++st.overflow_texels;
            st.max_extra_error = std::max(st.max_extra_error, extra);
          }
          s.counts[k] = count;
          tile_total += count;
          st.max_nodes = std::max(st.max_nodes, count);
          st.nodes += count;
        }
        const auto nodes_of = [&](int k) { return s.nodes_of(k, node_capacity, static_cast<Node*>(nullptr)); };
        if (kind == kDsmPacked) {
          // One reservation per tile, then a tile-local prefix sum.
          uint64_t at = used.fetch_add(tile_total);
          for (int k = 0; k < kDsmTile * kDsmTile; ++k) {
            const int tx = x0 + k % kDsmTile, ty = y0 + k / kDsmTile;
            if (tx >= res || ty >= height) continue;
            TexelRange& hdr = headers[size_t(ty) * res + tx];
            hdr.offset = uint32_t(pool_base + at);
            hdr.count = s.counts[k];
            if (at + s.counts[k] <= capacity) {
              std::copy_n(nodes_of(k), s.counts[k], out.nodes.data() + pool_base + at);
              std::copy_n(s.tags_of(k, node_capacity), s.counts[k], out.tags.data() + pool_base + at);
            }
            at += s.counts[k];
          }
        } else if (kind == kDsmChunked) {
          // One reservation of the tile's chunks (Alg. 4.1, hd/dsm_chunked.h).
          uint32_t chunks = tile_chunks(tile_total, C);
          uint64_t first = used.fetch_add(chunks);
          if (first + chunks > capacity) continue;  // short pool: only counted, redone
          write_chunked_tile(
              s.counts.data(), kDsmTile * kDsmTile, nodes_of, [&](int k) { return s.tags_of(k, node_capacity); },
              uint32_t((pool_base + first) * C), C, out.chunks.data(), out.tags.data(), s.heads.data());
          for (int k = 0; k < kDsmTile * kDsmTile; ++k) {
            const int tx = x0 + k % kDsmTile, ty = y0 + k / kDsmTile;
            if (tx < res && ty < height) headers[size_t(ty) * res + tx] = s.heads[k];
          }
        }
      }
    });
    const uint64_t total = used.load();
    if (kind == kDsmFixed || total <= capacity) {
      if (kind == kDsmPacked) {
        check_u32(pool_base + total, "nodes");
        out.nodes.resize(pool_base + total);  // exact: no slack
        out.tags.resize(pool_base + total);
      }
      if (kind == kDsmChunked) {
        out.chunks.resize((pool_base + total) * C);
        out.tags.resize((pool_base + total) * C);
      }
      partial.combine_each([&](const DsmBuildStats& p) {
        stats.nodes += p.nodes;
        stats.max_nodes = std::max(stats.max_nodes, p.max_nodes);
        stats.max_built_nodes = std::max(stats.max_built_nodes, p.max_built_nodes);
        stats.overflow_texels += p.overflow_texels;
        stats.layout_overflow_texels += p.layout_overflow_texels;
        stats.max_extra_error = std::max(stats.max_extra_error, p.max_extra_error);
        stats.walk.add(p.walk);
      });
      if (kind == kDsmChunked) stats.chunks = total;
      break;
    }
    capacity = total;  // grow to the exact need and redo
    ++stats.pool_retries;
  }

  switch (kind) {
    case kDsmFixed:
      stats.index_bytes = 0;
      stats.node_bytes_allocated = uint64_t(n_texels) * L * sizeof(Node);
      stats.node_bytes_used = stats.nodes * sizeof(Node);
      stats.tag_bytes = uint64_t(n_texels) * L * sizeof(SurfaceTag);
      break;
    case kDsmChunked:
      stats.index_bytes = uint64_t(n_texels) * sizeof(TexelRange);
      stats.node_bytes_allocated = stats.chunks * C * sizeof(Chunk);
      stats.node_bytes_used = stats.nodes * sizeof(Chunk);
      stats.tag_bytes = stats.chunks * C * sizeof(SurfaceTag);
      break;
    default:
      stats.index_bytes = uint64_t(n_texels) * sizeof(TexelRange);
      stats.node_bytes_allocated = stats.nodes * sizeof(Node);
      stats.node_bytes_used = stats.nodes * sizeof(Node);
      stats.tag_bytes = stats.nodes * sizeof(SurfaceTag);
  }
  stats.slack_bytes = stats.node_bytes_allocated - stats.node_bytes_used;
  stats.rgb = params.rgb;
  return stats;
}

}  // namespace

DsmBuildStats build_dsm(const SceneView& scene, const LightPassParams& params, FragmentLists frags,
                        DsmBuffers& out, const DsmLayoutParams& layout, int node_capacity) {
  check_layout(layout);
  adopt_layout(out, layout);
  if (params.rgb && params.method != kMethodDsm)
    throw std::invalid_argument("build_dsm: the baselines are grey (no RGB maps)");
  DsmMap map{};
  DsmBuildStats stats = params.rgb ? build_kind(scene, params, frags, rgb_arrays(out), map, layout, node_capacity)
                                   : build_kind(scene, params, frags, grey_arrays(out), map, layout, node_capacity);
  out.maps.push_back(map);
  return stats;
}

}  // namespace cdsm
