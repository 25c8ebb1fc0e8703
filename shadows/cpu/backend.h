// The cpu backend: TBB drivers over tiles that call the CDSM_HD kernels
// (light pass -> DSM in one of three layouts, camera pass -> image).
// DESIGN.md §3, §5.
#pragma once

#include <cstdint>
#include <vector>

#include "cpu/fragments_cpu.h"
#include "hd/camera_pass.h"
#include "hd/dsm_chunked.h"
#include "hd/dsm_fixed.h"
#include "hd/light_pass.h"

namespace cdsm {

// Which layout the maps of a frame use (DESIGN.md §3), and its parameters.
struct DsmLayoutParams {
  uint32_t layout = kDsmPacked;  // kDsmPacked / kDsmFixed / kDsmChunked
  int fixed_layers = 32;         // fixed: L, node slots per texel (>= 2)
  int chunk_nodes = 64;          // chunked: C, node slots per chunk (>= 1)
};

// One node kind's arrays of a DsmBuffers (scalar or RGB maps).
template <class Node, class Chunk>
struct DsmArrays {
  std::vector<TexelRange> texels;  // packed, chunked: headers of this kind's maps, map by map
  std::vector<Node> nodes;         // packed: exactly the nodes used; fixed: L slots per texel
  std::vector<Chunk> chunks;       // chunked: the chunk pool, C slots per chunk
  std::vector<SurfaceTag> tags;    // per slot of `nodes` (packed, fixed) or `chunks` (chunked)
  uint64_t texel_count = 0;        // this kind's texels (fixed keeps no headers)
  void clear() {
    texels.clear();
    nodes.clear();
    chunks.clear();
    tags.clear();
    texel_count = 0;
  }
};

// Host owner of all deep shadow maps of a frame, in one layout: grey maps'
// scalar nodes (the fields below) and RGB maps' nodes (`rgb`), each map's
// texel_offset counting its own kind's texels.
struct DsmBuffers {
  DsmLayoutParams layout;          // set by the first build_dsm after clear()
  std::vector<DsmMap> maps;
  std::vector<TexelRange> texels;  // packed, chunked: grey maps' headers, map by map
  std::vector<DsmNode> nodes;      // packed: exactly the nodes used; fixed: L slots per texel
  std::vector<ChunkNode> chunks;   // chunked: the chunk pool, C slots per chunk
  std::vector<SurfaceTag> tags;    // per slot of `nodes` (packed, fixed) or `chunks` (chunked)
  uint64_t texel_count = 0;        // grey maps' texels (fixed keeps no headers)
  DsmArrays<DsmNodeRgb, ChunkNodeRgb> rgb;

  DsmStorage storage() const {
    DsmStorage s;
    s.texels = {texels.data(), texels.size()};
    s.nodes = {nodes.data(), nodes.size()};
    s.chunks = {chunks.data(), chunks.size()};
    s.rgb_texels = {rgb.texels.data(), rgb.texels.size()};
    s.rgb_nodes = {rgb.nodes.data(), rgb.nodes.size()};
    s.rgb_chunks = {rgb.chunks.data(), rgb.chunks.size()};
    s.tags = {tags.data(), tags.size()};
    s.rgb_tags = {rgb.tags.data(), rgb.tags.size()};
    s.layout = layout.layout;
    s.layers = layout.layout == kDsmFixed ? uint32_t(layout.fixed_layers) : 0u;
    return s;
  }
  // Appends the maps of `src` (same layout; headers, links and offsets re-based).
  void append(const DsmBuffers& src);
  void clear() {
    maps.clear();
    texels.clear();
    nodes.clear();
    chunks.clear();
    tags.clear();
    texel_count = 0;
    rgb.clear();
  }
};

// One kind's arrays of a DsmBuffers by reference (the grey fields or `rgb`),
// for code written once for both kinds.
template <class Node, class Chunk>
struct DsmArraysRef {
  std::vector<TexelRange>& texels;
  std::vector<Node>& nodes;
  std::vector<Chunk>& chunks;
  std::vector<SurfaceTag>& tags;
  uint64_t& texel_count;
};
inline DsmArraysRef<DsmNode, ChunkNode> grey_arrays(DsmBuffers& b) {
  return {b.texels, b.nodes, b.chunks, b.tags, b.texel_count};
}
inline DsmArraysRef<DsmNodeRgb, ChunkNodeRgb> rgb_arrays(DsmBuffers& b) {
  return {b.rgb.texels, b.rgb.nodes, b.rgb.chunks, b.rgb.tags, b.rgb.texel_count};
}

// What building one map cost, in its layout. Bytes: index = per-texel
// headers; node bytes allocated = what the layout reserves for nodes, used =
// the nodes stored (chunked: with their links); slack = allocated - used.
struct DsmBuildStats {
  uint32_t layout = kDsmPacked;
  bool rgb = false;                   // RGB nodes (16 bytes; chunked slots 20) instead of scalar (8; 12)
  uint64_t texels = 0;
  uint64_t nodes = 0;                 // nodes stored
  uint32_t max_nodes = 0;             // stored, per texel
  uint32_t max_built_nodes = 0;       // per texel, before the layout's re-compression (fixed)
  uint64_t overflow_texels = 0;       // texels re-compressed (node buffer K or the layout's L)
  uint64_t layout_overflow_texels = 0;  // of those: re-compressed to fit the fixed layout's L
  float max_extra_error = 0.0f;       // error bound those re-compressions added (max over texels)
  uint64_t index_bytes = 0;
  uint64_t node_bytes_allocated = 0;
  uint64_t node_bytes_used = 0;
  uint64_t slack_bytes = 0;
  uint64_t tag_bytes = 0;             // the nodes' SurfaceTags (2 bytes per allocated node slot)
  uint64_t chunks = 0;                // chunked: chunks allocated
  uint64_t pool_retries = 0;          // node-pool grow-and-redo passes (packed, chunked)
  WalkStats walk;
};

inline constexpr int kDsmTile = 8;             // texels per tile side
inline constexpr int kTexelNodeCapacity = 1024;  // K: per-texel node buffer (cpu)

// Builds one map from its light-view fragment lists (sorted in place) and
// appends it to `out` in `layout` (the first map after out.clear() sets
// out's layout; later ones must match). Tiles of 8x8 texels each compute
// their nodes into per-texel buffers of K nodes, then
//   packed:  tile-local prefix sum, one atomic reservation of the tile's
//            exact node count;
//   fixed:   each texel writes its L slots, re-compressed when it has more;
//   chunked: one atomic reservation of the tile's chunks (hd/dsm_chunked.h).
// If a pool (packed, chunked) is too small it grows to the exact total and
// the pass is redone. params.rgb builds RGB nodes into out.rgb (same
// layout, same driver; the per-texel buffer removes by scan on overflow).
DsmBuildStats build_dsm(const SceneView& scene, const LightPassParams& params, FragmentLists frags,
                        DsmBuffers& out, const DsmLayoutParams& layout = {},
                        int node_capacity = kTexelNodeCapacity);

// Shades every pixel of the camera view (fragments sorted in place) into
// `rgb` (3 floats per pixel, linear).
void render_camera(const SceneView& scene, const ShadowView& shadows, const CameraPassParams& params,
                   FragmentLists frags, std::vector<float>& rgb, WalkStats& walk);

}  // namespace cdsm
