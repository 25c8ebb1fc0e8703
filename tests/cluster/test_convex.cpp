// Convex polygon clipping, convex bodies and the body B (thesis Alg. 4.3).
#include "cluster_test_util.h"

using namespace cluster_test;

// ---- convex clipping --------------------------------------------------------

TEST(Convex, ClipPolygonKeepsInnerSide) {
  Polygon sq{vec3(0, 0, 0), vec3(2, 0, 0), vec3(2, 2, 0), vec3(0, 2, 0)};
  std::vector<Vec3> cut;
  Polygon half = clip_polygon(sq, plane_through(vec3(0.5f, 0, 0), vec3(-1, 0, 0)), 1e-6f, &cut);
  ASSERT_EQ(half.size(), 4u);
  EXPECT_NEAR(0.5f * length(polygon_normal(half)), 1.0f, 1e-5f);  // 0.5 x 2
  for (Vec3 p : half) EXPECT_LE(p.x, 0.5f + 1e-6f);
  ASSERT_EQ(cut.size(), 2u);
  for (Vec3 p : cut) EXPECT_NEAR(p.x, 0.5f, 1e-6f);
  // Entirely outside: nothing; entirely inside: unchanged.
  EXPECT_TRUE(clip_polygon(sq, plane_through(vec3(3, 0, 0), vec3(1, 0, 0)), 1e-6f).empty());
  EXPECT_EQ(clip_polygon(sq, plane_through(vec3(-1, 0, 0), vec3(1, 0, 0)), 1e-6f).size(), 4u);
  // Cutting a corner off a triangle gives a quad.
  Polygon tri{vec3(0, 0, 0), vec3(4, 0, 0), vec3(0, 4, 0)};
  Polygon quad = clip_polygon(tri, plane_through(vec3(1, 0, 0), vec3(-1, 0, 0)), 1e-6f);
  ASSERT_EQ(quad.size(), 4u);
  EXPECT_NEAR(0.5f * length(polygon_normal(quad)), 8.0f - 4.5f, 1e-4f);
}

TEST(Convex, ClippedBoxIsClosedWithCap) {
  ConvexBody b = box_body(box(vec3(0, 0, 0), vec3(1, 1, 1)));
  EXPECT_NEAR(volume(b), 1.0f, 1e-5f);
  b.clip(plane_through(vec3(0.25f, 0, 0), vec3(-1, 0, 0)));  // keep x <= 0.25
  EXPECT_EQ(b.polygons.size(), 6u);
  EXPECT_NEAR(volume(b), 0.25f, 1e-5f);
  expect_convex(b, 1e-5f);

  ConvexBody c = box_body(box(vec3(0, 0, 0), vec3(1, 1, 1)));
  c.clip(plane_through(vec3(1, 1, 0.5f), vec3(-1, -1, -1)));  // x + y + z <= 2.5: a corner goes
  EXPECT_EQ(c.polygons.size(), 7u);
  EXPECT_NEAR(volume(c), 1.0f - 0.125f / 6.0f, 1e-5f);
  expect_convex(c, 1e-5f);
  EXPECT_TRUE(c.contains(vec3(0.5f, 0.5f, 0.5f)));
  EXPECT_FALSE(c.contains(vec3(0.95f, 0.95f, 0.95f)));
  EXPECT_FALSE(c.contains(vec3(1.1f, 0.5f, 0.5f)));

  ConvexBody d = box_body(box(vec3(0, 0, 0), vec3(1, 1, 1)));
  d.clip(plane_through(vec3(2, 0, 0), vec3(1, 0, 0)));  // keep x >= 2: nothing
  EXPECT_TRUE(d.empty());
  EXPECT_FALSE(d.contains(vec3(0.5f, 0.5f, 0.5f)));
}

TEST(Convex, HullWithPointAddsPyramid) {
  ConvexBody b = hull_with_point(box_body(box(vec3(0, 0, 0), vec3(1, 1, 1))), vec3(0.5f, 0.5f, 3.0f));
  EXPECT_NEAR(volume(b), 1.0f + 2.0f / 3.0f, 1e-4f);  // cube + pyramid of height 2
  expect_convex(b, 1e-5f);
  EXPECT_TRUE(b.contains(vec3(0.5f, 0.5f, 2.5f)));
  EXPECT_FALSE(b.contains(vec3(0.9f, 0.9f, 2.5f)));
  // A point off a corner sees three faces.
  ConvexBody c = hull_with_point(box_body(box(vec3(0, 0, 0), vec3(1, 1, 1))), vec3(2, 2, 2));
  expect_convex(c, 1e-5f);
  EXPECT_TRUE(c.contains(vec3(1.9f, 1.9f, 1.9f)));
  EXPECT_EQ(c.vertices().size(), 8u);  // the far corner is replaced by the point
  // A point inside changes nothing.
  ConvexBody d = hull_with_point(box_body(box(vec3(0, 0, 0), vec3(1, 1, 1))), vec3(0.5f, 0.5f, 0.5f));
  EXPECT_NEAR(volume(d), 1.0f, 1e-5f);
}

TEST(Convex, FrustumPlanesMatchTheView) {
  PinholeView v = camera_at(vec3(1, 2, 3), vec3(0, 0, 0));
  v.center = {0.2f, -0.1f};
  ConvexBody f = frustum_body(v);
  expect_convex(f, 1e-3f);
  std::vector<Plane> planes = frustum_planes(v);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> uni(-1.3f, 1.3f), depth(0.0f, 120.0f);
  for (int i = 0; i < 2000; ++i) {
    Vec3 p = v.eye +
             view_direction(v, (uni(rng) * 0.5f + 0.5f) * float(v.width), (uni(rng) * 0.5f + 0.5f) * float(v.height)) *
                 depth(rng);
    ViewProjection q = project(v, p);
    bool in_view = q.u >= 0 && q.u <= float(v.width) && q.v >= 0 && q.v <= float(v.height) && q.axial >= v.near &&
                   q.axial <= v.far;
    bool in_planes = true;
    for (const Plane& pl : planes) in_planes &= signed_distance(pl, p) >= 0.0f;
    if (std::fabs(q.u) > 0.01f && std::fabs(q.u - float(v.width)) > 0.01f && std::fabs(q.v) > 0.01f &&
        std::fabs(q.v - float(v.height)) > 0.01f) {
      EXPECT_EQ(in_view, in_planes);
    }
  }
}

// ---- the body B (thesis Alg. 4.3) ---------------------------------------------

// Samples of the camera frustum inside the scene box and the light frustum
// must lie in B; B must be convex.
static void check_body(const PinholeView& cam, Vec3 light_pos, const PinholeView* light_frustum,
                       int min_samples = 200) {
  ConvexBody B = lispsm_body(cam, light_pos, kScene, light_frustum);
  ASSERT_FALSE(B.empty());
  expect_convex(B, 2e-3f);
  Box3 bb = B.bounds();
  EXPECT_GE(bb.lo.x, kScene.lo.x - 1e-3f);
  EXPECT_LE(bb.hi.y, kScene.hi.y + 1e-3f);
  std::vector<Plane> lp;
  if (light_frustum) lp = frustum_planes(*light_frustum);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u01(0.0f, 1.0f);
  int tested = 0;
  for (int i = 0; i < 20000; ++i) {
    float z = cam.near + (cam.far - cam.near) * u01(rng) * u01(rng);
    Vec3 p = cam.eye + view_direction(cam, u01(rng) * float(cam.width), u01(rng) * float(cam.height)) * z;
    bool in = p.x >= kScene.lo.x && p.x <= kScene.hi.x && p.y >= kScene.lo.y && p.y <= kScene.hi.y &&
              p.z >= kScene.lo.z && p.z <= kScene.hi.z;
    for (const Plane& pl : lp) in &= signed_distance(pl, p) >= 0.0f;
    if (!in) continue;
    ++tested;
    EXPECT_TRUE(B.contains(p, 2e-3f)) << p.x << " " << p.y << " " << p.z;
  }
  EXPECT_GT(tested, min_samples);
  // Segments from the light to visible points (the shadow rays) stay in B.
  for (int i = 0; i < 2000; ++i) {
    float z = cam.near + (cam.far - cam.near) * u01(rng) * u01(rng);
    Vec3 p = cam.eye + view_direction(cam, u01(rng) * float(cam.width), u01(rng) * float(cam.height)) * z;
    Vec3 q = light_pos + (p - light_pos) * u01(rng);
    bool in = q.x >= kScene.lo.x && q.x <= kScene.hi.x && q.y >= kScene.lo.y && q.y <= kScene.hi.y &&
              q.z >= kScene.lo.z && q.z <= kScene.hi.z;
    for (const Plane& pl : lp) in &= signed_distance(pl, q) >= 0.0f;
    if (in) {
      EXPECT_TRUE(B.contains(q, 2e-3f));
    }
  }
}

TEST(Body, SpotLightBodyIsConvexAndHoldsTheVisibleRegion) {
  LightShape spot = spot_light(vec3(0, 12, 0), vec3(0, -1, 0), 40.0f);
  PinholeView lv = spot_view(spot, 512, 0.01f, 40.0f);
  check_body(camera_at(vec3(0, 3, 14), vec3(0, 0.5f, 0)), spot.position, &lv);
  // Light inside the camera frustum, camera inside the scene box.
  LightShape spot2 = spot_light(vec3(2, 5, -6), vec3(-0.3f, -1, 0.2f), 50.0f);
  PinholeView lv2 = spot_view(spot2, 512, 0.01f, 40.0f);
  check_body(camera_at(vec3(0, 2, 8), vec3(0, 1, -5)), spot2.position, &lv2);
}

TEST(Body, PointLightBodyWithAndWithoutFaceFrustum) {
  PinholeView cam = camera_at(vec3(-3, 4, 9), vec3(1, 0, -2));
  Vec3 l = vec3(1, 3, 1);
  check_body(cam, l, nullptr);
  auto faces = cube_face_views(l, 0.01f, 40.0f, 256);
  for (const PinholeView& f : faces) {
    ConvexBody B = lispsm_body(cam, l, kScene, &f);
    if (!B.empty()) check_body(cam, l, &f, 20);
  }
}

TEST(Body, LightFarOutsideTheSceneBox) {
  LightShape spot = spot_light(vec3(30, 40, 30), vec3(-30, -40, -30), 20.0f);
  PinholeView lv = spot_view(spot, 512, 0.01f, 200.0f);
  check_body(camera_at(vec3(0, 3, 14), vec3(0, 0.5f, 0)), spot.position, &lv);
}
