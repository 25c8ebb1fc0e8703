// The persistent shadow system (cdsm/shadow_system.h): edits mark what they
// invalidate; update() compiles only that and runs the frame.
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

namespace cdsm {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// A refit tree whose surface-area cost grew beyond this factor of its
// build's is rebuilt (tests/bench/bench_frames.cpp measured refit against
// rebuild; see docs/persistent-frames.md).
constexpr double kRefitCostLimit = 1.5;

bool finite_matrix(const Mat4& m) {
  for (auto& row : m.m)
    for (float v : row)
      if (!is_finite(v)) return false;
  return true;
}

template <class T>
uint64_t capacity_bytes(const std::vector<T>& v) {
  return uint64_t(v.capacity()) * sizeof(T);
}

uint64_t scene_bytes(const SceneBuffers& sb) {
  return capacity_bytes(sb.tri_vertices) + capacity_bytes(sb.tri_normals) + capacity_bytes(sb.tri_object) +
         capacity_bytes(sb.objects) + capacity_bytes(sb.volumes) + capacity_bytes(sb.voxels) +
         capacity_bytes(sb.macro_max) + capacity_bytes(sb.nano_pool) + capacity_bytes(sb.bvh) +
         capacity_bytes(sb.bvh_prims) + capacity_bytes(sb.object_bounds);
}

// Erases [begin, begin + count) and gives the memory back.
template <class T>
void erase_range(std::vector<T>& v, uint64_t begin, uint64_t count) {
  if (count == 0) return;
  v.erase(v.begin() + ptrdiff_t(begin), v.begin() + ptrdiff_t(begin + count));
  v.shrink_to_fit();
}

void add_walk(FrameStats& st, const WalkStats& w) {
  st.unmatched_fragments += w.unmatched;
  st.enclosing_overflow += w.enclosing_overflow;
  st.match_overflow += w.match_overflow;
  st.march_lengthened += w.march_lengthened;
}

}  // namespace

const char* to_string(RebuildReason r) {
  switch (r) {
    case RebuildReason::New: return "new";
    case RebuildReason::Settings: return "settings";
    case RebuildReason::Light: return "light";
    case RebuildReason::Members: return "members";
    case RebuildReason::Frustum: return "frustum";
    case RebuildReason::Content: return "content";
  }
  return "?";
}

// The backend's kernel times since the last take (the exec backends: CUDA
// events on the cuda backend), into `t.kernels`; the fragment producer's
// launches ("fragments: ...", and "scan: ...", its offsets: no other pass
// scans) add to `fragments_ms`, the others to `other_ms`.
static void take_kernel_times(ShadowBackend& backend, StageTimes& t, double& fragments_ms, double& other_ms) {
  for (const exec::StageTime& k : backend.take_stage_times()) {
    const bool producer = k.name.rfind("fragments", 0) == 0 || k.name.rfind("scan", 0) == 0;
    (producer ? fragments_ms : other_ms) += k.ms;
    auto it = std::find_if(t.kernels.begin(), t.kernels.end(), [&](const KernelTime& x) { return x.name == k.name; });
    if (it == t.kernels.end()) it = t.kernels.insert(t.kernels.end(), KernelTime{k.name, 0.0, 0});
    it->ms += k.ms;
    it->launches += k.launches;
  }
}

// The backend's host <-> backend bytes since the last take, into `u`.
static void add_transfers(ShadowBackend& backend, UpdateStats& u) {
  const TransferBytes t = backend.take_transfers();
  u.host_to_backend_bytes += t.host_to_backend;
  u.backend_to_host_bytes += t.backend_to_host;
}

// ---- Impl -------------------------------------------------------------------

ShadowSystem::Impl::Impl(const SystemOptions& o) : options(o) {
  scene.source = o.source;
  if (o.gl_context == GlContextUse::Application) {
    gl = make_system_gl(o.source);
    if (!o.private_fragment_context) fragments.use_context(system_context(*gl));
  }
  // Auto takes cuda only where the GL context this system uses (if any) is
  // on the CUDA device: the application's (current now), or the headless
  // one the fragment rasterizer makes.
  GlUse gl_use = GlUse::None;
  if (o.gl_context == GlContextUse::Application)
    gl_use = GlUse::Current;
  else if (o.fragments == FragmentSource::Auto || o.fragments == FragmentSource::Gl)
    gl_use = default_gl_use();
  BackendChoice c = make_backend(o.backend, gl_use);
  backend = std::move(c.backend);
  backend_name = c.name;
  backend_reason = c.reason;
  fragments.use_backend(backend.get());
}

ShadowSystem::Impl::~Impl() {
  // GL buffers a backend registered with CUDA are unregistered with the
  // context current where it can be made so (the backend dies before `gl`).
  if (gl) try_make_current(*gl);
}

FragmentLists ShadowSystem::Impl::camera_fragments() {
  CDSM_CHECK(has_camera_lists, scene.source + ": no camera fragment lists (render() first)");
  if (!camera_frags_read) {
    backend->read_lists(camera_lists, camera_frags);
    camera_frags_read = true;
  }
  return camera_frags.lists();
}

size_t ShadowSystem::Impl::object_index(ObjectHandle h) const {
  uint32_t i = 0;
  const SlotMap::Lookup found = object_slots.find(h.id, &i);
  if (found != SlotMap::Lookup::Found) throw Error(scene.source, describe_handle("object", h.id, found));
  return i;
}

size_t ShadowSystem::Impl::volume_index(uint64_t id) const {
  uint32_t i = 0;
  const SlotMap::Lookup found = volume_slots.find(id, &i);
  if (found != SlotMap::Lookup::Found) throw Error(scene.source, describe_handle("volume", id, found));
  return i;
}

size_t ShadowSystem::Impl::light_index(LightHandle h) const {
  uint32_t i = 0;
  const SlotMap::Lookup found = light_slots.find(h.id, &i);
  if (found != SlotMap::Lookup::Found) throw Error(scene.source, describe_handle("light", h.id, found));
  return i;
}

std::string ShadowSystem::Impl::object_where(size_t i) const {
  return object_location(scene.source, i, scene.objects[i].name);
}

bool ShadowSystem::Impl::is_closed_mesh(const std::shared_ptr<const TriangleMesh>& mesh) {
  if (!mesh) return false;
  auto it = closed_meshes.find(mesh.get());
  if (it != closed_meshes.end() && it->second.first == mesh) return it->second.second;
  const bool closed = is_closed(*mesh);
  closed_meshes[mesh.get()] = {mesh, closed};
  return closed;
}

void ShadowSystem::Impl::touch_object(size_t i) {
  ++objects[i].generation;
  changed = compile_pending = true;
}

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
    d.voxel_offset = d.grid_kind == kGridDense ? o.voxel_begin : o.block_begin * sizeof(GridBlock);
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
      compile_object(o, is_closed_mesh(o.mesh), where, co);
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
    build_bvh(nb);
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
    compile_object(o, rec.closed = is_closed_mesh(o.mesh), object_where(oi), co);
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
    change.objects = refresh_surfaces();
  }
  st.times.compile_ms = ms_since(t0);
  st.update.gl_upload_bytes += fragments.scene_changed(sb, change);
  backend->update_scene(sb, change);
  compile_pending = false;
}

void ShadowSystem::Impl::update(FrameStats& st) {
  build(st);
  publish(st);
}

void ShadowSystem::Impl::publish(FrameStats& st) {
  if (!gl) return;
  SystemGlScope gl_scope(gl.get(), &st.warnings);
  sync_gl_maps(*gl, frame.view(scene.shadows, /*with_storage=*/false), *backend, st.update);
  st.update.gl_readback_bytes = gl_readback_bytes;
  gl_readback_bytes = 0;
}

void ShadowSystem::Impl::build(FrameStats& st) {
  // The application's context only where the fragments are rasterized on it
  // (then on that context's thread).
  const bool app_fragments = (options.fragments == FragmentSource::Auto || options.fragments == FragmentSource::Gl) &&
                             !options.private_fragment_context;
  SystemGlScope gl_scope(app_fragments ? gl.get() : nullptr, &st.warnings);
  if (changed) {
    validate_scene(scene, &st.warnings);
    check_memory(scene, estimate_frame_memory(scene, RenderOptions{}));
    compile(st);
    FrameInputs in;
    in.scene = &sb;
    in.lights = scene.lights;
    in.light_ids = lights;
    for (const ObjectRec& r : objects) {
      in.object_ids.push_back(r.id);
      in.object_generations.push_back(r.generation);
    }
    in.camera = scene.camera;
    in.settings = scene.shadows;
    in.keep_previous = keep_previous;
    in.keep_fragments = options.keep_fragment_lists;
    in.geometry_epoch = geometry_epoch;
    in.maps_built = &progress_built;
    in.maps_to_build = &progress_total;
    build_shadow_frame(in, fragments.producer(sb), *backend, cache, frame);
    changed = false;
  } else {
    for (uint8_t& r : frame.map_rebuilt) r = 0;
    frame.rebuilt = frame.freed = 0;
    // Maps kept for the popping probe are not needed by a frame whose maps
    // did not change.
    for (MapId id : cache.retired) {
      backend->free_map(id);
      ++frame.freed;
    }
    cache.retired.clear();
    if (frame.freed) frame.refresh_headers();
    frame.rebuilds.clear();
    frame.reused = uint32_t(frame.maps.size());
    frame.fragments_ms = frame.build_ms = frame.cluster_ms = 0.0;
    frame.fragments = 0;
    frame.fragment_lists_reused = 0;
  }
  st.fragment_source = fragment_name;
  st.fragment_source_reason = fragment_reason;
  st.warnings.insert(st.warnings.end(), sb.warnings.begin(), sb.warnings.end());
  st.warnings.insert(st.warnings.end(), frame.warnings.begin(), frame.warnings.end());
  st.maps_rebuilt = frame.rebuilt;
  st.maps_reused = frame.reused;
  st.update.maps_freed = frame.freed;
  st.update.fragment_lists_reused = frame.fragment_lists_reused;
  st.update.fragment_cache_bytes = frame.fragment_cache_bytes;
  st.update.rebuilds = frame.rebuilds;
  for (const MapRebuild& r : frame.rebuilds) ++st.update.rebuilt_by_reason[int(r.reason)];
  st.cluster_ms = frame.cluster_ms;
  st.clusters.clear();
  for (size_t li = 0; li < frame.clusters.size(); ++li) {
    const LightClusters& lc = frame.clusters[li];
    LightClusterStats cs;
    cs.clustered = lc.clustered;
    cs.fallback_reason = lc.fallback_reason;
    cs.reclustered = lc.clustered && lc.clustering.reclustered;
    if (lc.clustered)
      for (const auto& c : lc.clustering.clusters) {
        cs.members.push_back({c.members.begin(), c.members.end()});
        cs.changed.push_back(c.members_changed || c.views_changed ? 1 : 0);
      }
    cs.maps = frame.setup.lights[li].map_count;
    cs.directions = lc.clustering.directions;
    cs.warped_directions = lc.clustering.perspective_directions;
    st.clusters.push_back(std::move(cs));
  }
  st.times.fragments_ms = frame.fragments_ms;
  st.times.dsm_build_ms = frame.build_ms;
  take_kernel_times(*backend, st.times, st.times.kernel_fragments_ms, st.times.kernel_dsm_build_ms);
  add_transfers(*backend, st.update);
  st.light_fragments = frame.fragments;
  DsmMemory& m = st.memory;
  m = DsmMemory{};
  m.maps = frame.maps.size();
  for (const DsmBuildStats& b : frame.map_stats) {
    m.texels += b.texels;
    m.nodes += b.nodes;
    m.index_bytes += b.index_bytes;
    m.node_bytes += b.node_bytes_used;
    m.slack_bytes += b.slack_bytes;
    m.tag_bytes += b.tag_bytes;
    m.max_nodes_per_texel = std::max(m.max_nodes_per_texel, b.max_nodes);
    m.overflow_texels += b.overflow_texels;
    m.rewalked_texels += b.rewalked_texels;
    m.max_extra_error = std::max(m.max_extra_error, b.max_extra_error);
    const uint64_t bytes = b.index_bytes + b.node_bytes_allocated + b.tag_bytes;
    if (b.rgb) {
      ++m.rgb_maps;
      m.rgb_bytes += bytes;
      m.rgb_nodes += b.nodes;
    } else {
      m.grey_bytes += bytes;
    }
    add_walk(st, b.walk);
  }
  m.avg_nodes_per_texel = m.texels ? double(m.nodes) / double(m.texels) : 0.0;
  const MapStoreStats store = backend->map_store();
  st.update.map_store_bytes = store.allocated_bytes;
  st.update.map_live_bytes = store.live_bytes;
  st.update.scene_bytes = scene_bytes(sb);
  st.update.gl_scene_bytes = fragments.gl_scene_bytes();
  st.lights = uint32_t(scene.lights.size());
  update_stats = st;
}

// ---- ShadowSystem -----------------------------------------------------------

ShadowSystem::ShadowSystem(const SystemOptions& options) : impl_(std::make_unique<Impl>(options)) {}
ShadowSystem::~ShadowSystem() = default;

const Scene& ShadowSystem::scene() const { return impl_->scene; }

std::vector<ObjectHandle> ShadowSystem::objects() const {
  std::vector<ObjectHandle> out;
  for (const auto& r : impl_->objects) out.push_back({r.id});
  return out;
}

std::vector<LightHandle> ShadowSystem::lights() const {
  std::vector<LightHandle> out;
  for (uint64_t id : impl_->lights) out.push_back({id});
  return out;
}

VolumeHandle ShadowSystem::add_volume(Volume volume) {
  Impl& I = *impl_;
  I.scene.volumes.push_back(std::move(volume));
  Impl::VolumeRec rec;
  rec.id = I.volume_slots.insert(uint32_t(I.volumes.size()));
  I.volumes.push_back(rec);
  I.changed = I.compile_pending = true;
  return {rec.id};
}

void ShadowSystem::set_volume(VolumeHandle h, Volume volume) {
  Impl& I = *impl_;
  const size_t vi = I.volume_index(h.id);
  I.scene.volumes[vi] = std::move(volume);
  I.volumes[vi].dirty = true;
  for (size_t oi = 0; oi < I.objects.size(); ++oi)
    if (I.objects[oi].volume == h.id) I.touch_object(oi);
  I.changed = I.compile_pending = true;
}

void ShadowSystem::remove_volume(VolumeHandle h) {
  Impl& I = *impl_;
  const size_t vi = I.volume_index(h.id);
  for (size_t oi = 0; oi < I.objects.size(); ++oi)
    if (I.objects[oi].volume == h.id)
      throw Error(I.object_where(oi), "uses the volume being removed: remove the object or change its interior first");
  if (I.volumes[vi].compiled) {
    I.erase_volume_data(vi);
    I.sb.volumes.erase(I.sb.volumes.begin() + ptrdiff_t(vi));
  }
  I.volume_slots.erase(h.id);
  I.volumes.erase(I.volumes.begin() + ptrdiff_t(vi));
  I.scene.volumes.erase(I.scene.volumes.begin() + ptrdiff_t(vi));
  for (size_t k = vi; k < I.volumes.size(); ++k) I.volume_slots.move(I.volumes[k].id, uint32_t(k));
  for (Object& o : I.scene.objects)
    if (o.volume > int32_t(vi)) --o.volume;
  I.structure_dirty = true;  // objects' volume indices shift
  I.changed = I.compile_pending = true;
}

ObjectHandle ShadowSystem::add_object(const Object& o, VolumeHandle volume) {
  Impl& I = *impl_;
  const std::string where = object_location(I.scene.source, I.objects.size(), o.name);
  if (!o.mesh) throw Error(where, "has no mesh");
  if (!finite_matrix(o.transform)) throw Error(where, "transform has NaN or infinite entries");
  Object copy = o;
  copy.volume = -1;
  Impl::ObjectRec rec;
  if (o.interior == InteriorKind::Volume) {
    if (!volume) throw Error(where, "has a volume interior but names no volume");
    const size_t vi = I.volume_index(volume.id);
    for (const auto& r : I.objects)
      if (r.volume == volume.id) throw Error(where, "volume " + std::to_string(vi) + " is used by two objects");
    copy.volume = int32_t(vi);
    rec.volume = volume.id;
  }
  rec.id = I.object_slots.insert(uint32_t(I.objects.size()));
  I.scene.objects.push_back(std::move(copy));
  I.objects.push_back(rec);
  I.structure_dirty = true;
  I.changed = I.compile_pending = true;
  return {rec.id};
}

void ShadowSystem::set_transform(ObjectHandle h, const Mat4& transform) {
  Impl& I = *impl_;
  const size_t i = I.object_index(h);
  if (!finite_matrix(transform)) throw Error(I.object_where(i), "transform has NaN or infinite entries");
  I.scene.objects[i].transform = transform;
  I.objects[i].moved = true;
  I.touch_object(i);
}

void ShadowSystem::set_surface(ObjectHandle h, const SurfaceMaterial& surface) {
  Impl& I = *impl_;
  const size_t i = I.object_index(h);
  I.scene.objects[i].surface = surface;
  I.objects[i].surface = true;
  I.touch_object(i);
}

void ShadowSystem::set_casts_shadows(ObjectHandle h, bool casts) {
  Impl& I = *impl_;
  const size_t i = I.object_index(h);
  I.scene.objects[i].casts_shadows = casts;
  I.objects[i].surface = true;
  I.touch_object(i);
}

void ShadowSystem::set_interior(ObjectHandle h, InteriorKind interior, Vec3 sigma, VolumeHandle volume) {
  Impl& I = *impl_;
  const size_t i = I.object_index(h);
  Object& o = I.scene.objects[i];
  uint64_t vol = 0;
  int32_t index = -1;
  if (interior == InteriorKind::Volume) {
    if (!volume) throw Error(I.object_where(i), "has a volume interior but names no volume");
    index = int32_t(I.volume_index(volume.id));
    for (size_t k = 0; k < I.objects.size(); ++k)
      if (k != i && I.objects[k].volume == volume.id)
        throw Error(I.object_where(i), "volume " + std::to_string(index) + " is used by two objects");
    vol = volume.id;
  }
  o.interior = interior;
  o.sigma = sigma;
  o.volume = index;
  I.objects[i].volume = vol;
  I.structure_dirty = true;  // media bounds change the fragment producers' clipping
  I.touch_object(i);
}

void ShadowSystem::set_mesh(ObjectHandle h, std::shared_ptr<const TriangleMesh> mesh) {
  Impl& I = *impl_;
  const size_t i = I.object_index(h);
  if (!mesh) throw Error(I.object_where(i), "has no mesh");
  I.scene.objects[i].mesh = std::move(mesh);
  I.structure_dirty = true;
  I.touch_object(i);
}

void ShadowSystem::remove_object(ObjectHandle h) {
  Impl& I = *impl_;
  const size_t i = I.object_index(h);
  I.object_slots.erase(h.id);
  I.scene.objects.erase(I.scene.objects.begin() + ptrdiff_t(i));
  I.objects.erase(I.objects.begin() + ptrdiff_t(i));
  for (size_t k = i; k < I.objects.size(); ++k) I.object_slots.move(I.objects[k].id, uint32_t(k));
  // Meshes no object uses any more are released.
  for (auto it = I.closed_meshes.begin(); it != I.closed_meshes.end();) {
    bool used = false;
    for (const Object& o : I.scene.objects) used |= o.mesh.get() == it->first;
    it = used ? std::next(it) : I.closed_meshes.erase(it);
  }
  I.structure_dirty = true;
  I.changed = I.compile_pending = true;
}

LightHandle ShadowSystem::add_light(const Light& light) {
  Impl& I = *impl_;
  I.scene.lights.push_back(light);
  I.lights.push_back(I.light_slots.insert(uint32_t(I.lights.size())));
  I.changed = true;
  return {I.lights.back()};
}

void ShadowSystem::set_light(LightHandle h, const Light& light) {
  Impl& I = *impl_;
  I.scene.lights[I.light_index(h)] = light;
  I.changed = true;
}

void ShadowSystem::remove_light(LightHandle h) {
  Impl& I = *impl_;
  const size_t i = I.light_index(h);
  I.scene.lights.erase(I.scene.lights.begin() + ptrdiff_t(i));
  I.light_slots.erase(h.id);
  I.lights.erase(I.lights.begin() + ptrdiff_t(i));
  for (size_t k = i; k < I.lights.size(); ++k) I.light_slots.move(I.lights[k], uint32_t(k));
  I.changed = true;
}

void ShadowSystem::set_camera(const Camera& camera) {
  impl_->scene.camera = camera;
  impl_->changed = true;
}

void ShadowSystem::set_settings(const ShadowSettings& settings) {
  impl_->scene.shadows = settings;
  impl_->changed = true;
}

void ShadowSystem::set_background(Vec3 background) { impl_->scene.background = background; }

void ShadowSystem::update(FrameStats* stats) {
  FrameStats local;
  FrameStats& st = stats ? *stats : local;
  st = FrameStats{};
  if (impl_->scene.objects.empty() && impl_->scene.lights.empty())
    throw Error(impl_->scene.source, "update() before any object or light was added: nothing to build maps for");
  impl_->update(st);
}

void ShadowSystem::build(FrameStats* stats) {
  FrameStats local;
  FrameStats& st = stats ? *stats : local;
  st = FrameStats{};
  if (impl_->scene.objects.empty() && impl_->scene.lights.empty())
    throw Error(impl_->scene.source, "build() before any object or light was added: nothing to build maps for");
  impl_->build(st);
}

void ShadowSystem::publish(FrameStats* stats) {
  FrameStats local;
  impl_->publish(stats ? *stats : local);
}

ShadowSystem::BuildProgress ShadowSystem::build_progress() const {
  return {impl_->progress_built.load(), impl_->progress_total.load()};
}

std::shared_ptr<const TriangleMesh> ShadowSystem::read_gl_mesh(const GlMeshSource& source) {
  Impl& I = *impl_;
  const std::string where = I.scene.source + ": read_gl_mesh";
  if (!I.gl)
    throw Error(where,
                "needs a system created on the application's GL context (SystemOptions::gl_context = "
                "GlContextUse::Application)");
  std::vector<std::string> warnings;
  SystemGlScope scope(I.gl.get(), &warnings);
  return cdsm::read_gl_mesh(*I.gl, source, where, I.gl_readback_bytes);
}

GlMapBuffers ShadowSystem::gl_buffers() const {
  const Impl& I = *impl_;
  if (!I.gl)
    throw Error(I.scene.source + ": gl_buffers",
                "needs a system created on the application's GL context (SystemOptions::gl_context = "
                "GlContextUse::Application)");
  return gl_map_buffers(*I.gl);
}

void ShadowSystem::bind_gl(uint32_t program) {
  Impl& I = *impl_;
  const std::string where = I.scene.source + ": bind_gl";
  if (!I.gl)
    throw Error(where,
                "needs a system created on the application's GL context (SystemOptions::gl_context = "
                "GlContextUse::Application)");
  bind_gl_maps(*I.gl, program);  // checks the context; changes exactly the program's cdsm bindings
}

int ShadowSystem::gl_light_index(LightHandle light) const { return int(impl_->light_index(light)); }

uint32_t ShadowSystem::gl_object_id(ObjectHandle object) const {
  const size_t i = impl_->object_index(object);
  return impl_->scene.objects[i].casts_shadows ? uint32_t(i) : kNoObject;
}

void ShadowSystem::reset_maps() {
  impl_->cache.clear(*impl_->backend);
  impl_->frame = ShadowFrame{};
  impl_->changed = true;
}

Image ShadowSystem::render(FrameStats* stats) {
  Impl& I = *impl_;
  FrameStats local;
  FrameStats& st = stats ? *stats : local;
  st = FrameStats{};
  const auto t_total = Clock::now();
  SystemGlScope gl_scope(I.gl.get(), &st.warnings);
  I.update(st);
  CameraPassParams& cam = I.cam;
  cam.view = camera_view(I.scene.camera);
  SceneView sv = I.sb.view();
  I.cam_inside = objects_containing(sv, cam.view.eye, ObjectMask{});
  cam.inside = {I.cam_inside.data(), I.cam_inside.size()};
  cam.ambient = I.scene.shadows.ambient_light;
  cam.background = I.scene.background;
  auto t0 = Clock::now();
  if (I.has_camera_lists) I.backend->free_lists(I.camera_lists);
  I.has_camera_lists = false;
  I.camera_frags_read = false;
  I.camera_lists = I.fragments.producer(I.sb)(*I.backend, cam.view, ObjectMask{});
  I.has_camera_lists = true;
  st.times.camera_fragments_ms = ms_since(t0);
  take_kernel_times(*I.backend, st.times, st.times.kernel_camera_fragments_ms, st.times.kernel_camera_fragments_ms);
  st.camera_fragments = I.backend->lists_fragments(I.camera_lists);
  Image img;
  img.width = cam.view.width;
  img.height = cam.view.height;
  t0 = Clock::now();
  WalkStats ws;
  // (the backend reads its own store: no host view of it is fetched)
  I.backend->camera_pass(I.frame.view(I.scene.shadows, /*with_storage=*/false), cam, I.camera_lists, img.rgb, ws);
  st.times.camera_ms = ms_since(t0);
  take_kernel_times(*I.backend, st.times, st.times.kernel_camera_ms, st.times.kernel_camera_ms);
  add_transfers(*I.backend, st.update);
  add_walk(st, ws);
  if (st.march_lengthened > 0)
    st.warnings.push_back(I.scene.source + ": " + std::to_string(st.march_lengthened) +
                          " volume segments lie so far from the eye or light that their march step is below float "
                          "resolution there; they were marched with the finest step float allows (coarser than asked)");
  if (st.enclosing_overflow > 0)
    st.warnings.push_back(I.scene.source + ": " + std::to_string(st.enclosing_overflow) +
                          " entries of light or camera rays into volumes nested inside " +
                          std::to_string(kMaxEnclosing) +
                          " other volumes; those innermost volumes were left out there (their media absorb nothing)");
  st.times.total_ms = ms_since(t_total);
  return img;
}

Image ShadowSystem::render_reference(float step_voxels, RenderProgress* progress) {
  Impl& I = *impl_;
  FrameStats st;
  validate_scene(I.scene, &st.warnings);
  I.compile(st);
  SceneView sv = I.sb.view();
  LightSetup ls = setup_lights(I.scene.lights, I.sb, 4);
  ReferenceOptions ro;
  ro.step_voxels = step_voxels;
  if (progress) {
    ro.progress = &progress->fraction;
    ro.cancel = &progress->cancel;
  }
  ReferenceRenderer ref(sv, ls.lights, ro);
  CameraPassParams cam;
  cam.view = camera_view(I.scene.camera);
  std::vector<uint32_t> inside = objects_containing(sv, cam.view.eye, ObjectMask{});
  cam.inside = {inside.data(), inside.size()};
  cam.ambient = I.scene.shadows.ambient_light;
  cam.background = I.scene.background;
  Image img;
  img.width = cam.view.width;
  img.height = cam.view.height;
  ref.render(cam, img.rgb);
  if (progress) {
    if (progress->cancel.load()) throw Error(I.scene.source, "reference render cancelled");
    progress->fraction.store(1.0f);
  }
  return img;
}

// ---- a whole Scene value against the system's state -------------------------

namespace {

template <class T>
bool same_bytes(const T& a, const T& b) {
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

bool same_surface(const SurfaceMaterial& a, const SurfaceMaterial& b) { return same_fields(a, b); }

bool same_transfer(const std::vector<TransferPoint>& a, const std::vector<TransferPoint>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (!same_bytes(a[i].density, b[i].density) || !same_bytes(a[i].extinction, b[i].extinction) ||
        !same_bytes(a[i].color, b[i].color))
      return false;
  return true;
}

// (names left out: a renamed volume is not compiled again)
bool same_volume(const Volume& a, const Volume& b) {
  return a.grid == b.grid && a.sparse == b.sparse && same_bytes(a.index_to_object, b.index_to_object) &&
         same_transfer(a.transfer, b.transfer) && changed_effects(a, b) == kAffectsNothing;
}

// (names included: a renamed light is set again, which rebuilds nothing)
bool same_light(const Light& a, const Light& b) { return same_fields(a, b); }
bool same_camera(const Camera& a, const Camera& b) { return same_fields(a, b); }

int32_t volume_of(const Object& o) { return o.interior == InteriorKind::Volume ? o.volume : -1; }

}  // namespace

void sync_scene(ShadowSystem& system, const Scene& scene) {
  ShadowSystem::Impl& I = internals(system);
  I.scene.source = scene.source;
  if (!same_camera(I.scene.camera, scene.camera)) system.set_camera(scene.camera);
  if (!same_fields(I.scene.shadows, scene.shadows)) system.set_settings(scene.shadows);
  system.set_background(scene.background);
  // Volumes keep their place: a different count, or objects whose volume
  // changed, re-add every object and volume (rare: scene files do not do it
  // between frames).
  bool regroup = scene.volumes.size() != I.scene.volumes.size();
  for (size_t i = 0; i < std::min(scene.objects.size(), I.scene.objects.size()) && !regroup; ++i)
    regroup = volume_of(scene.objects[i]) != volume_of(I.scene.objects[i]);
  if (regroup) {
    for (ObjectHandle h : system.objects()) system.remove_object(h);
    while (!I.volumes.empty()) system.remove_volume({I.volumes.back().id});
    for (const Volume& v : scene.volumes) system.add_volume(v);
  } else {
    for (size_t i = 0; i < scene.volumes.size(); ++i)
      if (!same_volume(scene.volumes[i], I.scene.volumes[i])) system.set_volume({I.volumes[i].id}, scene.volumes[i]);
  }
  while (I.scene.objects.size() > scene.objects.size()) system.remove_object({I.objects.back().id});
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    const Object& o = scene.objects[i];
    const int32_t vi = volume_of(o);
    const VolumeHandle vh{vi >= 0 && size_t(vi) < I.volumes.size() ? I.volumes[size_t(vi)].id : 0};
    if (i >= I.scene.objects.size()) {
      system.add_object(o, vh);
      continue;
    }
    const Object& now = I.scene.objects[i];
    const ObjectHandle h{I.objects[i].id};
    I.scene.objects[i].name = o.name;
    if (o.mesh != now.mesh) system.set_mesh(h, o.mesh);
    if (!same_bytes(o.transform, now.transform)) system.set_transform(h, o.transform);
    if (!same_surface(o.surface, now.surface)) system.set_surface(h, o.surface);
    if (o.casts_shadows != now.casts_shadows) system.set_casts_shadows(h, o.casts_shadows);
    if (o.interior != now.interior || !same_bytes(o.sigma, now.sigma)) system.set_interior(h, o.interior, o.sigma, vh);
  }
  while (I.scene.lights.size() > scene.lights.size()) system.remove_light({I.lights.back()});
  for (size_t i = 0; i < scene.lights.size(); ++i) {
    if (i >= I.scene.lights.size())
      system.add_light(scene.lights[i]);
    else if (!same_light(scene.lights[i], I.scene.lights[i]) || scene.lights[i].name != I.scene.lights[i].name)
      system.set_light({I.lights[i]}, scene.lights[i]);
  }
}

}  // namespace cdsm
