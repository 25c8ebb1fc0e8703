// sync_scene (scene_sync.h): brings a ShadowSystem to the content of a whole
// Scene value by edits, comparing by identity (the Renderer uses it).
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
#include "scene_sync.h"
#include "shadow_system_impl.h"

namespace cdsm {

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
  ShadowSystem::Impl& I = *system.impl_;
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
