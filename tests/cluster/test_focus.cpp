// Focusing light frusta on clusters (thesis §3.4.2).
#include "cluster_test_util.h"

using namespace cluster_test;

// ---- focusing --------------------------------------------------------------------

TEST(Focus, FrustumHoldsEveryMemberCornerWithGuard) {
  LightShape pl = point_light(vec3(0, 8, 0));
  std::vector<Box3> members = {cube(vec3(4, 1, 3), 0.5f), cube(vec3(5, 0.5f, 2), 0.5f),
                               box(vec3(3, 0, 1), vec3(4, 2, 1.5f))};
  for (float guard : {1.0f, 3.0f}) {
    FocusParams fp;
    fp.resolution = 128;
    fp.guard_texels = guard;
    FocusResult f = focus_cluster(pl, members, fp);
    ASSERT_FALSE(f.split);
    ASSERT_EQ(f.views.size(), 1u);
    const PinholeView& v = f.views[0];
    expect_orthonormal(v);
    EXPECT_GT(v.near, 0.0f);
    for (const Box3& b : members)
      for (int i = 0; i < 8; ++i) EXPECT_TRUE(inside_with_guard(v, b.corner(i), guard));
    // Tight: some corner lies within about a texel of the guard on each side.
    float umin = 1e9f, umax = -1e9f, vmin = 1e9f, vmax = -1e9f;
    for (const Box3& b : members)
      for (int i = 0; i < 8; ++i) {
        ViewProjection q = project(v, b.corner(i));
        umin = std::min(umin, q.u), umax = std::max(umax, q.u), vmin = std::min(vmin, q.v), vmax = std::max(vmax, q.v);
      }
    EXPECT_LT(umin, guard + 0.1f);
    EXPECT_GT(umax, 128.0f - guard - 0.1f);
    EXPECT_LT(vmin, guard + 0.1f);
    EXPECT_GT(vmax, 128.0f - guard - 0.1f);
    // Re-aimed: the residual window offset is small.
    EXPECT_LT(std::fabs(v.center.x), 0.05f * v.tan_half_x + 1e-4f);
    EXPECT_LT(std::fabs(v.center.y), 0.05f * v.tan_half_y + 1e-4f);
  }
}

TEST(Focus, ReducesTexelSizeAgainstTheUnfocusedSpotMap) {
  LightShape spot = spot_light(vec3(0, 12, 0), vec3(0, -1, 0), 45.0f);
  const int res = 512;
  std::vector<Box3> members = {cube(vec3(-6, 0.5f, 4), 0.5f), cube(vec3(-5, 0.5f, 5), 0.4f)};
  FocusParams fp;
  fp.resolution = res;
  FocusResult f = focus_cluster(spot, members, fp);
  ASSERT_EQ(f.views.size(), 1u);
  PinholeView full = spot_view(spot, res, 0.01f, 40.0f);
  Vec3 c = (members[0].center() + members[1].center()) * 0.5f;
  auto texel = [&](const PinholeView& v) {
    float za = dot(c - v.eye, v.forward);
    return std::max(2.0f * v.tan_half_x, 2.0f * v.tan_half_y) * za / float(res);
  };
  EXPECT_LT(texel(f.views[0]), texel(full) / 4.0f) << texel(f.views[0]) << " vs " << texel(full);
  for (const Box3& b : members)
    for (int i = 0; i < 8; ++i) EXPECT_TRUE(inside_with_guard(f.views[0], b.corner(i), 1.0f));
}

TEST(Focus, SpotWindowNeverExceedsTheCone) {
  // A member much larger than the cone: the focused window is the cone's.
  LightShape spot = spot_light(vec3(0, 10, 0), vec3(0, -1, 0), 20.0f);
  FocusParams fp;
  fp.resolution = 256;
  FocusResult f = focus_cluster(spot, {box(vec3(-30, 0, -30), vec3(30, 1, 30))}, fp);
  ASSERT_EQ(f.views.size(), 1u);
  PinholeView cone = spot_view(spot, 256, 0.01f, 40.0f);
  EXPECT_LE(f.views[0].tan_half_x, cone.tan_half_x * 1.01f);
  EXPECT_LE(f.views[0].tan_half_y, cone.tan_half_y * 1.01f);
  EXPECT_GT(angle_deg(f.views[0].forward, spot.direction), -1.0f);
  EXPECT_LT(angle_deg(f.views[0].forward, spot.direction), 1.0f);
  // A box around the light of a narrow spot still focuses in one frustum.
  FocusResult g = focus_cluster(spot, {cube(spot.position, 1.0f)}, fp);
  EXPECT_FALSE(g.split);
  ASSERT_EQ(g.views.size(), 1u);
  EXPECT_LE(g.views[0].tan_half_x, cone.tan_half_x * 1.01f);
  // Entirely outside the cone: nothing to focus on.
  EXPECT_TRUE(focus_cluster(spot, {cube(vec3(20, 0, 0), 1.0f)}, fp).views.empty());
}

TEST(Focus, WideOrEnclosingClustersSplitPerCubeFace) {
  LightShape pl = point_light(vec3(0, 3, 0));
  FocusParams fp;
  fp.resolution = 128;
  // Boxes on both sides of the light: spans ~180°.
  std::vector<Box3> around = {cube(vec3(5, 3, 0), 0.5f), cube(vec3(-5, 3, 0), 0.5f)};
  FocusResult f = focus_cluster(pl, around, fp);
  EXPECT_TRUE(f.split);
  EXPECT_EQ(f.views.size(), 2u);
  for (const Box3& b : around)
    for (int i = 0; i < 8; ++i) {
      int hits = 0;
      for (const PinholeView& v : f.views) hits += inside_with_guard(v, b.corner(i), 1.0f) ? 1 : 0;
      EXPECT_GE(hits, 1);
    }
  // A box containing the light: pieces in all six faces, each within a face.
  std::vector<Box3> enclosing = {box(vec3(-2, 1, -2), vec3(2, 5, 2))};
  FocusResult g = focus_cluster(pl, enclosing, fp);
  EXPECT_TRUE(g.split);
  EXPECT_EQ(g.views.size(), 6u);
  for (const PinholeView& v : g.views) {
    expect_orthonormal(v);
    EXPECT_LE(std::fabs(v.center.x) + v.tan_half_x, 1.1f);
    EXPECT_LE(std::fabs(v.center.y) + v.tan_half_y, 1.1f);
  }
  for (int i = 0; i < 8; ++i) {
    int hits = 0;
    for (const PinholeView& v : g.views) hits += inside_with_guard(v, enclosing[0].corner(i), 1.0f) ? 1 : 0;
    EXPECT_GE(hits, 1);
  }
  // A cluster within ~110°: one frustum.
  std::vector<Box3> wedge = {cube(vec3(5, 0, 0), 0.3f), cube(vec3(0, 0, 5), 0.3f)};
  EXPECT_FALSE(focus_cluster(pl, wedge, fp).split);
}
