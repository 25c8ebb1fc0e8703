#include "cluster/lispsm.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace cdsm::cluster {
namespace {

// Window-normalized image coordinates of a world point in `light`; false
// behind the eye.
bool image_coords(const PinholeView& light, Vec3 p, Vec2& s) {
  Vec3 d = p - light.eye;
  float za = dot(d, light.forward);
  if (is_orthographic(light)) {  // parallel rays: no divide
    if (!(za > 0.0f)) return false;
    s.x = (dot(d, light.right) - light.center.x) / light.tan_half_x;
    s.y = (dot(d, light.up) - light.center.y) / light.tan_half_y;
    return true;
  }
  if (!(za > 1e-7f * length(d)) || !(za > 0.0f)) return false;
  s.x = (dot(d, light.right) / za - light.center.x) / light.tan_half_x;
  s.y = (dot(d, light.up) / za - light.center.y) / light.tan_half_y;
  return true;
}

// Pre-scale coordinates: (a, b) in the image-plane frame, then the warp.
Vec2 raw_coords(const LispsmMap& m, Vec2 s, bool& ok) {
  float a = s.x * m.ex.x + s.y * m.ex.y;
  float b = s.x * m.ez.x + s.y * m.ez.y;
  ok = true;
  if (!m.perspective) return {a, b};
  float t = b - m.apex_b;  // distance from P's apex along its view axis
  if (!(t > 1e-6f * m.n)) {
    ok = false;
    return {};
  }
  float x = (a - m.apex_a) / t;
  float z = ((m.f + m.n) - 2.0f * m.f * m.n / t) / (m.f - m.n);  // P's normalized depth
  return {x, z};
}

void fit_scale(LispsmMap& m, const std::vector<Vec2>& s) {
  float lo[2] = {1e30f, 1e30f}, hi[2] = {-1e30f, -1e30f};
  for (Vec2 q : s) {
    bool ok = false;
    Vec2 r = raw_coords(m, q, ok);
    if (!ok) continue;
    lo[0] = std::min(lo[0], r.x), hi[0] = std::max(hi[0], r.x);
    lo[1] = std::min(lo[1], r.y), hi[1] = std::max(hi[1], r.y);
  }
  m.mid = {0.5f * (lo[0] + hi[0]), 0.5f * (lo[1] + hi[1])};
  m.half = {std::max(0.5f * (hi[0] - lo[0]), 1e-12f), std::max(0.5f * (hi[1] - lo[1]), 1e-12f)};
}

}  // namespace

bool LispsmMap::map(Vec3 world, Vec2& out) const {
  if (!valid) return false;
  Vec2 s;
  if (!image_coords(light, world, s)) return false;
  bool ok = false;
  Vec2 r = raw_coords(*this, s, ok);
  if (!ok) return false;
  out = {(r.x - mid.x) / half.x, (r.y - mid.y) / half.y};
  return true;
}

LispsmMap uniform_light_map(const PinholeView& light) {
  LispsmMap m;
  m.light = light;
  m.valid = true;
  return m;
}

LispsmMap build_lispsm(const PinholeView& camera, const PinholeView& light, const ConvexBody& body,
                       const LispsmParams& params) {
  LispsmMap m;
  m.light = light;
  // B's vertices in front of the light. B holds the light itself where the
  // light lies in it (a point light's or a spot's B is the hull of the
  // camera frustum and the light, cut by the light's view): its near plane
  // (the tiny near_clamp of a small scene) cannot cut that apex off beyond
  // the clip's tolerance, and the apex has no image; the other vertices
  // bound B's directions.
  std::vector<Vec3> verts;
  std::vector<Vec2> s;
  Vec3 centroid{};
  for (Vec3 p : body.vertices()) {
    Vec2 q;
    if (!image_coords(light, p, q)) continue;
    verts.push_back(p);
    s.push_back(q);
    centroid += p;
  }
  if (verts.empty()) return m;
  centroid = centroid / float(verts.size());
  m.valid = true;

  // gamma: the view direction against the light ray through B (thesis §2.4.2).
  const Vec3 v = camera.forward;
  const Vec3 l = is_orthographic(light) ? light.forward : normalize(centroid - light.eye);
  m.sin_gamma = length(cross(v, l));

  // The view direction projected onto the light's image plane: the image of
  // v under the projection's Jacobian at the centroid (a positive scale dropped).
  Vec3 d0 = centroid - light.eye;
  float za0 = dot(d0, light.forward);
  float sx0 = dot(d0, light.right) / za0, sy0 = dot(d0, light.up) / za0;
  float vf = dot(v, light.forward);
  if (is_orthographic(light)) sx0 = sy0 = 0.0f;  // the image of v is its part across the light
  Vec2 v2{(dot(v, light.right) - sx0 * vf) / light.tan_half_x, (dot(v, light.up) - sy0 * vf) / light.tan_half_y};
  float v2len = std::sqrt(v2.x * v2.x + v2.y * v2.y);

  auto uniform = [&]() {
    m.perspective = false;
    m.ex = {1, 0};
    m.ez = {0, 1};
    m.n = m.f = 0.0f;
    fit_scale(m, s);
    return m;
  };
  if (m.sin_gamma < params.min_sin_gamma || !(v2len > 1e-12f)) return uniform();

  m.ez = {v2.x / v2len, v2.y / v2len};
  m.ex = {m.ez.y, -m.ez.x};
  float a_lo = 1e30f, a_hi = -1e30f, b_lo = 1e30f, b_hi = -1e30f;
  for (Vec2 q : s) {
    float a = q.x * m.ex.x + q.y * m.ex.y, b = q.x * m.ez.x + q.y * m.ez.y;
    a_lo = std::min(a_lo, a), a_hi = std::max(a_hi, a);
    b_lo = std::min(b_lo, b), b_hi = std::max(b_hi, b);
  }
  const float d_img = b_hi - b_lo;

  // Camera near/far restricted to B, and B's world extent across the light.
  float z_lo = 1e30f, z_hi = -1e30f, w_lo = 1e30f, w_hi = -1e30f;
  Vec3 v_perp = normalize(v - l * dot(v, l));
  for (Vec3 p : verts) {
    float z = dot(p - camera.eye, camera.forward);
    z_lo = std::min(z_lo, z), z_hi = std::max(z_hi, z);
    float w = dot(p, v_perp);
    w_lo = std::min(w_lo, w), w_hi = std::max(w_hi, w);
  }
  const float d_world = w_hi - w_lo;
  if (!(d_img > 1e-6f) || !(d_world > 0.0f)) return uniform();
  float z_n = std::max(camera.near, z_lo);
  float z_f = std::max(std::min(camera.far, z_hi), z_n * (1.0f + 1e-3f));
  float n_world = (z_n + std::sqrt(z_f * z_n)) / m.sin_gamma;  // Wimmer et al. n_opt

  m.perspective = true;
  m.n = n_world * d_img / d_world;
  m.f = m.n + d_img;
  m.apex_b = b_lo - m.n;
  m.apex_a = 0.5f * (a_lo + a_hi);
  Vec2 se;
  if (image_coords(light, camera.eye, se))  // the apex sits in line with the eye
    m.apex_a = std::clamp(se.x * m.ex.x + se.y * m.ex.y, a_lo, a_hi);
  fit_scale(m, s);
  return m;
}

}  // namespace cdsm::cluster
