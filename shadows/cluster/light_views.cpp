#include "cluster/light_views.h"

#include <algorithm>
#include <cmath>

#include "cdsm/error.h"

namespace cdsm::cluster {
namespace {

constexpr float kPi = 3.14159265358979f;
float radians(float deg) { return deg * (kPi / 180.0f); }

PinholeView square_view(Vec3 eye, Vec3 forward, Vec3 up_hint, float tan_half, float near, float far, int res) {
  PinholeView v;
  v.eye = eye;
  v.forward = normalize(forward);
  make_frame(v.forward, up_hint, v.right, v.up);
  v.tan_half_x = v.tan_half_y = tan_half;
  v.center = {0.0f, 0.0f};
  v.near = near;
  v.far = far;
  v.width = v.height = res;
  return v;
}

}  // namespace

float widen_for_guard(float half, int res, float guard) {
  float inner = float(res) - 2.0f * guard;  // texels left for the content
  if (!(inner > 0.0f)) throw Error("clustering", "DSM resolution too small for the guard band");
  return half * float(res) / inner;
}

void make_frame(Vec3 forward, Vec3 up_hint, Vec3& right, Vec3& up) {
  Vec3 f = normalize(forward);
  Vec3 h = normalize(up_hint);
  if (!(length(h) > 0.5f) || std::fabs(dot(f, h)) > 0.999f) h = std::fabs(f.y) < 0.9f ? vec3(0, 1, 0) : vec3(0, 0, 1);
  right = normalize(cross(f, h));
  up = normalize(cross(right, f));
}

PinholeView spot_view(const LightShape& light, int res, float near, float far) {
  float half = std::tan(radians(std::clamp(light.outer_cone_deg, 0.01f, 89.0f)));
  Vec3 f = normalize(light.direction);
  Vec3 hint = std::fabs(f.y) < 0.9f ? vec3(0, 1, 0) : vec3(0, 0, 1);
  return square_view(light.position, f, hint, widen_for_guard(half, res, 1.0f), near, far, res);
}

std::array<PinholeView, 6> cube_face_views(Vec3 position, float near, float far, int res) {
  static const Vec3 forward[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  static const Vec3 up[6] = {{0, 1, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, -1}, {0, 1, 0}, {0, 1, 0}};
  std::array<PinholeView, 6> faces;
  const float half = widen_for_guard(1.0f, res, 1.0f);
  for (int i = 0; i < 6; ++i) faces[i] = square_view(position, forward[i], up[i], half, near, far, res);
  return faces;
}

std::vector<Plane> cone_planes(const LightShape& light, int sides) {
  if (!light.spot || !(light.outer_cone_deg < 89.9f)) return {};
  const float theta = radians(std::max(light.outer_cone_deg, 0.01f));
  const Vec3 a = normalize(light.direction);
  Vec3 e1, e2;
  make_frame(a, vec3(0, 1, 0), e1, e2);
  std::vector<Plane> planes;
  planes.reserve(size_t(sides));
  for (int i = 0; i < sides; ++i) {
    float phi = 2.0f * kPi * float(i) / float(sides);
    Vec3 radial = e1 * std::cos(phi) + e2 * std::sin(phi);
    // Inward normal of the plane tangent to the cone along azimuth phi.
    planes.push_back(plane_through(light.position, a * std::sin(theta) - radial * std::cos(theta)));
  }
  return planes;
}

namespace {

// An orthographic view along `direction` (the frame of make_frame with +Y
// as the up hint), its window centred at (cx, cy) on the right/up axes with
// half sizes hx, hy, the eye at `depth` along the view axis.
PinholeView ortho_view(Vec3 direction, float cx, float cy, float hx, float hy, float depth, float far, int res) {
  PinholeView v;
  v.projection = Projection::Orthographic;
  v.forward = normalize(direction);
  make_frame(v.forward, vec3(0, 1, 0), v.right, v.up);
  v.eye = v.right * cx + v.up * cy + v.forward * depth;
  v.tan_half_x = hx;
  v.tan_half_y = hy;
  v.width = v.height = res;
  v.far = far;
  return v;
}

}  // namespace

float near_clamp(const LightShape& light, const Box3& scene) {
  if (scene.empty()) return 1e-3f;
  const float reach = length(scene.extent()) + (light.directional ? 0.0f : length(scene.center() - light.position));
  return std::min(1e-3f, std::max(1e-6f * reach, 1e-30f));
}

// A length below which a window or a depth margin is float noise for
// coordinates of this magnitude (at most the 1 mm floors of a scene a metre
// across: smaller scenes get smaller floors, larger ones keep 1 mm).
static float length_floor(float magnitude, float at_most) {
  return std::min(at_most, std::max(1e-6f * magnitude, 1e-30f));
}

PinholeView directional_view(Vec3 direction, const Box3& box, int res) {
  const Vec3 c = box.center();
  const float scale = length(c) + length(box.extent());
  const float r = std::max(0.5f * length(box.extent()), length_floor(scale, 1e-3f));
  const float half = widen_for_guard(r, res, 1.0f);
  const float texel = 2.0f * half / float(res);
  const float margin = 0.05f * r + length_floor(scale, 1e-3f);
  Vec3 f = normalize(direction), right, up;
  make_frame(f, vec3(0, 1, 0), right, up);
  const float cx = std::round(dot(c, right) / texel) * texel, cy = std::round(dot(c, up) / texel) * texel;
  PinholeView v = ortho_view(f, cx, cy, half, half, dot(c, f) - r - margin, 2.0f * (r + margin), res);
  v.near = 0.5f * margin;
  return v;
}

PinholeView directional_focus(Vec3 direction, const std::vector<Vec3>& points, int res, float guard) {
  Vec3 f = normalize(direction), right, up;
  make_frame(f, vec3(0, 1, 0), right, up);
  float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
  for (Vec3 p : points) {
    const float c[3] = {dot(p, right), dot(p, up), dot(p, f)};
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], c[k]), hi[k] = std::max(hi[k], c[k]);
  }
  if (points.empty()) lo[0] = lo[1] = lo[2] = hi[0] = hi[1] = hi[2] = 0.0f;
  float scale = 0.0f;
  for (int k = 0; k < 3; ++k) scale = std::max(scale, std::max(std::fabs(lo[k]), std::fabs(hi[k])));
  // Half sizes on a 2^(1/4) ladder, with the guard band and half a texel
  // more for the snapped centre.
  auto half_of = [&](int k) {
    const float h = widen_for_guard(std::max(0.5f * (hi[k] - lo[k]), length_floor(scale, 1e-4f)), res, guard + 0.5f);
    return std::exp2(std::ceil(4.0f * std::log2(h)) * 0.25f);
  };
  const float hx = half_of(0), hy = half_of(1);
  const float tx = 2.0f * hx / float(res), ty = 2.0f * hy / float(res);
  const float cx = std::round(0.5f * (lo[0] + hi[0]) / tx) * tx, cy = std::round(0.5f * (lo[1] + hi[1]) / ty) * ty;
  const float margin = 0.01f * (hi[2] - lo[2]) + length_floor(scale, 1e-3f);
  PinholeView v = ortho_view(f, cx, cy, hx, hy, lo[2] - margin, hi[2] - lo[2] + 2.0f * margin, res);
  v.near = 0.5f * margin;
  return v;
}

bool spot_fits_one_frustum(const LightShape& light) {
  return light.spot && light.outer_cone_deg <= kMaxSpotFrustumHalfAngleDeg;
}

}  // namespace cdsm::cluster
