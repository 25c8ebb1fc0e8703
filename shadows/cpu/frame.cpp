#include "cpu/frame.h"

#include <chrono>
#include <cmath>

namespace cdsm {
namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

Vec3 any_perpendicular(Vec3 d) {
  Vec3 a = std::fabs(d.y) < 0.9f ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
  return normalize(cross(cross(d, a), d)) * -1.0f;
}

}  // namespace

FragmentProducer cpu_fragment_producer(const SceneView& scene) {
  return [scene](const PinholeView& view, ObjectMask mask, FragmentBuffers& out) {
    cast_fragments(scene, view, mask, out);
  };
}

PinholeView camera_view(const Camera& cam) {
  PinholeView v;
  v.eye = cam.position;
  v.forward = normalize(cam.target - cam.position);
  v.right = normalize(cross(v.forward, cam.up));
  v.up = cross(v.right, v.forward);
  v.tan_half_y = std::tan(cam.fov_y_deg * 0.5f * 3.14159265f / 180.0f);
  v.tan_half_x = v.tan_half_y * float(cam.width) / float(cam.height);
  v.width = cam.width;
  v.height = cam.height;
  v.near = cam.near;
  v.far = cam.far;
  return v;
}

PinholeView light_view(Vec3 eye, Vec3 forward, Vec3 up_hint, float tan_half, int res, int guard,
                       float near, float far) {
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

LightSetup setup_lights(const Scene& scene, const Box3& box, int res) {
  LightSetup ls;
  for (const Light& l : scene.lights) {
    LightData ld{};
    ld.position = l.position;
    ld.type = l.type == LightType::Spot ? kLightSpot : kLightPoint;
    ld.direction = normalize(l.direction);
    const float k = 3.14159265f / 180.0f;
    ld.cos_outer = std::cos(l.outer_cone_deg * k);
    ld.cos_inner = std::cos(std::min(l.inner_cone_deg, l.outer_cone_deg) * k);
    if (ld.cos_inner <= ld.cos_outer) ld.cos_inner = ld.cos_outer + 1e-6f;
    ld.radiance = l.color * l.intensity;
    ld.first_map = uint32_t(ls.map_views.size());
    // Depth range: everything of the scene box in front of the light.
    float far = 0.0f;
    for (int c = 0; c < 8; ++c) far = std::max(far, length(box.corner(c) - l.position));
    far = far * 1.01f + 1e-3f;
    float near = std::max(1e-4f, far * 1e-5f);
    bool faces = l.type == LightType::Point || l.outer_cone_deg > 60.0f;
    if (faces) {
      for (const PinholeView& v : cube_face_views(l.position, res, near, far)) {
        ls.map_views.push_back(v);
        ls.map_light.push_back(uint32_t(ls.lights.size()));
      }
      ld.map_count = 6;
      ld.map_mode = kMapsCubeFaces;
    } else {
      float tan_half = std::tan(l.outer_cone_deg * k);
      ls.map_views.push_back(light_view(l.position, ld.direction, {0, 1, 0}, tan_half, res, 1, near, far));
      ls.map_light.push_back(uint32_t(ls.lights.size()));
      ld.map_count = 1;
      ld.map_mode = kMapsCombine;
    }
    ls.lights.push_back(ld);
  }
  return ls;
}

ShadowView ShadowFrame::view(const ShadowSettings& s) const {
  ShadowView v;
  v.lights = {setup.lights.data(), setup.lights.size()};
  v.maps = {dsm.maps.data(), dsm.maps.size()};
  v.storage = dsm.storage();
  v.filtering = s.filtering;
  v.bias_constant = s.bias_constant;
  v.bias_slope = s.bias_slope;
  return v;
}

void build_shadow_frame(const Scene& scene, const SceneBuffers& sb, const FragmentProducer& produce,
                        ShadowFrame& frame) {
  SceneView sv = sb.view();
  frame.setup = setup_lights(scene, sb.bounds, scene.shadows.resolution);
  frame.dsm.clear();
  frame.map_stats.clear();
  frame.fragments_ms = frame.build_ms = 0.0;
  frame.fragments = 0;
  std::vector<uint32_t> casters = sb.mask_where([&](uint32_t o) { return (sb.objects[o].flags & kObjCastsShadows) != 0u; });
  ObjectMask mask{{casters.data(), casters.size()}};
  FragmentBuffers fb;
  for (const PinholeView& v : frame.setup.map_views) {
    auto t0 = std::chrono::steady_clock::now();
    produce(v, mask, fb);
    frame.fragments_ms += ms_since(t0);
    frame.fragments += fb.total();
    t0 = std::chrono::steady_clock::now();
    std::vector<uint32_t> inside = objects_containing(sv, v.eye, mask);
    LightPassParams lp{v, scene.shadows.epsilon, {inside.data(), inside.size()}};
    frame.map_stats.push_back(build_dsm(sv, lp, fb.lists(), frame.dsm));
    frame.build_ms += ms_since(t0);
  }
}

}  // namespace cdsm
