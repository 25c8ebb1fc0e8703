// The persistent shadow system (cdsm/shadow_system.h): handles and edits,
// each marking what it invalidates, GL binding and inspection. What
// update() then does lives beside it: system_compile.cpp (the scene part),
// system_frame.cpp (builds, publishing, render), scene_sync.cpp (a whole
// Scene value by edits).
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

bool finite_matrix(const Mat4& m) {
  for (auto& row : m.m)
    for (float v : row)
      if (!is_finite(v)) return false;
  return true;
}

}  // namespace

// ---- Impl -------------------------------------------------------------------

ShadowSystem::Impl::Impl(const SystemOptions& o) : options(o) {
  scene.source = o.source;
  if (o.gl_context == GlContextUse::Application) {
    gl = make_system_gl(o.source);
    if (!o.private_fragment_context) fragments.use_context(system_context(*gl));
  }
  BackendChoice c = make_system_backend(o);
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

FragmentLists ShadowSystem::Impl::camera_fragments() const {
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

void ShadowSystem::Impl::require_host_meshes(const std::string& what) const {
  for (size_t i = 0; i < objects.size(); ++i)
    if (objects[i].gpu)
      throw Error(object_where(i), what +
                                       " needs every mesh's triangles on the host, and this one stays on the GPU "
                                       "(add_gpu_object): draw the scene with your own shader and cdsm.glsl (bind_gl)");
}

void ShadowSystem::Impl::touch_object(size_t i) {
  ++objects[i].generation;
  changed = compile_pending = true;
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

std::vector<VolumeHandle> ShadowSystem::volumes() const {
  std::vector<VolumeHandle> out;
  for (const auto& r : impl_->volumes) out.push_back({r.id});
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
  if (I.objects[i].gpu && interior != InteriorKind::None)
    throw Error(I.object_where(i), "set_interior: a mesh that stays on the GPU has no interior (medium or volume)");
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
  if (I.objects[i].gpu)
    throw Error(I.object_where(i),
                "set_mesh: its mesh stays on the GPU (add_gpu_object): after changing its buffers call "
                "mark_changed(), or remove it and add a host mesh");
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

// The same camera or settings again (an engine sets them every frame)
// change nothing: the next update() stays free.
void ShadowSystem::set_camera(const Camera& camera) {
  if (same_fields(impl_->scene.camera, camera)) return;
  impl_->scene.camera = camera;
  impl_->changed = true;
}

void ShadowSystem::set_settings(const ShadowSettings& settings) {
  if (same_fields(impl_->scene.shadows, settings)) return;
  impl_->scene.shadows = settings;
  impl_->changed = true;
}

void ShadowSystem::set_background(Vec3 background) { impl_->scene.background = background; }

void ShadowSystem::update(FrameStats* stats) {
  FrameStats local;
  FrameStats& st = stats ? *stats : local;
  st = FrameStats{};
  impl_->update(st);
}

void ShadowSystem::build(FrameStats* stats) {
  FrameStats local;
  FrameStats& st = stats ? *stats : local;
  st = FrameStats{};
  impl_->build(st);
}

void ShadowSystem::publish(FrameStats* stats) {
  FrameStats local;
  impl_->publish(stats ? *stats : local);
}

ShadowSystem::BuildProgress ShadowSystem::build_progress() const {
  return {impl_->progress_built.load(), impl_->progress_total.load()};
}

void ShadowSystem::reset_maps() {
  impl_->cache.clear(*impl_->backend);
  impl_->frame = ShadowFrame{};
  impl_->changed = true;
}

}  // namespace cdsm
