// The compiled scene in an executor's memory (ExecBackend's scene part):
// the arrays of SceneBuffers, uploaded whole or by the ranges an edit
// changed, and the kernels' view of them.
#pragma once

#include "backend/backend.h"
#include "exec/exec.h"

namespace cdsm::exec {

template <class Ex>
class ExecSceneStore {
 public:
  explicit ExecSceneStore(Ex& ex)
      : tri_vertices_(ex),
        tri_normals_(ex),
        tri_object_(ex),
        objects_(ex),
        volumes_(ex),
        voxels_(ex),
        macro_max_(ex),
        nano_pool_(ex),
        bvh_(ex),
        bvh_prims_(ex) {}

  // All of the arrays on `everything` (or the first call, or a change of
  // their sizes), else only what `change` names — a moved object's
  // triangles and the BVH nodes a refit changed, the object or volume data
  // when edited. `sb` stays the host's scene (host()) until the next call.
  void update(const SceneBuffers& sb, const SceneChange& change) {
    const bool all = change.everything || host_ == nullptr || tri_vertices_.size() != sb.tri_vertices.size() ||
                     bvh_.size() != sb.bvh.size() || objects_.size() != sb.objects.size();
    host_ = &sb;
    if (all) {
      tri_vertices_.assign(sb.tri_vertices);
      tri_normals_.assign(sb.tri_normals);
      tri_object_.assign(sb.tri_object);
      objects_.assign(sb.objects);
      bvh_.assign(sb.bvh);
      bvh_prims_.assign(sb.bvh_prims);
    } else {
      for (const IndexRange& r : change.triangles) {
        const uint64_t v = uint64_t(r.first) * 3, n = uint64_t(r.count) * 3;
        tri_vertices_.write(v, sb.tri_vertices.data() + v, n);
        if (!sb.tri_normals.empty()) tri_normals_.write(v, sb.tri_normals.data() + v, n);
      }
      if (change.bvh) {
        bvh_.assign(sb.bvh);
        bvh_prims_.assign(sb.bvh_prims);
      } else {
        for (const IndexRange& r : change.bvh_nodes) bvh_.write(r.first, sb.bvh.data() + r.first, r.count);
      }
      if (change.objects) objects_.assign(sb.objects);
    }
    if (all || change.volumes || change.grids) volumes_.assign(sb.volumes);
    if (all || change.grids) {
      voxels_.assign(sb.voxels);
      macro_max_.assign(sb.macro_max);
      nano_pool_.assign(reinterpret_cast<const unsigned char*>(sb.nano_pool.data()),
                        sb.nano_pool.size() * sizeof(GridBlock));
    }
  }

  // The host's scene of the last update (null before the first).
  const SceneBuffers* host() const { return host_; }

  // The kernels' view of the arrays (executor memory).
  SceneView view() const {
    SceneView v;
    v.tri_vertices = tri_vertices_.cspan();
    v.tri_normals = tri_normals_.cspan();
    v.tri_object = tri_object_.cspan();
    v.objects = objects_.cspan();
    v.volumes = volumes_.cspan();
    v.voxels = voxels_.cspan();
    v.macro_max = macro_max_.cspan();
    v.nano_pool = {nano_pool_.data(), nano_pool_.size()};
    v.bvh = bvh_.cspan();
    v.bvh_prims = bvh_prims_.cspan();
    return v;
  }

 private:
  ExecArray<Vec3, Ex> tri_vertices_, tri_normals_;
  ExecArray<uint32_t, Ex> tri_object_;
  ExecArray<ObjectData, Ex> objects_;
  ExecArray<VolumeData, Ex> volumes_;
  ExecArray<float, Ex> voxels_, macro_max_;
  ExecArray<unsigned char, Ex> nano_pool_;
  ExecArray<BvhNode, Ex> bvh_;
  ExecArray<uint32_t, Ex> bvh_prims_;
  const SceneBuffers* host_ = nullptr;
};

}  // namespace cdsm::exec
