// The cpu backend: TBB drivers over tiles that call the CDSM_HD kernels
// (light pass -> packed DSM, camera pass -> image). DESIGN.md §5.
#pragma once

#include <cstdint>
#include <vector>

#include "cpu/fragments_cpu.h"
#include "hd/camera_pass.h"
#include "hd/light_pass.h"

namespace cdsm {

// Host owner of all deep shadow maps of a frame (packed layout).
struct DsmBuffers {
  std::vector<DsmMap> maps;
  std::vector<TexelRange> texels;  // all maps' headers, map by map
  std::vector<DsmNode> nodes;      // exactly the nodes used
  DsmStorage storage() const {
    return {{texels.data(), texels.size()}, {nodes.data(), nodes.size()}};
  }
  void clear() {
    maps.clear();
    texels.clear();
    nodes.clear();
  }
};

struct DsmBuildStats {
  uint64_t texels = 0;
  uint64_t nodes = 0;
  uint32_t max_nodes = 0;             // per texel
  uint64_t overflow_texels = 0;       // texels re-compressed to fit the node buffer
  float max_extra_error = 0.0f;       // error bound added by those re-compressions
  uint64_t pool_retries = 0;          // node-pool grow-and-redo passes
  WalkStats walk;
};

inline constexpr int kDsmTile = 8;             // texels per tile side
inline constexpr int kTexelNodeCapacity = 1024;  // K: per-texel node buffer (cpu)

// Builds one map from its light-view fragment lists (sorted in place) and
// appends it to `out` (headers + nodes). Tiles of 8x8 texels each compute
// their nodes, take a tile-local prefix sum and reserve their exact node
// count with one atomic add; if the pool is too small it grows to the
// exact total and the pass is redone.
DsmBuildStats build_dsm(const SceneView& scene, const LightPassParams& params, FragmentLists frags,
                        DsmBuffers& out, int node_capacity = kTexelNodeCapacity);

// Shades every pixel of the camera view (fragments sorted in place) into
// `rgb` (3 floats per pixel, linear).
void render_camera(const SceneView& scene, const ShadowView& shadows, const CameraPassParams& params,
                   FragmentLists frags, std::vector<float>& rgb, WalkStats& walk);

}  // namespace cdsm
