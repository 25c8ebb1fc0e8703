#include "scene/scene_buffers.h"

namespace cdsm {

SceneView SceneBuffers::view() const {
  SceneView v;
  v.tri_vertices = {tri_vertices.data(), tri_vertices.size()};
  v.tri_normals = {tri_normals.data(), tri_normals.size()};
  v.tri_object = {tri_object.data(), tri_object.size()};
  v.objects = {objects.data(), objects.size()};
  v.volumes = {volumes.data(), volumes.size()};
  v.voxels = {voxels.data(), voxels.size()};
  v.macro_max = {macro_max.data(), macro_max.size()};
  v.nano_pool = {reinterpret_cast<const uint8_t*>(nano_pool.data()), nano_pool.size() * sizeof(GridBlock)};
  v.bvh = {bvh.data(), bvh.size()};
  v.bvh_prims = {bvh_prims.data(), bvh_prims.size()};
  return v;
}

}  // namespace cdsm
