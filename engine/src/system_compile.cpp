// The scene part of ShadowSystem::update() (cdsm/shadow_system.h): what the
// edits marked is compiled into the scene arrays — volumes' grids, the
// geometry arrays and BVH when objects came or went, moved objects' own
// triangle ranges with a BVH refit, surfaces — and nothing else.
#include "cdsm/fields.h"
#include "cdsm/shadow_system.h"

#include <algorithm>
#include <stdexcept>
#include <chrono>
#include <cstring>

#include "cdsm/error.h"
#include "cdsm/scene_io.h"
#include "backend_select.h"
#include "backend/backend.h"
#include "memory_budget.h"
#include "reference/reference.h"
#include "scene_compile.h"
#include "shadow_system_impl.h"
#include "stopwatch.h"

namespace cdsm {

namespace {

// A refit tree whose surface-area cost grew beyond this factor of its
// build's is rebuilt (tests/bench/bench_frames.cpp measured refit against
// rebuild; see docs/persistent-frames.md).
constexpr double kRefitCostLimit = 1.5;

// Erases [begin, begin + count) and gives the memory back.
template <class T>
void erase_range(std::vector<T>& v, uint64_t begin, uint64_t count) {
  if (count == 0) return;
  v.erase(v.begin() + ptrdiff_t(begin), v.begin() + ptrdiff_t(begin + count));
  v.shrink_to_fit();
}

}  // namespace

// Erases volume vi's data from the scene arrays (freeing it); later
// volumes' data moves down and their offsets follow.
void ShadowSystem::Impl::erase_volume_data(size_t vi) {
  const VolumeRec rec = volumes[vi];
  erase_range(sb.voxels, rec.voxel_begin, rec.voxel_count);
  erase_range(sb.nano_pool, rec.block_begin, rec.block_count);
  erase_range(sb.macro_max, rec.macro_begin, rec.macro_count);
  for (size_t k = 0; k < volumes.size(); ++k) {
    VolumeRec& o = volumes[k];
    if (k == vi || !o.compiled) continue;
    if (o.voxel_begin > rec.voxel_begin) o.voxel_begin -= rec.voxel_count;
    if (o.block_begin > rec.block_begin) o.block_begin -= rec.block_count;
    if (o.macro_begin > rec.macro_begin) o.macro_begin -= rec.macro_count;
    VolumeData& d = sb.volumes[k];
    d.voxel_offset = d.grid_kind == GridKind::Dense ? o.voxel_begin : o.block_begin * sizeof(GridBlock);
    d.macro_offset = o.macro_begin;
  }
  volumes[vi].compiled = false;
}

// Dirty volumes: compiled on their own, their old data erased from the
// scene arrays (later volumes' offsets shift down), the new data appended.
void ShadowSystem::Impl::compile_volumes(FrameStats& st) {
  for (size_t vi = 0; vi < volumes.size(); ++vi) {
    VolumeRec& rec = volumes[vi];
    if (!rec.dirty) continue;
    const Volume& v = scene.volumes[vi];
    const std::string where =
        scene.source + ": volume " + std::to_string(vi) + (v.name.empty() ? "" : " '" + v.name + "'");
    CompiledVolume cv = compile_volume(v, where);
    if (rec.compiled) erase_volume_data(vi);
    const VolumeData placed = vi < sb.volumes.size() ? sb.volumes[vi] : VolumeData{};
    rec.voxel_begin = sb.voxels.size();
    rec.block_begin = sb.nano_pool.size();
    rec.macro_begin = sb.macro_max.size();
    const uint32_t at = append_volume(sb, cv);
    rec.voxel_count = cv.voxels.size();
    rec.block_count = cv.nano_pool.size();
    rec.macro_count = cv.macro_max.size();
    VolumeData d = sb.volumes[at];
    sb.volumes.pop_back();
    // Keep the placement of its object (place_volume below redoes it).
    d.index_to_world = placed.index_to_world;
    d.world_to_index = placed.world_to_index;
    if (vi < sb.volumes.size())
      sb.volumes[vi] = d;
    else
      sb.volumes.push_back(d);
    for (size_t oi = 0; oi < objects.size(); ++oi)
      if (objects[oi].volume == rec.id) place_volume(sb.volumes[vi], v, scene.objects[oi].transform, object_where(oi));
    rec.compiled = true;
    rec.dirty = false;
    ++st.update.volumes_compiled;
  }
}

// Geometry arrays and BVH from every object (the volumes' data is kept).
void ShadowSystem::Impl::compile_structure(FrameStats& st) {
  SceneBuffers nb;
  nb.voxels = std::move(sb.voxels);
  nb.macro_max = std::move(sb.macro_max);
  nb.nano_pool = std::move(sb.nano_pool);
  nb.volumes = sb.volumes;
  try {
    std::vector<int> used(volumes.size(), -1);
    CompiledObject co;
    for (size_t oi = 0; oi < scene.objects.size(); ++oi) {
      const Object& o = scene.objects[oi];
      const std::string where = object_where(oi);
      compile_object(o, objects[oi].gpu ? objects[oi].gpu->closed : is_closed_mesh(o.mesh), where, co);
      if (objects[oi].gpu) gpu_bounds(oi, co);
      if (o.interior == InteriorKind::Volume) {
        if (!objects[oi].volume) throw Error(where, "has a volume interior but names no volume");
        const size_t vi = volume_index(objects[oi].volume);
        if (used[vi] >= 0) throw Error(where, "volume " + std::to_string(vi) + " is used by two objects");
        used[vi] = int(oi);
        co.data.volume = int32_t(vi);
        place_volume(nb.volumes[vi], scene.volumes[vi], o.transform, where);
      }
      append_object(nb, co, scene.source);
    }
    for (size_t vi = 0; vi < volumes.size(); ++vi)
      if (used[vi] < 0) throw Error(scene.source + ": volume " + std::to_string(vi), "is not used by any object");
    build_scene_bvh(nb, scene.source);
  } catch (...) {
    sb.voxels = std::move(nb.voxels);
    sb.macro_max = std::move(nb.macro_max);
    sb.nano_pool = std::move(nb.nano_pool);
    throw;
  }
  sb = std::move(nb);
  bvh_built_cost = bvh_cost(sb);
  for (ObjectRec& r : objects) r.moved = r.surface = false;
  structure_dirty = false;
  ++st.update.full_compiles;
  ++st.update.bvh_rebuilds;
  st.update.objects_compiled += uint32_t(objects.size());
}

// Moved objects: their world data recomputed into their own range, the BVH
// refitted (rebuilt when the tree degraded).
void ShadowSystem::Impl::compile_moves(FrameStats& st, SceneChange& change) {
  bool any = false;
  CompiledObject co;
  for (size_t oi = 0; oi < objects.size(); ++oi) {
    ObjectRec& rec = objects[oi];
    if (!rec.moved) continue;
    const Object& o = scene.objects[oi];
    compile_object(o, rec.closed = rec.gpu ? rec.gpu->closed : is_closed_mesh(o.mesh), object_where(oi), co);
    if (rec.gpu) gpu_bounds(oi, co);
    ObjectData& od = sb.objects[oi];
    CDSM_CHECK(co.vertices.size() == size_t(od.tri_count) * 3, "compile_moves: triangle count changed");
    if (od.volume >= 0) {
      place_volume(sb.volumes[size_t(od.volume)], scene.volumes[size_t(od.volume)], o.transform, object_where(oi));
      change.volumes = true;
    }
    std::copy(co.vertices.begin(), co.vertices.end(), sb.tri_vertices.begin() + ptrdiff_t(od.first_tri) * 3);
    std::copy(co.normals.begin(), co.normals.end(), sb.tri_normals.begin() + ptrdiff_t(od.first_tri) * 3);
    sb.object_bounds[oi] = co.bounds;
    change.triangles.push_back({od.first_tri, od.tri_count});
    rec.moved = false;
    any = true;
    ++st.update.objects_compiled;
  }
  if (!any) return;
  sb.bounds = Box3{};
  for (const Box3& b : sb.object_bounds) sb.bounds.grow(b);
  const double cost = refit_bvh(sb, &change.bvh_nodes);
  if (cost > kRefitCostLimit * bvh_built_cost) {
    build_bvh(sb);
    bvh_built_cost = bvh_cost(sb);
    change.bvh = true;
    change.bvh_nodes.clear();
    ++st.update.bvh_rebuilds;
  } else {
    ++st.update.bvh_refits;
  }
}

void ShadowSystem::Impl::gpu_bounds(size_t oi, CompiledObject& co) {
  const GpuMesh& g = *objects[oi].gpu;
  const Mat4& t = scene.objects[oi].transform;
  Box3 b;
  if (g.bounds_given) {
    for (int c = 0; c < 8; ++c)
      b.grow(t.point(Vec3{c & 1 ? g.bounds.hi.x : g.bounds.lo.x, c & 2 ? g.bounds.hi.y : g.bounds.lo.y,
                          c & 4 ? g.bounds.hi.z : g.bounds.lo.z}));
  } else {
    b = fragments.gpu_mesh_bounds(g, t);
  }
  // (no finite triangle: the placeholder's point, the object's origin)
  if (!b.empty()) co.bounds = b;
}

// GPU meshes the application changed (mark_changed) and that did not move:
// their bounds taken again, nothing else (their placeholders on the host
// and in the BVH stay as they are; the rasterizer reads them again).
// Whether any was.
bool ShadowSystem::Impl::refresh_gpu_bounds(const SceneChange& moved) {
  bool any = false;
  CompiledObject co;
  for (size_t oi = 0; oi < objects.size(); ++oi) {
    if (!objects[oi].gpu_changed) continue;
    const uint32_t first = sb.objects[oi].first_tri;
    if (std::any_of(moved.triangles.begin(), moved.triangles.end(),
                    [&](const IndexRange& t) { return t.first == first; }))
      continue;  // (compile_moves took its bounds)
    co.bounds = sb.object_bounds[oi];
    gpu_bounds(oi, co);
    sb.object_bounds[oi] = co.bounds;
    any = true;
  }
  if (any) {
    sb.bounds = Box3{};
    for (const Box3& b : sb.object_bounds) sb.bounds.grow(b);
  }
  return any;
}

// Material and shadow-flag edits: kernel data only. Whether any was made.
bool ShadowSystem::Impl::refresh_surfaces() {
  bool any = false;
  for (size_t oi = 0; oi < objects.size(); ++oi) {
    if (!objects[oi].surface) continue;
    apply_surface(scene.objects[oi], object_where(oi), sb.objects[oi]);
    objects[oi].surface = false;
    any = true;
  }
  return any;
}

void ShadowSystem::Impl::compile(FrameStats& st) {
  fragments.choose(options.fragments, fragment_name, fragment_reason);
  if (fragment_name != epoch_fragment_name) {
    epoch_fragment_name = fragment_name;
    ++geometry_epoch;
  }
  for (size_t oi = 0; oi < objects.size(); ++oi)
    if (objects[oi].gpu && fragment_name != "gl")
      throw Error(object_where(oi),
                  "stays on the GPU (add_gpu_object): only the GL rasterizer reads its triangles, "
                  "and the fragments come from the " +
                      fragment_name + " producer (" + fragment_reason + ")");
  if (!compile_pending) return;
  ++geometry_epoch;
  auto t0 = Clock::now();
  SceneChange change;
  const uint32_t volumes_before = st.update.volumes_compiled;
  compile_volumes(st);
  change.grids = st.update.volumes_compiled != volumes_before;
  if (structure_dirty) {
    compile_structure(st);
    change.everything = true;
  } else {
    compile_moves(st, change);
    refresh_gpu_bounds(change);
    change.objects = refresh_surfaces();
  }
  st.times.compile_ms = ms_since(t0);
  std::vector<FragmentSourceSelector::GpuObject> gpu;  // read on the GPU where they are
  for (size_t oi = 0; oi < objects.size(); ++oi)
    if (objects[oi].gpu)
      gpu.push_back({uint32_t(oi), objects[oi].gpu.get(), scene.objects[oi].transform, objects[oi].gpu_changed});
  st.update.gl_upload_bytes += fragments.scene_changed(sb, change, gpu);
  for (ObjectRec& r : objects) r.gpu_changed = false;
  backend->update_scene(sb, change);
  compile_pending = false;
}

}  // namespace cdsm
