// Host owner of a compiled scene: flat arrays + BVH, the algorithm's plain
// input (the engine compiles its scene model into it, engine/src/scene_compile.h).
#pragma once

#include <string>
#include <vector>

#include "hd/scene_data.h"

namespace cdsm {

// 32 bytes, 32-byte aligned: the unit of the NanoVDB grid pool, so every
// grid in it starts aligned.
struct alignas(32) GridBlock {
  unsigned char bytes[32];
};

struct SceneBuffers {
  std::vector<Vec3> tri_vertices;
  std::vector<Vec3> tri_normals;
  std::vector<uint32_t> tri_object;
  std::vector<ObjectData> objects;
  std::vector<VolumeData> volumes;
  std::vector<float> voxels;
  std::vector<float> macro_max;
  std::vector<GridBlock> nano_pool;  // NanoVDB grids, each 32-byte aligned
  std::vector<BvhNode> bvh;
  std::vector<uint32_t> bvh_prims;
  std::vector<Box3> object_bounds;    // world-space box per object
  Box3 bounds;                        // whole scene
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

// Builds the BVH over the triangles already in `sb` (binned SAH).
void build_bvh(SceneBuffers& sb);

// A range of array entries [first, first + count).
struct IndexRange {
  uint32_t first = 0, count = 0;
};

// After triangles moved (the same triangles, new positions): every node's
// box recomputed bottom-up, the tree kept. Returns bvh_cost() of the result;
// `changed` (when given) receives the runs of nodes whose boxes changed.
double refit_bvh(SceneBuffers& sb, std::vector<IndexRange>* changed = nullptr);

// The tree's surface-area cost: the sum over nodes of their surface area
// (times their triangle count for leaves) over the root's. A refit tree
// whose cost grew well beyond its build's is worth rebuilding.
double bvh_cost(const SceneBuffers& sb);

}  // namespace cdsm
