// Greedy clustering (thesis Alg. 4.2), the whole clustering pipeline and
// frame-to-frame hysteresis.
#include "cluster_test_util.h"

using namespace cluster_test;

// ---- greedy clustering (thesis Alg. 4.2) ------------------------------------------

TEST(Greedy, KnownTables) {
  // Two tight pairs far apart.
  CasterDistances D = table(4, {{0, .1f, 1, 1}, {.1f, 0, 1, 1}, {1, 1, 0, .1f}, {1, 1, .1f, 0}});
  auto g = greedy_clusters(D, 0.5f, 4);
  ASSERT_EQ(g.size(), 2u);
  std::set<std::set<int>> got;
  for (auto& c : g) got.insert(std::set<int>(c.begin(), c.end()));
  EXPECT_EQ(got, (std::set<std::set<int>>{{0, 1}, {2, 3}}));
  // m = 1: one cluster.
  auto one = greedy_clusters(D, 0.5f, 1);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].size(), 4u);
  // Three mutually far casters with m = 2: the third joins the nearest
  // (smallest maximum distance to the members).
  CasterDistances E = table(3, {{0, 1, .6f}, {1, 0, .9f}, {.6f, .9f, 0}});
  auto h = greedy_clusters(E, 0.5f, 2);
  ASSERT_EQ(h.size(), 2u);
  expect_partition(h, 3);
  std::set<std::set<int>> got2;
  for (auto& c : h) got2.insert(std::set<int>(c.begin(), c.end()));
  EXPECT_EQ(got2, (std::set<std::set<int>>{{0, 2}, {1}}));
  // A chain 0-1-2 with d0 between the links and the span: {0,1} or {1,2}, never all three.
  CasterDistances F = table(3, {{0, .3f, .6f}, {.3f, 0, .3f}, {.6f, .3f, 0}});
  auto k = greedy_clusters(F, 0.4f, 3);
  ASSERT_EQ(k.size(), 2u);
  for (auto& c : k)
    for (int a : c)
      for (int b : c) EXPECT_LE(F.d(a, b), 0.4f);
}

TEST(Greedy, SingleAndNoCaster) {
  CasterDistances D = table(1, {{0}});
  auto g = greedy_clusters(D, 0.1f, 3);
  ASSERT_EQ(g.size(), 1u);
  EXPECT_EQ(g[0], std::vector<int>{0});
  EXPECT_TRUE(greedy_clusters(table(0, {}), 0.1f, 3).empty());
  // A caster outside every B (unseen) still gets a cluster; it is placed by
  // the uniform distances.
  CasterDistances U = table(3, {{0, .1f, 1}, {.1f, 0, 1}, {1, 1, 0}});
  U.seen[2] = 0;
  U.uniform[0 * 3 + 2] = U.uniform[2 * 3 + 0] = 0.05f;
  U.uniform[1 * 3 + 2] = U.uniform[2 * 3 + 1] = 0.08f;
  auto u = greedy_clusters(U, 0.2f, 3);
  ASSERT_EQ(u.size(), 1u);
  EXPECT_EQ(u[0].size(), 3u);
}

// ---- the whole pipeline ---------------------------------------------------------------

static std::vector<Caster> two_groups() {
  std::vector<Caster> c;
  int id = 10;
  for (Vec3 p : {vec3(-6.5f, 0.5f, 0.3f), vec3(-6, 0.5f, -0.4f), vec3(-5.6f, 0.5f, 0.2f)})
    c.push_back({id++, cube(p, 0.3f)});
  for (Vec3 p : {vec3(6.5f, 0.5f, 0.3f), vec3(6, 0.5f, -0.4f), vec3(5.6f, 0.5f, 0.2f)})
    c.push_back({id++, cube(p, 0.3f)});
  return c;
}

// What the two-group tests cluster them with: d0 0.3, up to 4 clusters at 256^2.
static ClusterSettings two_group_settings() {
  ClusterSettings s;
  s.d0 = 0.3f;
  s.max_clusters = 4;
  s.resolution = 256;
  return s;
}

TEST(Clustering, TwoFarGroupsMakeTwoClusters) {
  LightShape spot = spot_light(vec3(0, 12, 0), vec3(0, -1, 0), 50.0f);
  PinholeView cam = camera_at(vec3(0, 3, 14), vec3(0, 0.5f, 0));
  std::vector<Caster> casters = two_groups();
  ClusterSettings s = two_group_settings();
  // The premise: small distances within a group, large across.
  CasterDistances D = caster_distances(spot, cam, kScene, casters, s);
  ASSERT_EQ(D.directions.size(), 1u);
  EXPECT_TRUE(D.directions[0].map.perspective);
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(D.seen[size_t(i)], 1u);
    for (int j = 0; j < 6; ++j) {
      if (i == j) continue;
      if ((i < 3) == (j < 3)) {
        EXPECT_LT(D.d(i, j), 0.3f) << i << " " << j;
      } else {
        EXPECT_GT(D.d(i, j), 0.6f) << i << " " << j;
      }
    }
  }
  Clustering c = cluster_casters(spot, cam, kScene, casters, s);
  EXPECT_EQ(c.directions, 1);
  EXPECT_EQ(c.perspective_directions, 1);
  ASSERT_EQ(c.clusters.size(), 2u);
  auto sets = member_sets(c);
  std::set<std::set<int32_t>> got(sets.begin(), sets.end());
  EXPECT_EQ(got, (std::set<std::set<int32_t>>{{10, 11, 12}, {13, 14, 15}}));
  for (const Cluster& k : c.clusters) {
    ASSERT_EQ(k.views.size(), 1u);
    EXPECT_FALSE(k.split);
    for (int32_t id : k.members)
      for (int i = 0; i < 8; ++i)
        EXPECT_TRUE(inside_with_guard(k.views[0], casters[size_t(id - 10)].bounds.corner(i), 1.0f));
  }
  // m = 1: everything in one cluster.
  s.max_clusters = 1;
  Clustering one = cluster_casters(spot, cam, kScene, casters, s);
  ASSERT_EQ(one.clusters.size(), 1u);
  EXPECT_EQ(one.clusters[0].members, (std::vector<int32_t>{10, 11, 12, 13, 14, 15}));
  // A single caster: one cluster.
  Clustering single = cluster_casters(spot, cam, kScene, {casters[0]}, s);
  ASSERT_EQ(single.clusters.size(), 1u);
  EXPECT_EQ(single.clusters[0].members, std::vector<int32_t>{10});
  // No casters: no clusters.
  EXPECT_TRUE(cluster_casters(spot, cam, kScene, {}, s).clusters.empty());
}

TEST(Clustering, OmniDistancesUseOnlyFacesBothCastersOccupy) {
  LightShape pl = point_light(vec3(0, 3, 0));
  PinholeView cam = camera_at(vec3(0, 5, 9.5f), vec3(0, 2, 0), 90.0f);
  std::vector<Caster> casters = {{0, cube(vec3(6, 3, 0), 0.3f)},                         // +X only
                                 {1, box(vec3(5, 2.5f, 4.6f), vec3(5.6f, 3.5f, 5.4f))},  // straddles +X / +Z
                                 {2, cube(vec3(-6, 3, 0), 0.3f)},                        // -X only
                                 {3, cube(vec3(6, 3, 1.5f), 0.3f)}};                     // +X only
  ClusterSettings s;
  s.resolution = 256;
  CasterDistances D = caster_distances(pl, cam, kScene, casters, s);
  ASSERT_EQ(D.directions.size(), 6u);
  // Face order +X, -X, +Y, -Y, +Z, -Z.
  EXPECT_EQ(D.seen[0], 1u << 0);
  EXPECT_EQ(D.seen[1], (1u << 0) | (1u << 4));
  EXPECT_EQ(D.seen[2], 1u << 1);
  EXPECT_EQ(D.seen[3], 1u << 0);
  // No common face: "infinitely" far.
  EXPECT_EQ(D.d(0, 2), kFarDistance);
  EXPECT_EQ(D.d(1, 2), kFarDistance);
  // 0-1 and 0-3 share only +X: the +X distance, computed here from that
  // face's map over the boxes' parts inside its B.
  auto extent = [&](int face, int i, Vec2& lo, Vec2& hi) {
    ConvexBody b = box_body(casters[size_t(i)].bounds);
    b.clip(D.directions[size_t(face)].body.planes());
    lo = {1e9f, 1e9f};
    hi = {-1e9f, -1e9f};
    for (Vec3 p : b.vertices()) {
      Vec2 q;
      ASSERT_TRUE(D.directions[size_t(face)].map.map(p, q));
      lo = {std::min(lo.x, q.x), std::min(lo.y, q.y)};
      hi = {std::max(hi.x, q.x), std::max(hi.y, q.y)};
    }
  };
  auto dist = [&](int face, int i, int j) {
    Vec2 li, hi, lj, hj;
    extent(face, i, li, hi);
    extent(face, j, lj, hj);
    return std::max(std::hypot(li.x - lj.x, li.y - lj.y), std::hypot(hi.x - hj.x, hi.y - hj.y));
  };
  EXPECT_NEAR(D.d(0, 1), dist(0, 0, 1), 1e-5f);
  EXPECT_NEAR(D.d(0, 3), dist(0, 0, 3), 1e-5f);
  EXPECT_GT(D.d(0, 3), 0.0f);
  // Clustering with m = 2 keeps the -X caster apart.
  s.d0 = 5.0f;  // everything sharing a face is "close"
  s.max_clusters = 2;
  Clustering c = cluster_casters(pl, cam, kScene, casters, s);
  ASSERT_EQ(c.clusters.size(), 2u);
  auto sets = member_sets(c);
  std::set<std::set<int32_t>> got(sets.begin(), sets.end());
  EXPECT_EQ(got, (std::set<std::set<int32_t>>{{0, 1, 3}, {2}}));
  EXPECT_EQ(c.directions, 6);
}

TEST(Clustering, RandomLayoutsKeepTheInvariants) {
  std::mt19937 rng(20240611);
  std::uniform_real_distribution<float> ux(-9.0f, 9.0f), uy(0.0f, 5.0f), uh(0.1f, 0.8f), u01(0.0f, 1.0f);
  int d0_checked = 0, m_reached = 0;  // the layouts must exercise both regimes
  for (int layout = 0; layout < 30; ++layout) {
    const bool omni = layout % 2 == 1;
    LightShape light = omni ? point_light(vec3(ux(rng) * 0.5f, 4.0f + u01(rng), ux(rng) * 0.5f))
                            : spot_light(vec3(ux(rng) * 0.3f, 11, ux(rng) * 0.3f),
                                         vec3(ux(rng) * 0.05f, -1, ux(rng) * 0.05f), 30.0f + 25.0f * u01(rng));
    PinholeView cam =
        camera_at(vec3(ux(rng), 1.0f + 4.0f * u01(rng), 12.0f), vec3(ux(rng) * 0.3f, 0.5f, ux(rng) * 0.3f));
    const int n = 1 + int(u01(rng) * 15.0f);
    std::vector<Caster> casters;
    for (int i = 0; i < n; ++i) {
      Vec3 c = vec3(ux(rng), uy(rng), ux(rng));
      // keep casters clear of the light for the containment check below
      if (length(c - light.position) < 2.0f) c = c + vec3(3, 0, 0);
      float h = uh(rng);
      casters.push_back({100 + i, box(c - vec3(h, h * 0.5f, h), c + vec3(h, h * 0.5f, h))});
    }
    ClusterSettings s;
    s.d0 = 0.05f + 1.0f * u01(rng);
    s.max_clusters = layout % 3 == 2 ? 8 : 1 + int(u01(rng) * 5.0f);
    s.resolution = 128;
    SCOPED_TRACE("layout " + std::to_string(layout) + (omni ? " omni" : " spot") + " n=" + std::to_string(n) +
                 " m=" + std::to_string(s.max_clusters));
    CasterDistances D = caster_distances(light, cam, kScene, casters, s);
    auto groups = greedy_clusters(D, s.d0, s.max_clusters);
    EXPECT_LE(int(groups.size()), s.max_clusters);
    EXPECT_GE(groups.size(), 1u);
    expect_partition(groups, n);
    // While fewer than m clusters exist, every two lit members are within d0
    // (unlit casters cast no shadow; they only need a home).
    if (int(groups.size()) < s.max_clusters) {
      for (const auto& g : groups) {
        if (g.size() >= 2) ++d0_checked;
        for (int a : g)
          for (int b : g) {
            if (D.lit[size_t(a)] && D.lit[size_t(b)]) {
              EXPECT_LE(D.d(a, b), s.d0) << a << " " << b;
            }
          }
      }
    }
    if (int(groups.size()) == s.max_clusters && s.max_clusters < n) ++m_reached;

    Clustering c = cluster_casters(light, cam, kScene, casters, s);
    EXPECT_EQ(c.clusters.size(), groups.size());
    std::set<int32_t> ids;
    for (const Cluster& k : c.clusters) {
      for (int32_t id : k.members) EXPECT_TRUE(ids.insert(id).second) << "id " << id << " twice";
      for (const PinholeView& v : k.views) expect_orthonormal(v);
      // The frustum is focused on the members inside some B (only their
      // shadows reach the view); without any, on all lit members.
      bool any_seen = false;
      for (int32_t id : k.members) any_seen = any_seen || D.seen[size_t(id - 100)] != 0u;
      auto focused = [&](int32_t id) { return !any_seen || D.seen[size_t(id - 100)] != 0u; };
      if (!omni) {
        // Spot: every member corner inside the cone is in the cluster's frustum.
        const float cos_cone = std::cos((light.outer_cone_deg - 0.01f) * kPi / 180.0f);
        for (int32_t id : k.members)
          for (int i = 0; i < 8; ++i) {
            if (!focused(id)) continue;
            Vec3 p = casters[size_t(id - 100)].bounds.corner(i);
            if (dot(normalize(p - light.position), light.direction) < cos_cone) continue;
            int hits = 0;
            for (const PinholeView& v : k.views) hits += inside_with_guard(v, p, 1.0f) ? 1 : 0;
            EXPECT_GE(hits, 1) << "id " << id << " corner " << i;
          }
        continue;
      }
      // Every focused member corner is in one of the cluster's frusta, with guard.
      for (int32_t id : k.members)
        for (int i = 0; i < 8; ++i) {
          if (!focused(id)) continue;
          Vec3 p = casters[size_t(id - 100)].bounds.corner(i);
          int hits = 0;
          for (const PinholeView& v : k.views) hits += inside_with_guard(v, p, 1.0f) ? 1 : 0;
          EXPECT_GE(hits, 1) << "id " << id << " corner " << i;
        }
    }
    EXPECT_EQ(int(ids.size()), n);
  }
  EXPECT_GE(d0_checked, 3);
  EXPECT_GE(m_reached, 3);
}

TEST(Clustering, SpotFocusHoldsMemberCornersInsideTheCone) {
  LightShape spot = spot_light(vec3(0, 12, 0), vec3(0, -1, 0), 35.0f);
  PinholeView cam = camera_at(vec3(0, 3, 14), vec3(0, 0.5f, 0));
  std::vector<Caster> casters = two_groups();
  casters.push_back({16, box(vec3(-12, 0, -1), vec3(-4, 1, 1))});  // sticks out of the cone
  ClusterSettings s;
  s.d0 = 0.3f;
  s.max_clusters = 3;
  s.guard_texels = 2.0f;
  s.resolution = 256;
  Clustering c = cluster_casters(spot, cam, kScene, casters, s);
  const float cos_cone = std::cos(35.0f * kPi / 180.0f);
  for (const Cluster& k : c.clusters) {
    ASSERT_EQ(k.views.size(), 1u);
    for (int32_t id : k.members) {
      const Box3& b = casters[size_t(id - 10)].bounds;
      for (int i = 0; i < 8; ++i) {
        Vec3 d = b.corner(i) - spot.position;
        if (dot(normalize(d), spot.direction) < cos_cone) continue;  // unlit corner
        EXPECT_TRUE(inside_with_guard(k.views[0], b.corner(i), 2.0f)) << id << " " << i;
      }
    }
  }
}

// ---- hysteresis ---------------------------------------------------------------------------

TEST(Hysteresis, KeepsAssignmentWithinToleranceAndReclustersBeyond) {
  LightShape spot = spot_light(vec3(0, 12, 0), vec3(0, -1, 0), 50.0f);
  PinholeView cam = camera_at(vec3(0, 3, 14), vec3(0, 0.5f, 0));
  std::vector<Caster> casters = {{1, cube(vec3(-2, 0.5f, 0), 0.4f)}, {2, cube(vec3(2, 0.5f, 0), 0.4f)}};
  ClusterSettings s;
  s.max_clusters = 2;
  s.resolution = 256;
  s.hysteresis = 0.25f;
  const float d12 = caster_distances(spot, cam, kScene, casters, s).d(0, 1);
  ASSERT_GT(d12, 0.05f);

  s.d0 = d12 * 1.05f;  // together
  Clustering f0 = cluster_casters(spot, cam, kScene, casters, s);
  ASSERT_EQ(f0.clusters.size(), 1u);

  // Nothing moved: kept, nothing to rebuild.
  Clustering f1 = update_clusters(spot, cam, kScene, casters, s, f0);
  EXPECT_FALSE(f1.reclustered);
  ASSERT_EQ(f1.clusters.size(), 1u);
  EXPECT_FALSE(f1.clusters[0].members_changed);
  EXPECT_FALSE(f1.clusters[0].views_changed);
  EXPECT_EQ(f1.clusters[0].previous, 0);

  // A small camera move: the distances change a little, the clusters stay,
  // and so do the focused frusta (they do not depend on the camera).
  PinholeView cam2 = camera_at(vec3(0.3f, 3.1f, 13.8f), vec3(0.05f, 0.5f, 0));
  Clustering f2 = update_clusters(spot, cam2, kScene, casters, s, f1);
  EXPECT_FALSE(f2.reclustered);
  EXPECT_FALSE(f2.clusters[0].views_changed);

  // The pair now slightly beyond d0 (within d0 (1 + h)): a fresh clustering
  // would split it, hysteresis keeps it.
  s.d0 = d12 * 0.95f;
  ASSERT_EQ(cluster_casters(spot, cam, kScene, casters, s).clusters.size(), 2u);
  Clustering f3 = update_clusters(spot, cam, kScene, casters, s, f2);
  EXPECT_FALSE(f3.reclustered);
  EXPECT_EQ(f3.clusters.size(), 1u);

  // Far beyond: re-clustered into two, both new member sets.
  s.d0 = d12 * 0.7f;
  Clustering f4 = update_clusters(spot, cam, kScene, casters, s, f3);
  EXPECT_TRUE(f4.reclustered);
  ASSERT_EQ(f4.clusters.size(), 2u);
  for (const Cluster& k : f4.clusters) {
    EXPECT_TRUE(k.members_changed);
    EXPECT_TRUE(k.views_changed);
    EXPECT_EQ(k.previous, -1);
  }

  // Two clusters close enough to merge (union within d0 / (1 + h)): merged.
  s.d0 = d12 * 1.3f;
  Clustering f5 = update_clusters(spot, cam, kScene, casters, s, f4);
  EXPECT_TRUE(f5.reclustered);
  EXPECT_EQ(f5.clusters.size(), 1u);
  // ...but within the band (d12 > d0 / (1 + h)) two clusters are kept.
  s.d0 = d12 * 1.1f;
  Clustering f6 = update_clusters(spot, cam, kScene, casters, s, f4);
  EXPECT_FALSE(f6.reclustered);
  EXPECT_EQ(f6.clusters.size(), 2u);
}

TEST(Hysteresis, ReportsWhichClustersChanged) {
  LightShape spot = spot_light(vec3(0, 12, 0), vec3(0, -1, 0), 50.0f);
  PinholeView cam = camera_at(vec3(0, 3, 14), vec3(0, 0.5f, 0));
  std::vector<Caster> casters = two_groups();
  ClusterSettings s = two_group_settings();
  Clustering f0 = cluster_casters(spot, cam, kScene, casters, s);
  ASSERT_EQ(f0.clusters.size(), 2u);

  // A new caster next to the right group: re-cluster; the left group's
  // cluster is unchanged (same members, same frustum), the right one changed.
  std::vector<Caster> more = casters;
  more.push_back({16, cube(vec3(6.2f, 0.5f, 0.8f), 0.3f)});
  Clustering f1 = update_clusters(spot, cam, kScene, more, s, f0);
  EXPECT_TRUE(f1.reclustered);
  ASSERT_EQ(f1.clusters.size(), 2u);
  int unchanged = 0, changed = 0;
  for (const Cluster& k : f1.clusters) {
    if (k.members == std::vector<int32_t>{10, 11, 12}) {
      ++unchanged;
      EXPECT_FALSE(k.members_changed);
      EXPECT_FALSE(k.views_changed);
      ASSERT_GE(k.previous, 0);
      EXPECT_EQ(f0.clusters[size_t(k.previous)].members, k.members);
    } else {
      ++changed;
      EXPECT_EQ(k.members, (std::vector<int32_t>{13, 14, 15, 16}));
      EXPECT_TRUE(k.members_changed);
      EXPECT_TRUE(k.views_changed);
    }
  }
  EXPECT_EQ(unchanged, 1);
  EXPECT_EQ(changed, 1);

  // The light moves: members kept, every frustum must be rebuilt.
  LightShape moved = spot;
  moved.position = vec3(0.5f, 12, 0);
  Clustering f2 = update_clusters(moved, cam, kScene, more, s, f1);
  EXPECT_FALSE(f2.reclustered);
  for (const Cluster& k : f2.clusters) {
    EXPECT_FALSE(k.members_changed);
    EXPECT_TRUE(k.views_changed);
  }
}

TEST(Hysteresis, UnlitCastersDoNotForceReclustering) {
  LightShape spot = spot_light(vec3(0, 12, 0), vec3(0, -1, 0), 30.0f);
  PinholeView cam = camera_at(vec3(0, 3, 14), vec3(0, 0.5f, 0));
  std::vector<Caster> casters = {{1, cube(vec3(-2, 0.5f, 0), 0.4f)},
                                 {2, cube(vec3(2, 0.5f, 0), 0.4f)},
                                 {3, cube(vec3(9, 0.5f, 9), 0.4f)}};  // outside the cone
  ClusterSettings s;
  s.d0 = 0.05f;
  s.max_clusters = 4;
  s.resolution = 256;
  CasterDistances D = caster_distances(spot, cam, kScene, casters, s);
  EXPECT_EQ(D.lit, (std::vector<uint8_t>{1, 1, 0}));
  Clustering f0 = cluster_casters(spot, cam, kScene, casters, s);
  ASSERT_EQ(f0.clusters.size(), 2u);  // the unlit caster joins one, opens none
  Clustering f1 = update_clusters(spot, cam, kScene, casters, s, f0);
  EXPECT_FALSE(f1.reclustered);
  for (const Cluster& k : f1.clusters) EXPECT_FALSE(k.views_changed);
}

TEST(Clustering, WideSpotUsesCubeFacesAndItsCone) {
  LightShape spot = spot_light(vec3(0, 5, 0), vec3(0, -1, 0), 75.0f);
  PinholeView cam = camera_at(vec3(0, 3, 14), vec3(0, 0.5f, 0));
  std::vector<Caster> casters = {{0, cube(vec3(-8, 0.5f, 0), 0.5f)},
                                 {1, cube(vec3(8, 0.5f, 1), 0.5f)},
                                 {2, cube(vec3(0, 0.5f, 2), 0.5f)},
                                 {3, cube(vec3(3, 9, 0), 0.5f)}};  // above the light: unlit
  ClusterSettings s;
  s.d0 = 0.3f;
  s.max_clusters = 1;
  s.resolution = 256;
  CasterDistances D = caster_distances(spot, cam, kScene, casters, s);
  EXPECT_EQ(D.directions.size(), 6u);
  EXPECT_EQ(D.lit, (std::vector<uint8_t>{1, 1, 1, 0}));
  Clustering c = cluster_casters(spot, cam, kScene, casters, s);
  ASSERT_EQ(c.clusters.size(), 1u);
  const Cluster& k = c.clusters[0];
  EXPECT_TRUE(k.split);  // ~130° between the outer casters
  EXPECT_GE(k.views.size(), 2u);
  EXPECT_LE(k.views.size(), 5u);  // the +Y face is outside the cone
  const float cos_cone = std::cos(74.99f * kPi / 180.0f);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 8; ++j) {
      Vec3 p = casters[size_t(i)].bounds.corner(j);
      if (dot(normalize(p - spot.position), spot.direction) < cos_cone) continue;
      int hits = 0;
      for (const PinholeView& v : k.views) hits += inside_with_guard(v, p, 1.0f) ? 1 : 0;
      EXPECT_GE(hits, 1) << i << " " << j;
    }
}

// A point light in a small scene (teapot_omni.json's: a 6 m floor, the
// light 0.55 m up between a teapot, a cup with steam and a glass sphere).
// The light's near clamp is a few micrometres, and each cube face's B (the
// hull of the camera frustum and the light, cut by the face) keeps the
// light itself as a vertex within the clip's tolerance; that vertex has no
// image. It made the face's LiSPSM map invalid, so no caster counted as
// seen in that face, and a cluster's focused maps were fitted to its one
// seen member: the glass sphere's shadow, in front of the camera, fell in
// no map (T 1 against 0.36, teapot_omni with clusters 2: T-RMSE 0.12).
TEST(Clustering, APointLightInASmallSceneSeesEveryCasterTheCameraSees) {
  const LightShape pl = point_light(vec3(0.05f, 0.55f, 0.05f));
  const Box3 scene = box(vec3(-3, 0, -3), vec3(3, 1, 3));
  PinholeView cam = camera_at(vec3(0.2f, 1.6f, 3.2f), vec3(0, 0.35f, 0), 40.0f, 30.0f);
  const std::vector<Caster> casters = {{1, box(vec3(-1.15f, 0, -0.32f), vec3(-0.18f, 0.5f, 0.32f))},       // teapot
                                       {2, box(vec3(0.36f, 0, -0.29f), vec3(1.14f, 0.34f, 0.49f))},        // cup
                                       {3, box(vec3(0.56f, 0.3f, -0.09f), vec3(0.94f, 0.97f, 0.29f))},     // steam
                                       {4, box(vec3(-0.18f, 0.001f, 0.62f), vec3(0.18f, 0.36f, 0.98f))}};  // glass
  ClusterSettings s;
  s.min_near = near_clamp(pl, scene);
  ASSERT_LT(s.min_near, 1e-3f);
  const CasterDistances D = caster_distances(pl, cam, scene, casters, s);
  ASSERT_EQ(D.directions.size(), 6u);
  for (size_t k = 0; k < D.directions.size(); ++k)
    EXPECT_TRUE(D.directions[k].body.empty() || D.directions[k].map.valid) << "face " << k;
  for (size_t i = 0; i < casters.size(); ++i) EXPECT_NE(D.seen[i], 0u) << "caster " << casters[i].id;
  // Two clusters: every member's box lies within its cluster's maps.
  s.max_clusters = 2;
  s.d0 = 0.0f;
  const Clustering c = cluster_casters(pl, cam, scene, casters, s);
  for (const Cluster& cl : c.clusters)
    for (int32_t id : cl.members) {
      const Box3& b = casters[size_t(id - 1)].bounds;
      for (int corner = 0; corner < 8; ++corner) {
        const Vec3 p = b.corner(corner) * 0.9f + (b.lo + b.hi) * 0.05f;  // inside, off the box's faces
        bool held = false;
        for (const PinholeView& v : cl.views) {
          const ViewProjection pr = project(v, p);
          held = held ||
                 (pr.axial > 0.0f && pr.u >= 0.0f && pr.v >= 0.0f && pr.u <= float(v.width) && pr.v <= float(v.height));
        }
        EXPECT_TRUE(held) << "caster " << id << " corner " << corner << " in none of its cluster's " << cl.views.size()
                          << " maps";
      }
    }
}
