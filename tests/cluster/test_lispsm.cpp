// The light-space perspective map (thesis §2.4.2) and the plain light views.
#include "cluster_test_util.h"

using namespace cluster_test;

// ---- LiSPSM -------------------------------------------------------------------

TEST(Lispsm, BodyMapsOntoTheUnitSquare) {
  LightShape spot = spot_light(vec3(0, 12, 0), vec3(0, -1, 0), 40.0f);
  PinholeView lv = spot_view(spot, 512, 0.01f, 40.0f);
  PinholeView cam = camera_at(vec3(0, 3, 14), vec3(0, 0.5f, 0));
  ConvexBody B = lispsm_body(cam, spot.position, kScene, &lv);
  LispsmMap m = build_lispsm(cam, lv, B);
  ASSERT_TRUE(m.valid);
  EXPECT_TRUE(m.perspective);
  EXPECT_GT(m.sin_gamma, 0.9f);  // view nearly horizontal, light from above
  EXPECT_GT(m.n, 0.0f);
  float lo[2] = {1e9f, 1e9f}, hi[2] = {-1e9f, -1e9f};
  for (Vec3 p : B.vertices()) {
    Vec2 q;
    ASSERT_TRUE(m.map(p, q));
    lo[0] = std::min(lo[0], q.x), hi[0] = std::max(hi[0], q.x);
    lo[1] = std::min(lo[1], q.y), hi[1] = std::max(hi[1], q.y);
  }
  EXPECT_NEAR(lo[0], -1.0f, 1e-4f);
  EXPECT_NEAR(hi[0], 1.0f, 1e-4f);
  EXPECT_NEAR(lo[1], -1.0f, 1e-4f);
  EXPECT_NEAR(hi[1], 1.0f, 1e-4f);
  // Points inside B map inside the square.
  std::mt19937 rng(3);
  std::vector<Vec3> verts = B.vertices();
  std::uniform_int_distribution<size_t> pick(0, verts.size() - 1);
  std::uniform_real_distribution<float> u01(0.0f, 1.0f);
  for (int i = 0; i < 500; ++i) {
    float a = u01(rng), b = u01(rng), c = u01(rng), s = a + b + c;
    Vec3 p = (verts[pick(rng)] * a + verts[pick(rng)] * b + verts[pick(rng)] * c) / s;
    Vec2 q;
    ASSERT_TRUE(m.map(p, q));
    EXPECT_LE(std::fabs(q.x), 1.0f + 1e-4f);
    EXPECT_LE(std::fabs(q.y), 1.0f + 1e-4f);
  }
  // Behind the light: no mapping.
  Vec2 q;
  EXPECT_FALSE(m.map(vec3(0, 20, 0), q));
}

TEST(Lispsm, WarpEnlargesObjectsNearTheCamera) {
  LightShape spot = spot_light(vec3(0, 12, 0), vec3(0, -1, 0), 40.0f);
  PinholeView lv = spot_view(spot, 512, 0.01f, 40.0f);
  PinholeView cam = camera_at(vec3(0, 2, 9), vec3(0, 0.5f, -8));
  ConvexBody B = lispsm_body(cam, spot.position, kScene, &lv);
  LispsmMap warp = build_lispsm(cam, lv, B);
  LispsmParams never;
  never.min_sin_gamma = 2.0f;  // forces the uniform space
  LispsmMap flat = build_lispsm(cam, lv, B, never);
  ASSERT_TRUE(warp.perspective);
  ASSERT_FALSE(flat.perspective);
  auto area = [](const LispsmMap& m, Box3 b) {
    float lx = 1e9f, ly = 1e9f, hx = -1e9f, hy = -1e9f;
    for (int i = 0; i < 8; ++i) {
      Vec2 q;
      EXPECT_TRUE(m.map(b.corner(i), q));
      lx = std::min(lx, q.x), hx = std::max(hx, q.x), ly = std::min(ly, q.y), hy = std::max(hy, q.y);
    }
    return (hx - lx) * (hy - ly);
  };
  Box3 near_box = cube(vec3(0, 0.5f, 5), 0.3f), far_box = cube(vec3(0, 0.5f, -7), 0.3f);
  float r_warp = area(warp, near_box) / area(warp, far_box);
  float r_flat = area(flat, near_box) / area(flat, far_box);
  EXPECT_GT(r_warp, 1.5f * r_flat) << r_warp << " vs " << r_flat;
}

TEST(Lispsm, FallsBackToUniformWhenViewIsParallelToLight) {
  LightShape spot = spot_light(vec3(0, 12, 0), vec3(0, -1, 0), 40.0f);
  PinholeView lv = spot_view(spot, 512, 0.01f, 40.0f);
  // Camera looking straight down, below the light.
  Camera c;
  c.position = vec3(0.2f, 8, 0.1f);
  c.target = vec3(0.2f, 0, 0.1f);
  c.up = vec3(0, 0, -1);
  c.near = 0.1f;
  c.far = 50.0f;
  PinholeView cam = camera_view(c, 1.0f);
  ConvexBody B = lispsm_body(cam, spot.position, kScene, &lv);
  LispsmMap m = build_lispsm(cam, lv, B);
  ASSERT_TRUE(m.valid);
  EXPECT_FALSE(m.perspective);
  EXPECT_LT(m.sin_gamma, 0.1f);
  // Uniform: straight lines of the light image stay straight, B spans [-1, 1]^2.
  float lo = 1e9f, hi = -1e9f;
  for (Vec3 p : B.vertices()) {
    Vec2 q;
    ASSERT_TRUE(m.map(p, q));
    lo = std::min(lo, q.x), hi = std::max(hi, q.x);
  }
  EXPECT_NEAR(lo, -1.0f, 1e-4f);
  EXPECT_NEAR(hi, 1.0f, 1e-4f);
  // A camera tilted by 45° uses the warp.
  c.target = vec3(0.2f, 0, 8.1f);
  c.up = vec3(0, 1, 0);
  PinholeView tilted = camera_view(c, 1.0f);
  LispsmMap t = build_lispsm(tilted, lv, lispsm_body(tilted, spot.position, kScene, &lv));
  EXPECT_TRUE(t.perspective);
}

TEST(Lispsm, WeakerWarpAsViewApproachesLight) {
  // n grows like 1 / sin(gamma): the warp n / (f - n) rises as gamma falls.
  LightShape spot = spot_light(vec3(0, 30, 0), vec3(0, -1, 0), 30.0f);
  PinholeView lv = spot_view(spot, 512, 0.01f, 60.0f);
  float last = 0.0f;
  for (float pitch : {10.0f, 30.0f, 50.0f, 70.0f}) {
    float r = pitch * kPi / 180.0f;
    PinholeView cam = camera_at(vec3(0, 5, 8), vec3(0, 5 - std::sin(r), 8 - std::cos(r)), 40.0f, 40.0f);
    LispsmMap m = build_lispsm(cam, lv, lispsm_body(cam, spot.position, kScene, &lv));
    ASSERT_TRUE(m.perspective) << pitch;
    float ratio = m.n / (m.f - m.n);
    EXPECT_GT(ratio, last) << pitch;
    last = ratio;
  }
}

// ---- light views ----------------------------------------------------------------

TEST(LightViews, CubeFacesCoverAllDirectionsWithGuard) {
  const int res = 64;
  auto faces = cube_face_views(vec3(1, 2, 3), 0.01f, 50.0f, res);
  const Vec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int i = 0; i < 6; ++i) {
    expect_orthonormal(faces[size_t(i)]);
    EXPECT_NEAR(dot(faces[size_t(i)].forward, axes[i]), 1.0f, 1e-6f);
    EXPECT_NEAR(dot(cross(faces[size_t(i)].forward, faces[size_t(i)].up), faces[size_t(i)].right), 1.0f, 1e-5f);
  }
  std::mt19937 rng(5);
  std::normal_distribution<float> g(0.0f, 1.0f);
  for (int k = 0; k < 3000; ++k) {
    Vec3 d = normalize(vec3(g(rng), g(rng), g(rng)));
    Vec3 p = vec3(1, 2, 3) + d * 10.0f;
    int hits = 0;
    for (const PinholeView& f : faces) hits += inside_with_guard(f, p, 1.0f) ? 1 : 0;
    EXPECT_GE(hits, 1);
  }
  // The direction on a face edge is a full texel inside.
  ViewProjection q = project(faces[0], vec3(1, 2, 3) + vec3(1, 1, 0));
  EXPECT_NEAR(q.v, 1.0f, 1e-3f);
}

TEST(LightViews, SpotViewHoldsTheConeWithGuard) {
  LightShape spot = spot_light(vec3(0, 5, 0), vec3(0.3f, -1, 0.1f), 35.0f);
  PinholeView v = spot_view(spot, 256, 0.05f, 30.0f);
  expect_orthonormal(v);
  Vec3 e1, e2;
  make_frame(spot.direction, vec3(0, 1, 0), e1, e2);
  float t = std::tan(35.0f * kPi / 180.0f);
  for (int i = 0; i < 64; ++i) {
    float phi = 2 * kPi * float(i) / 64.0f;
    Vec3 p = spot.position + (spot.direction + (e1 * std::cos(phi) + e2 * std::sin(phi)) * t) * 10.0f;
    EXPECT_TRUE(inside_with_guard(v, p, 1.0f));
  }
}
