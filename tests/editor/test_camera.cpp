// The editor's camera controls (editor/edit/camera_control.h): plain state
// with mouse and keyboard deltas in, a camera out.
#include <gtest/gtest.h>

#include <cmath>

#include "camera_control.h"

using namespace cdsm;
using namespace cdsm::editor;

namespace {

float dist(Vec3 a, Vec3 b) { return length(a - b); }

TEST(EditCamera, RoundTripsACamera) {
  Camera c;
  c.position = {0.3f, 2.3f, 4.4f};
  c.target = {0.0f, 0.35f, -0.1f};
  const Camera back = OrbitCamera::from(c).apply(c);
  EXPECT_LT(dist(back.position, c.position), 1e-5f);
  EXPECT_LT(dist(back.target, c.target), 1e-6f);
  EXPECT_EQ(back.width, c.width);
}

TEST(EditCamera, OrbitKeepsTheDistancePanMovesBoth) {
  OrbitCamera o;
  o.target = {1, 0, 0};
  o.distance = 3.0f;
  o.pitch_deg = 0.0f;  // on the horizon: yaw is the angle between the positions
  const Vec3 p0 = o.position();
  o.orbit(100.0f, 0.0f);  // 30 degrees of yaw
  EXPECT_NEAR(dist(o.position(), o.target), 3.0f, 1e-5f);
  EXPECT_NEAR(std::acos(dot(normalize(p0 - o.target), normalize(o.position() - o.target))) * 180.0f / 3.14159265f,
              30.0f, 1e-3f);
  o.orbit(0.0f, 1e6f);
  EXPECT_LE(o.pitch_deg, 89.0f);  // never over the pole
  const Vec3 t0 = o.target, q0 = o.position();
  o.pan(50.0f, 0.0f, 45.0f, 500);
  EXPECT_NEAR(dist(o.target, t0), dist(o.position(), q0), 1e-5f);
  // 50 px of a 500 px high view at distance 3, 45 degrees: 2*3*tan(22.5)/500*50.
  EXPECT_NEAR(dist(o.target, t0), 2.0f * 3.0f * std::tan(22.5f * 3.14159265f / 180.0f) / 10.0f, 1e-4f);
}

TEST(EditCamera, ZoomFlyFrame) {
  OrbitCamera o;
  o.distance = 10.0f;
  o.zoom(1.0f);
  EXPECT_NEAR(o.distance, 8.8f, 1e-4f);
  o.zoom(-1e4f);
  EXPECT_LE(o.distance, 1e6f);
  o.distance = 2.0f;
  const Vec3 t0 = o.target;
  o.fly({0, 0, 1.0f});  // forward by 1
  EXPECT_NEAR(dist(o.target, t0), 1.0f, 1e-5f);
  EXPECT_NEAR(o.distance, 2.0f, 1e-6f);
  Box3 b;
  b.grow(Vec3{-1, 0, -1});
  b.grow(Vec3{1, 2, 1});
  o.frame(b, 45.0f);
  EXPECT_LT(dist(o.target, {0, 1, 0}), 1e-6f);
  // The bounding sphere (radius sqrt(3)) fits the vertical field of view.
  EXPECT_GE(o.distance * std::sin(22.5f * 3.14159265f / 180.0f), std::sqrt(3.0f));
  Box3 empty;
  const Vec3 before = o.target;
  o.frame(empty, 45.0f);
  EXPECT_EQ(dist(o.target, before), 0.0f);
}

}  // namespace
