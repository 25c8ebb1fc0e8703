// Host owner of a compiled scene (cdsm::Scene -> flat arrays + BVH).
#pragma once

#include <string>
#include <vector>

#include "cdsm/scene.h"
#include "hd/scene_data.h"

namespace cdsm {

struct SceneBuffers {
  std::vector<Vec3> tri_vertices;
  std::vector<Vec3> tri_normals;
  std::vector<uint32_t> tri_object;
  std::vector<ObjectData> objects;
  std::vector<VolumeData> volumes;
  std::vector<float> voxels;
  std::vector<float> macro_max;
  std::vector<SparseGrid::Block> nano_pool;  // NanoVDB grids, each 32-byte aligned
  std::vector<BvhNode> bvh;
  std::vector<uint32_t> bvh_prims;
  std::vector<Box3> object_bounds;  // world-space box per object
  Box3 bounds;                      // whole scene
  std::vector<std::string> warnings;  // content the renderer cannot honour (reported, not fatal)

  SceneView view() const;
  // Bitmask words selecting the objects for which pred(i) holds.
  template <class Pred>
  std::vector<uint32_t> mask_where(Pred pred) const {
    std::vector<uint32_t> words((objects.size() + 31) / 32, 0u);
    for (uint32_t i = 0; i < objects.size(); ++i)
      if (pred(i)) words[i >> 5] |= 1u << (i & 31u);
    return words;
  }
};

// Flattens the scene: world-space triangles, per-object data, volumes with
// macro-cells, and a BVH. Throws cdsm::Error on invalid content (NaN in a
// vertex or transform, a bad volume reference, too many triangles).
SceneBuffers compile_scene(const Scene& scene);

// Builds the BVH over the triangles already in `sb` (binned SAH).
void build_bvh(SceneBuffers& sb);

}  // namespace cdsm
