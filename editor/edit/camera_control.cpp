#include "camera_control.h"

#include <algorithm>
#include <cmath>

namespace cdsm::editor {
namespace {
constexpr float kDeg = 3.14159265f / 180.0f;
}

OrbitCamera OrbitCamera::from(const Camera& c) {
  OrbitCamera o;
  o.target = c.target;
  const Vec3 d = c.position - c.target;
  o.distance = std::max(length(d), 1e-4f);
  o.pitch_deg = std::asin(std::clamp(d.y / o.distance, -1.0f, 1.0f)) / kDeg;
  o.yaw_deg = std::atan2(d.x, d.z) / kDeg;
  o.pitch_deg = std::clamp(o.pitch_deg, -89.0f, 89.0f);
  return o;
}

Vec3 OrbitCamera::position() const {
  const float p = pitch_deg * kDeg, y = yaw_deg * kDeg;
  return target + Vec3{std::cos(p) * std::sin(y), std::sin(p), std::cos(p) * std::cos(y)} * distance;
}

Camera OrbitCamera::apply(const Camera& base) const {
  Camera c = base;
  c.position = position();
  c.target = target;
  c.up = {0, 1, 0};
  return c;
}

void OrbitCamera::orbit(float dx, float dy) {
  yaw_deg -= 0.3f * dx;
  pitch_deg = std::clamp(pitch_deg + 0.3f * dy, -89.0f, 89.0f);
  yaw_deg = std::remainder(yaw_deg, 360.0f);
}

void OrbitCamera::pan(float dx, float dy, float fov_y_deg, int height) {
  const Vec3 f = normalize(target - position());
  const Vec3 r = normalize(cross(f, Vec3{0, 1, 0}));
  const Vec3 u = cross(r, f);
  // World units per pixel at the target's distance.
  const float per_px = 2.0f * distance * std::tan(0.5f * fov_y_deg * kDeg) / float(std::max(height, 1));
  target = target + r * (-dx * per_px) + u * (dy * per_px);
}

void OrbitCamera::zoom(float wheel_steps) {
  distance = std::clamp(distance * std::pow(0.88f, wheel_steps), 1e-3f, 1e6f);
}

void OrbitCamera::fly(Vec3 d) {
  const Vec3 f = normalize(target - position());
  const Vec3 r = normalize(cross(f, Vec3{0, 1, 0}));
  const Vec3 u = cross(r, f);
  target = target + r * d.x + u * d.y + f * d.z;
}

void OrbitCamera::frame(const Box3& box, float fov_y_deg) {
  if (box.empty()) return;
  target = box.center();
  const float radius = std::max(0.5f * length(box.extent()), 1e-3f);
  distance = radius / std::sin(0.5f * fov_y_deg * kDeg) * 1.05f;
}

}  // namespace cdsm::editor
