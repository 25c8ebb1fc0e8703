// Lights and their views (frame.h): the kernels' light data, the camera's
// and the lights' pinhole views, cube faces, and each light's unclustered
// maps with the depth range its casters need.
#include <algorithm>
#include <cmath>

#include "cluster/focus.h"
#include "frame.h"
#include "scene_compile.h"

namespace cdsm {
namespace {

Vec3 any_perpendicular(Vec3 d) {
  Vec3 a = std::fabs(d.y) < 0.9f ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
  return normalize(cross(cross(d, a), d)) * -1.0f;
}

// Depth range of a light: far over the scene box; near half the distance
// to the closest caster box that does not hold the light, not a fraction of
// far — one huge object must not push near past the small ones near the
// light. (Near only clips surfaces: depths are radial floats, there is no
// depth buffer, and media boundaries before near are kept anyway.)
void light_range(const Light& l, const SceneBuffers& sb, float& near, float& far) {
  far = 0.0f;
  for (int c = 0; c < 8; ++c) far = std::max(far, length(sb.bounds.corner(c) - l.position));
  far = far * 1.01f + 1e-3f;
  float closest = far;
  for (size_t o = 0; o < sb.objects.size(); ++o) {
    if (!(sb.objects[o].flags & kObjCastsShadows) || sb.object_bounds[o].empty()) continue;
    const Box3& b = sb.object_bounds[o];
    float d = length(vmax(vmax(b.lo - l.position, l.position - b.hi), Vec3{0, 0, 0}));
    if (d > 0.0f) closest = std::min(closest, d);
  }
  near = std::max(0.5f * closest, 1e-6f);
}

}  // namespace

LightData light_data(const Light& l) {
  LightData ld{};
  ld.position = l.type == LightType::Directional ? Vec3{0, 0, 0} : l.position;
  ld.type = l.type;
  ld.direction = normalize(l.direction);
  const float k = 3.14159265f / 180.0f;
  ld.cos_outer = l.type == LightType::Spot ? std::cos(l.outer_cone_deg * k) : -2.0f;
  ld.cos_inner = l.type == LightType::Spot ? std::cos(std::min(l.inner_cone_deg, l.outer_cone_deg) * k) : -1.0f;
  if (ld.cos_inner <= ld.cos_outer) ld.cos_inner = ld.cos_outer + 1e-6f;
  ld.radiance = l.color * l.intensity;
  ld.size = l.type == LightType::Directional ? std::tan(0.5f * l.angular_diameter_deg * k) : l.radius;
  return ld;
}

FragmentProducer cpu_fragment_producer(const SceneView& scene) {
  return [scene](ShadowBackend& backend, const ListsRequest* requests, size_t n, ListsId* ids) {
    produce_each(backend, requests, n, ids, [&](const ListsRequest& r) {
      FragmentBuffers fb;
      cast_fragments(scene, r.view, r.mask, fb);
      return backend.adopt_lists(std::move(fb));
    });
  };
}

ListsId produce_lists(const FragmentProducer& produce, ShadowBackend& backend, const PinholeView& view, ObjectMask mask,
                      bool unchecked, uint64_t slot) {
  const ListsRequest r{view, mask, unchecked, slot};
  ListsId id = 0;
  produce(backend, &r, 1, &id);
  return id;
}

PinholeView camera_view(const Camera& cam) {
  // The eye's axes are the view matrix's rows: one basis for the camera
  // pass, the clustering and an engine's GL view (Camera::view_matrix).
  const Mat4 m = cam.view_matrix();
  PinholeView v;
  v.eye = cam.position;
  v.right = {m.m[0][0], m.m[0][1], m.m[0][2]};
  v.up = {m.m[1][0], m.m[1][1], m.m[1][2]};
  v.forward = -Vec3{m.m[2][0], m.m[2][1], m.m[2][2]};
  v.tan_half_y = std::tan(cam.fov_y_deg * 0.5f * 3.14159265f / 180.0f);
  v.tan_half_x = v.tan_half_y * float(cam.width) / float(cam.height);
  v.width = cam.width;
  v.height = cam.height;
  v.near = cam.near;
  v.far = cam.far;
  return v;
}

PinholeView light_view(Vec3 eye, Vec3 forward, Vec3 up_hint, float tan_half, int res, int guard, float near,
                       float far) {
  PinholeView v;
  v.eye = eye;
  v.forward = normalize(forward);
  Vec3 r = cross(v.forward, up_hint);
  if (length(r) < 1e-4f) r = cross(v.forward, any_perpendicular(v.forward));
  v.right = normalize(r);
  v.up = cross(v.right, v.forward);
  // Widen so `guard` texels lie outside the requested window on each side.
  float widen = float(res) / float(std::max(1, res - 2 * guard));
  v.tan_half_x = v.tan_half_y = tan_half * widen;
  v.width = v.height = res;
  v.near = near;
  v.far = far;
  return v;
}

std::vector<PinholeView> cube_face_views(Vec3 eye, int res, float near, float far) {
  const Vec3 fwd[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  const Vec3 up[6] = {{0, 1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}, {0, 1, 0}, {0, 1, 0}};
  std::vector<PinholeView> v;
  for (int f = 0; f < 6; ++f) v.push_back(light_view(eye, fwd[f], up[f], 1.0f, res, 1, near, far));
  return v;
}

LightSetup setup_lights(const std::vector<Light>& lights, const SceneBuffers& sb, int res) {
  LightSetup ls;
  std::vector<uint32_t> casters;
  for (uint32_t o = 0; o < sb.objects.size(); ++o)
    if (sb.objects[o].flags & kObjCastsShadows) casters.push_back(o);
  for (size_t li = 0; li < lights.size(); ++li) {
    const Light& l = lights[li];
    LightData ld = light_data(l);
    ld.first_map = uint32_t(ls.maps.size());
    if (l.type == LightType::Directional) {
      Box3 box;
      for (uint32_t o : casters) box.grow(sb.object_bounds[o]);
      if (box.empty()) box = sb.bounds;
      if (box.empty()) box.grow(Vec3{0, 0, 0});
      ls.maps.push_back({cluster::directional_view(ld.direction, box, res), uint32_t(li), casters});
      ld.map_count = 1;
      ld.map_mode = MapMode::Combine;
      ls.lights.push_back(ld);
      continue;
    }
    float near, far;
    light_range(l, sb, near, far);
    bool faces = l.type == LightType::Point || l.outer_cone_deg > cluster::kMaxSpotFrustumHalfAngleDeg;
    if (faces) {
      for (const PinholeView& v : cube_face_views(l.position, res, near, far))
        ls.maps.push_back({v, uint32_t(li), casters});
      ld.map_count = 6;
      ld.map_mode = MapMode::CubeFaces;
    } else {
      float tan_half = std::tan(l.outer_cone_deg * 3.14159265f / 180.0f);
      ls.maps.push_back(
          {light_view(l.position, ld.direction, {0, 1, 0}, tan_half, res, 1, near, far), uint32_t(li), casters});
      ld.map_count = 1;
      ld.map_mode = MapMode::Combine;
    }
    ls.lights.push_back(ld);
  }
  return ls;
}

DsmLayoutParams dsm_layout_params(const ShadowSettings& s) { return {s.layout, s.fixed_layers, s.chunk_nodes}; }

}  // namespace cdsm
