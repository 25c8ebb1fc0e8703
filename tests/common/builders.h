// Scene builders the tests share: lights and an empty scene (one copy;
// unit_util.h and stability_util.h build on these).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <utility>

#include "cdsm/scene.h"

namespace cdsm_test {

inline cdsm::Light spot_light(cdsm::Vec3 pos, cdsm::Vec3 dir, float outer_deg = 30.0f, float inner_deg = 25.0f) {
  cdsm::Light l;
  l.type = cdsm::LightType::Spot;
  l.position = pos;
  l.direction = cdsm::normalize(dir);
  l.outer_cone_deg = outer_deg;
  l.inner_cone_deg = inner_deg;
  return l;
}

inline cdsm::Light point_light(cdsm::Vec3 pos) {
  cdsm::Light l;
  l.type = cdsm::LightType::Point;
  l.position = pos;
  return l;
}

// A directional light (the sun) travelling along `dir`.
inline cdsm::Light sun_light(cdsm::Vec3 dir) {
  cdsm::Light l;
  l.type = cdsm::LightType::Directional;
  l.direction = cdsm::normalize(dir);
  return l;
}

// A camera at `position` looking at `target`, width x height pixels (its
// other fields Camera's defaults).
inline cdsm::Camera camera_at(cdsm::Vec3 position, cdsm::Vec3 target, int width = 64, int height = 48) {
  cdsm::Camera c;
  c.position = position;
  c.target = target;
  c.width = width;
  c.height = height;
  return c;
}

// A surface object: `mesh` placed by `transform`, `opacity` per crossing.
inline cdsm::Object surface_object(const std::string& name, cdsm::TriangleMesh mesh,
                                   cdsm::Mat4 transform = cdsm::Mat4{}, float opacity = 1.0f, bool casts = true) {
  cdsm::Object o;
  o.name = name;
  o.mesh = std::make_shared<const cdsm::TriangleMesh>(std::move(mesh));
  o.transform = transform;
  o.surface.opacity = opacity;
  o.casts_shadows = casts;
  return o;
}

// Adds a surface object moved to `at` (no rotation, unit scale) to `scene`;
// returns its index.
inline uint32_t add_surface(cdsm::Scene& scene, const std::string& name, cdsm::TriangleMesh mesh, cdsm::Vec3 at,
                            float opacity) {
  scene.objects.push_back(
      surface_object(name, std::move(mesh), cdsm::make_transform(at, {0, 0, 0}, {1, 1, 1}), opacity));
  return uint32_t(scene.objects.size() - 1);
}

// A scene with a camera (64x48, from (0, 2, 6) at the origin) and no objects or lights.
inline cdsm::Scene empty_scene(const std::string& name) {
  cdsm::Scene s;
  s.source = name;
  s.camera = camera_at({0, 2, 6}, {0, 0, 0});
  return s;
}

}  // namespace cdsm_test
