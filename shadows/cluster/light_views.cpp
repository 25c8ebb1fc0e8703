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

bool spot_fits_one_frustum(const LightShape& light) {
  return light.spot && light.outer_cone_deg <= kMaxSpotFrustumHalfAngleDeg;
}

}  // namespace cdsm::cluster
