// cpu driver of the light pass: packed DSM with exact allocation per tile.
#include <tbb/combinable.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>

#include "cpu/backend.h"

namespace cdsm {
namespace {

void add(WalkStats& a, const WalkStats& b) {
  a.enclosing_overflow += b.enclosing_overflow;
  a.match_overflow += b.match_overflow;
  a.unmatched += b.unmatched;
}

}  // namespace

DsmBuildStats build_dsm(const SceneView& scene, const LightPassParams& params, FragmentLists frags,
                        DsmBuffers& out, int node_capacity) {
  const int res = params.view.width;
  const int tiles_x = (res + kDsmTile - 1) / kDsmTile;
  const int tiles_y = (params.view.height + kDsmTile - 1) / kDsmTile;
  const size_t n_texels = size_t(res) * size_t(params.view.height);

  DsmMap map{};
  map.view = params.view;
  map.res = uint32_t(res);
  map.texel_offset = out.texels.size();
  out.texels.resize(out.texels.size() + n_texels, TexelRange{0, 0});
  TexelRange* headers = out.texels.data() + map.texel_offset;

  const size_t node_base = out.nodes.size();
  // First guess of the pool: a few nodes per texel; grows exactly if short.
  size_t capacity = std::max<size_t>(n_texels * 4, 1024);
  DsmBuildStats stats;
  stats.texels = n_texels;

  struct Scratch {
    std::vector<DsmNode> nodes;
    std::vector<uint32_t> counts;
  };
  tbb::enumerable_thread_specific<Scratch> scratch([&] {
    Scratch s;
    s.nodes.resize(size_t(kDsmTile) * kDsmTile * size_t(node_capacity));
    s.counts.resize(size_t(kDsmTile) * kDsmTile);
    return s;
  });

  for (;;) {
    out.nodes.resize(node_base + capacity);
    std::atomic<uint64_t> used{0};
    tbb::combinable<DsmBuildStats> partial;
    tbb::parallel_for(tbb::blocked_range<int>(0, tiles_x * tiles_y), [&](const tbb::blocked_range<int>& r) {
      Scratch& s = scratch.local();
      DsmBuildStats& st = partial.local();
      for (int tile = r.begin(); tile < r.end(); ++tile) {
        int x0 = (tile % tiles_x) * kDsmTile, y0 = (tile / tiles_x) * kDsmTile;
        uint32_t tile_total = 0;
        for (int k = 0; k < kDsmTile * kDsmTile; ++k) {
          int tx = x0 + k % kDsmTile, ty = y0 + k / kDsmTile;
          s.counts[k] = 0;
          if (tx >= res || ty >= params.view.height) continue;
          NodeBuffer buf{s.nodes.data() + size_t(k) * node_capacity, node_capacity};
          build_texel(scene, params, frags.pixel(tx, ty), tx, ty, buf, st.walk);
          s.counts[k] = uint32_t(buf.count);
          tile_total += uint32_t(buf.count);
          st.max_nodes = std::max(st.max_nodes, uint32_t(buf.count));
          if (buf.recompressions > 0) {
            ++st.overflow_texels;
            st.max_extra_error = std::max(st.max_extra_error, buf.extra_error);
          }
        }
        // One reservation per tile, then a tile-local prefix sum.
        uint64_t at = used.fetch_add(tile_total);
        for (int k = 0; k < kDsmTile * kDsmTile; ++k) {
          int tx = x0 + k % kDsmTile, ty = y0 + k / kDsmTile;
          if (tx >= res || ty >= params.view.height) continue;
          TexelRange& hdr = headers[size_t(ty) * res + tx];
          hdr.offset = uint32_t(node_base + at);
          hdr.count = s.counts[k];
          if (at + s.counts[k] <= capacity)
            std::copy_n(s.nodes.data() + size_t(k) * node_capacity, s.counts[k],
                        out.nodes.data() + node_base + at);
          at += s.counts[k];
        }
      }
    });
    uint64_t total = used.load();
    if (total <= capacity) {
      out.nodes.resize(node_base + total);  // exact: no slack
      partial.combine_each([&](const DsmBuildStats& p) {
        stats.max_nodes = std::max(stats.max_nodes, p.max_nodes);
        stats.overflow_texels += p.overflow_texels;
        stats.max_extra_error = std::max(stats.max_extra_error, p.max_extra_error);
        add(stats.walk, p.walk);
      });
      stats.nodes = total;
      break;
    }
    capacity = total;  // grow to the exact need and redo
    ++stats.pool_retries;
  }
  out.maps.push_back(map);
  return stats;
}

}  // namespace cdsm
