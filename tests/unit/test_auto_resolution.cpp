// Auto resolution (issue 48): each map sized from the screen so that about
// `texels_per_pixel` texels cross an image pixel where its receivers are
// seen. A receive-only ground strip under the sun with two boards, one 4 m
// from the camera and one 32 m away, two clusters (d0 0): one focused map
// per board, its receivers seen at distances eight times apart; each map's
// median density must be within one ladder step of the target, for two
// targets. A camera moving a little keeps the rungs (hysteresis); one
// moving twice as close to the near board raises its map by about two rungs.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <tuple>

#include "auto_resolution.h"
#include "cdsm/renderer.h"
#include "cdsm/scene_io.h"
#include "common/camera_path.h"
#include "common/sanitized.h"
#include "memory_budget.h"
#include "unit_util.h"

using namespace cdsm;
using namespace cdsm_test;

namespace {

constexpr double kStep = 1.41421356;  // one ladder step

Scene two_boards(Vec3 eye) {
  Scene sc;
  sc.source = "two boards at 4 and 32 m";
  sc.objects.push_back(surface_object("ground", make_ground(8.0f, 80.0f, 0.1f), Mat4{}, 1.0f, /*casts=*/false));
  for (float z : {-4.0f, -32.0f})
    sc.objects.push_back(surface_object("board", make_box({1.5f, 0.05f, 1.5f}),
                                        make_transform({0.3f, 0.8f, z}, {0, 0, 0}, {1, 1, 1}), 1.0f));
  sc.lights.push_back(sun_light({0.3f, -1.0f, 0.2f}));
  sc.camera = camera_at(eye, {0.0f, 0.0f, -16.0f}, 320, 240);
  sc.camera.far = 200.0f;
  sc.shadows.resolution = kAutoResolution;
  sc.shadows.max_clusters = 2;
  sc.shadows.d0 = 0.0f;
  return sc;
}

RenderOptions cpu() {
  RenderOptions o;
  o.backend = Backend::Cpu;
  o.fragments = FragmentSource::Cpu;
  return o;
}

TEST(AutoResolution, TheLadder) {
  const int expect[] = {16, 23, 32, 45, 64, 91, 128, 181, 256, 362, 512, 724, 1024, 1448, 2048, 2896, 4096};
  for (int k = 0; k < int(std::size(expect)); ++k) {
    EXPECT_EQ(resolution_rung(k), expect[k]) << k << ": " << resolution_rung(k);
    EXPECT_NEAR(rung_position(resolution_rung(k)), k, 0.05) << k;  // 23 is 22.6 rounded
  }
}

// Each map's texels per pixel at its median receiver within one ladder step
// of the target, for receivers 4 and 32 m from the camera.
TEST(AutoResolution, AReceiverSeenAtTwoDistancesGetsTheTargetDensityAtBoth) {
  for (float target : {1.0f, 2.0f}) {
    Scene sc = two_boards({0.0f, 4.0f, 0.0f});
    sc.shadows.texels_per_pixel = target;
    Renderer r;
    FrameStats st;
    r.render(sc, cpu(), &st);
    ASSERT_EQ(st.clusters.size(), 1u);
    ASSERT_TRUE(st.clusters[0].clustered);
    ASSERT_EQ(st.map_resolutions.size(), 2u);
    int near_res = 0, far_res = 0;
    for (const MapResolutionStats& m : st.map_resolutions) {
      std::printf("[ auto     ] target %.1f: %d^2, %s, %u receivers, texels per pixel median %.3f, p5 %.3f\n",
                  double(target), m.resolution, m.limit.c_str(), m.receivers, m.texels_per_pixel_median,
                  m.texels_per_pixel_p5);
      EXPECT_EQ(m.limit, "target");
      EXPECT_GE(m.receivers, 5u);
      EXPECT_GE(m.texels_per_pixel_median, target / kStep);
      EXPECT_LE(m.texels_per_pixel_median, target * kStep);
      (near_res == 0 ? near_res : far_res) = m.resolution;
    }
    // The same boards seen eight times farther: their maps differ by about
    // six rungs (2^3 per side), in either order of the clusters.
    EXPECT_GE(std::fabs(rung_position(near_res) - rung_position(far_res)), 4.0) << near_res << " vs " << far_res;
  }
}

TEST(AutoResolution, AMovingCameraKeepsItsRungsUntilAStepIsPassed) {
  Renderer r;
  FrameStats a, b, c;
  r.render(two_boards({0.0f, 4.0f, 0.0f}), cpu(), &a);
  r.render(two_boards({0.0f, 3.9f, -0.2f}), cpu(), &b);  // 4% closer to the near board
  ASSERT_EQ(a.map_resolutions.size(), 2u);
  ASSERT_EQ(b.map_resolutions.size(), 2u);
  for (size_t k = 0; k < 2; ++k) EXPECT_EQ(a.map_resolutions[k].resolution, b.map_resolutions[k].resolution) << k;
  EXPECT_EQ(b.update.rebuilt_by_reason[int(RebuildReason::Settings)], 0u);
  r.render(two_boards({0.0f, 2.0f, -2.0f}), cpu(), &c);  // about twice as close to the near board
  ASSERT_EQ(c.map_resolutions.size(), 2u);
  int risen = 0;
  for (size_t k = 0; k < 2; ++k)
    risen = std::max(risen, int(std::lround(rung_position(c.map_resolutions[k].resolution) -
                                            rung_position(a.map_resolutions[k].resolution))));
  EXPECT_GE(risen, 1);
}

// The hysteresis band: a map wanting 0.6 rungs above the one it has keeps
// it; 0.8 rungs above, it moves; with no rung before, it takes the nearest.
TEST(AutoResolution, HysteresisKeepsARungWithinThreeQuartersOfAStep) {
  auto setup = [] {
    LightSetup ls;
    LightData L{};
    L.type = LightType::Directional;
    L.map_count = 1;
    L.map_mode = MapMode::Combine;
    ls.lights.push_back(L);
    MapPlan p;
    p.view.eye = {0, 10, 0};
    p.view.forward = {0, -1, 0};
    p.view.right = {1, 0, 0};
    p.view.up = {0, 0, -1};
    p.view.tan_half_x = p.view.tan_half_y = 5.0f;  // 10 m across, guard band included
    p.view.width = p.view.height = 512;
    p.view.projection = Projection::Orthographic;
    p.view.near = 0.1f;
    p.view.far = 100.0f;
    ls.maps.push_back(p);
    return ls;
  };
  // Receivers on the ground whose pixel makes the map want rung `at`.
  auto receivers_wanting = [](double at) {
    const double content = 2.0 * 5.0 * 510.0 / 512.0, wanted = 16.0 * std::pow(2.0, at / 2.0);
    std::vector<CameraReceiver> r;
    for (int i = 0; i < 9; ++i) r.push_back({{float(i - 4), 0.0f, 1.0f}, float(content / (wanted - 2.0))});
    return r;
  };
  ShadowSettings s;
  s.resolution = kAutoResolution;
  s.texels_per_pixel = 1.0f;  // the receivers' pixels above are for 1
  for (auto [at, before, expect] : {std::tuple{10.6, -1, 11}, std::tuple{10.6, 10, 10}, std::tuple{10.8, 10, 11},
                                    std::tuple{9.3, 10, 10}, std::tuple{9.2, 10, 9}}) {
    LightSetup ls = setup();
    std::vector<std::vector<int>> rungs;
    std::vector<MapResolutionStats> st;
    choose_map_resolutions(s, receivers_wanting(at), {{before}}, 1e30, 96.0, ls, rungs, st);
    EXPECT_EQ(rungs[0][0], expect) << "wanting rung " << at << " after rung " << before;
    EXPECT_EQ(st[0].resolution, resolution_rung(expect));
    EXPECT_EQ(ls.maps[0].view.width, resolution_rung(expect));
    // The window keeps its content (a one-texel guard band at the new resolution).
    EXPECT_NEAR(ls.maps[0].view.tan_half_x * float(st[0].resolution - 2) / float(st[0].resolution),
                5.0f * 510.0f / 512.0f, 1e-4f);
  }
}

// The budget: the maps' texels within shadows.max_memory (less what the
// rest of the frame takes), the map serving the fewest receivers stepped
// down first. At 4 texels per pixel the near board's map wants 512^2
// (25 MiB), the far one's 91^2; a limit that leaves 80% of that takes the
// far map to the ladder's bottom, then the near one a rung down.
TEST(AutoResolution, TheBudgetLowersTheLeastSeenMapFirst) {
  Scene sc = two_boards({0.0f, 4.0f, 0.0f});
  sc.shadows.texels_per_pixel = 4.0f;
  Renderer r;
  FrameStats free_run, tight;
  r.render(sc, cpu(), &free_run);
  ASSERT_EQ(free_run.map_resolutions.size(), 2u);
  const double per_texel = map_bytes_per_texel(sc.shadows);
  auto texel_bytes = [&](const FrameStats& st) {
    double b = 0.0;
    for (const MapResolutionStats& m : st.map_resolutions) b += double(m.resolution) * m.resolution * per_texel;
    return b;
  };
  const double wanted = texel_bytes(free_run);
  std::vector<MemoryItem> items = estimate_frame_memory(sc, RenderOptions{});
  double others = 0.0;
  for (const MemoryItem& i : items)
    if (!i.per_map_texel) others += i.bytes;
  sc.shadows.max_memory_mib = int64_t(std::ceil((others + 0.8 * wanted) / 1048576.0));
  const double budget = map_texel_budget(sc.shadows, estimate_frame_memory(sc, RenderOptions{}));
  r.render(sc, cpu(), &tight);
  ASSERT_EQ(tight.map_resolutions.size(), 2u);
  const size_t near = free_run.map_resolutions[0].receivers > free_run.map_resolutions[1].receivers ? 0 : 1,
               far = 1 - near;
  std::printf("[ auto     ] budget %.1f MiB of %.1f wanted: near map %d^2 -> %d^2 (%s), far map %d^2 -> %d^2 (%s)\n",
              budget / 1048576.0, wanted / 1048576.0, free_run.map_resolutions[near].resolution,
              tight.map_resolutions[near].resolution, tight.map_resolutions[near].limit.c_str(),
              free_run.map_resolutions[far].resolution, tight.map_resolutions[far].resolution,
              tight.map_resolutions[far].limit.c_str());
  EXPECT_LE(texel_bytes(tight), budget);
  EXPECT_EQ(tight.map_resolutions[far].resolution, kSmallestAutoResolution);
  EXPECT_EQ(tight.map_resolutions[far].limit, "budget");
  EXPECT_EQ(tight.map_resolutions[near].limit, "budget");
  EXPECT_NEAR(rung_position(tight.map_resolutions[near].resolution),
              rung_position(free_run.map_resolutions[near].resolution) - 1.0, 0.05);
  // The default limit (half the machine's memory) leaves both at their target.
  for (const MapResolutionStats& m : free_run.map_resolutions) EXPECT_EQ(m.limit, "target");
}

// sparse.json for a spot's camera path: at 160 x 107 and 2 texels per
// pixel (CDSM_PATH_FULL=1: its own 480 x 320 at 1, 200 frames).
Scene sparse_path_scene() {
  Scene s = load_scene(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/sparse.json");
  s.shadows.resolution = kAutoResolution;
  if (!full_paths()) {
    s.camera.width = 160;
    s.camera.height = 107;
    s.shadows.texels_per_pixel = 2.0f;
  }
  return s;
}

// A spot scene's camera path (issue 48 item 4; sun_clouds' is in
// test_directional): sparse.json's four clusters under a spot 60 m up, the
// camera 10 m sideways and turned 30 degrees over 60 frames at 160 x 107,
// 2 texels per pixel. A map is rebuilt only on a frame where one moved a
// rung or the clustering changed; the popping stays within 0.01 at p99.
TEST(AutoResolution, ASpotScenesCameraPathRebuildsOnlyOnNewRungs) {
  Scene s = sparse_path_scene();
  ASSERT_EQ(s.lights.size(), 1u);
  ASSERT_EQ(s.lights[0].type, LightType::Spot);
  const int frames = full_paths() ? 200 : 60;
  expect_auto_path("sparse.json", walk_camera_path(s, frames), frames, 0.2);
}

// The same path with "clusters": "auto" as well: the count chosen per frame
// (hysteresis) stays, every rebuild is explained, and the popping is no
// more than that of the same path with the count fixed at the one chosen
// (sparse.json at two clusters re-clusters once on this path, p99 0.077:
// the clustering's own popping, not the count's).
TEST(AutoClusters, ASpotScenesCameraPathKeepsItsCount) {
  // Two walks of the path: Release only (the count's choice runs under the
  // sanitizers in SplitOnlyWhereOneMapCannotReachTheDensity).
  if (CDSM_TEST_SANITIZED) GTEST_SKIP() << "Release only (two camera paths; CI time under ASan)";
  Scene s = sparse_path_scene();
  s.shadows.max_clusters = kAutoClusters;
  FrameStats first;
  Renderer().render(s, cpu(), &first);
  ASSERT_EQ(first.clusters.size(), 1u);
  const int chosen = first.clusters[0].chosen_clusters;
  ASSERT_GE(chosen, 1);
  const int frames = full_paths() ? 200 : 60;
  const PathFigures fig = walk_camera_path(s, frames);
  s.shadows.max_clusters = chosen;
  const PathFigures fixed = walk_camera_path(s, frames);
  std::printf("[ auto path] %d clusters fixed: %u frames with rebuilds (%u maps), popping p99 %.4f\n", chosen,
              fixed.frames_with_rebuilds, fixed.maps_rebuilt, fixed.worst_p99);
  std::printf(
      "[ auto path] sparse.json, auto clusters (%d on the first frame), %d frames: %u with rebuilds (%u maps), "
      "%u with a new count, %u unexplained; popping p99 %.4f\n",
      chosen, frames, fig.frames_with_rebuilds, fig.maps_rebuilt, fig.frames_with_new_counts,
      fig.unexplained_rebuild_frames, fig.worst_p99);
  EXPECT_LE(fig.frames_with_new_counts, 3u);
  EXPECT_EQ(fig.unexplained_rebuild_frames, 0u);
  EXPECT_LE(fig.worst_p99, fixed.worst_p99 + 0.005);
  EXPECT_LE(fig.maps_rebuilt, fixed.maps_rebuilt + 2u * uint32_t(fig.frames_with_new_counts) * uint32_t(chosen));
}

TEST(AutoResolution, TheLadderTopAndTheScreenSayWhy) {
  Scene sc = two_boards({0.0f, 4.0f, 0.0f});
  sc.shadows.max_resolution = 64;
  Renderer r;
  FrameStats st;
  r.render(sc, cpu(), &st);
  ASSERT_EQ(st.map_resolutions.size(), 2u);
  int tops = 0;  // the near board's map wants 256 (above), the far one's 45
  for (const MapResolutionStats& m : st.map_resolutions) {
    EXPECT_LE(m.resolution, 64);
    if (m.limit == "ladder top") {
      EXPECT_EQ(m.resolution, 64);
      EXPECT_LT(m.texels_per_pixel_median, 1.0 / kStep);
      ++tops;
    }
  }
  EXPECT_EQ(tops, 1);
  // A fixed resolution says so, and every map has it.
  sc.shadows.resolution = 256;
  r.render(sc, cpu(), &st);
  for (const MapResolutionStats& m : st.map_resolutions) {
    EXPECT_EQ(m.resolution, 256);
    EXPECT_EQ(m.limit, "fixed");
  }
}

// Auto clusters (issue 48 item 2): the two boards under the sun with
// "clusters": "auto". One map over the whole strip cannot give the near
// board its density within 512^2, so the light is split: the count chosen
// reaches it, every count with fewer maps does not, and its maps meet the
// target within a ladder step. With a fixed resolution the size limit is
// that resolution: at 512^2 the light is split, at 1024^2 one map serves.
TEST(AutoClusters, SplitOnlyWhereOneMapCannotReachTheDensity) {
  Scene sc = two_boards({0.0f, 4.0f, 0.0f});
  sc.shadows.max_clusters = kAutoClusters;
  sc.shadows.max_resolution = 512;
  sc.shadows.texels_per_pixel = 1.0f;
  Renderer r;
  FrameStats st;
  r.render(sc, cpu(), &st);
  ASSERT_EQ(st.clusters.size(), 1u);
  const LightClusterStats& c = st.clusters[0];
  std::printf("[ auto     ] %s\n", cluster_count_text(c).c_str());
  ASSERT_EQ(c.count_trials.size(), 4u);  // 1, 2, 4, 8 (cluster_limit)
  EXPECT_EQ(c.count_trials[0].clusters, 1);
  EXPECT_FALSE(c.count_trials[0].reaches);
  EXPECT_GT(c.count_trials[0].wanted_texels, 512.0 * kStep);
  ASSERT_GE(c.chosen_clusters, 2);
  EXPECT_EQ(c.count_reason, std::string("the fewest that reach the density"));
  for (const LightClusterStats::CountTrial& t : c.count_trials) {
    if (t.maps < c.maps) {
      EXPECT_FALSE(t.reaches) << t.clusters;
    }
    if (t.clusters == c.chosen_clusters) {
      EXPECT_TRUE(t.reaches) << t.clusters;
    }
  }
  EXPECT_TRUE(c.clustered);
  EXPECT_EQ(size_t(c.maps), st.map_resolutions.size());
  for (const MapResolutionStats& m : st.map_resolutions) {
    EXPECT_EQ(m.limit, "target");
    EXPECT_GE(m.texels_per_pixel_median, 1.0 / kStep);
    EXPECT_LE(m.texels_per_pixel_median, kStep);
  }
  const double one_map = c.count_trials[0].wanted_texels;
  for (int res : {512, 1024}) {
    sc.shadows.resolution = res;
    Renderer fixed;
    fixed.render(sc, cpu(), &st);
    std::printf("[ auto     ] %d^2: %s\n", res, cluster_count_text(st.clusters[0]).c_str());
    EXPECT_EQ(st.clusters[0].chosen_clusters, one_map < res * 1.19 ? 1 : 2) << res << ": one map wants " << one_map;
  }
  EXPECT_GT(one_map, 512 * 1.19);
  EXPECT_LT(one_map, 1024 * 1.19);
}

// The count's choice and its hysteresis on the numbers: need is the rung
// position the neediest map of a count wants, reach the highest one a map
// can have plus half a step; with a fixed resolution (here 1024^2) the
// texels grow with the maps, with auto resolution they may fall.
TEST(AutoClusters, TheFewestThatReachUnlessMoreMapsSaveAndHysteresis) {
  const double inf = std::numeric_limits<double>::infinity(), M = 1048576.0;
  auto fixed = [&](std::vector<double> need) {
    std::vector<CountTrial> t;
    for (size_t k = 0; k < need.size(); ++k) t.push_back({need[k], double(1u << k) * M, double(1u << k)});
    return t;
  };
  // Auto resolution: 1, 2, 4, 8 maps wanting 4, 1.5, 0.9, 0.8 Mtexels.
  auto sizes = [&](std::vector<double> need) {
    const double texels[] = {4.0 * M, 1.5 * M, 0.9 * M, 0.8 * M};
    std::vector<CountTrial> t;
    for (size_t k = 0; k < need.size(); ++k) t.push_back({need[k], texels[k], double(1u << k)});
    return t;
  };
  struct Case {
    const char* what;
    std::vector<CountTrial> trials;
    int kept;
    size_t pick;
  } cases[] = {
      {"2 clusters reach", fixed({20, 12, 11, 10.5}), -1, 1},
      {"one map reaches", fixed({14, 12, 11, 10.5}), -1, 0},
      {"none reaches: the fewest within a step of the best", fixed({20, 16, 15.2, 15}), -1, 1},
      {"none reaches: 17 is more than a step from 15", fixed({20, 17, 15.2, 15}), -1, 2},
      {"4 kept, but 2 reach with margin", fixed({20, 13, 12, 11}), 2, 1},
      {"4 kept: 2 reach without margin", fixed({20, 14, 12, 11}), 2, 2},
      {"1 kept: within 3/4 of a step", fixed({15, 13, 12, 11}), 0, 0},
      {"1 not kept: beyond 3/4 of a step", fixed({15.5, 13, 12, 11}), 0, 1},
      {"auto resolution: 2 maps for 1.5 M texels instead of 4", sizes({12, 12, 12, 12}), -1, 1},
      {"... 4 maps for 0.9 M would cost more (3.6 M texels x maps)", sizes({12, 12, 12, 12}), -1, 1},
      {"... 1 kept: 2 maps save less than twice what is asked", sizes({12, 12, 12, 12}), 0, 0},
      {"... 4 kept: within twice the cost of 2", sizes({12, 12, 12, 12}), 2, 2},
      {"... 8 kept: more than twice the cost of 2", sizes({12, 12, 12, 12}), 3, 1},
      {"... cheaper counts that do not reach are not taken", sizes({12, 15, 15, 15}), -1, 0},
      {"... too little saved to be worth a map", {{12, 0.3 * M, 1}, {12, 0.1 * M, 2}}, -1, 0},
      {"nothing seen: one map", fixed({-inf, -inf, -inf, -inf}), -1, 0},
      {"nothing seen: whatever was kept", fixed({-inf, -inf, -inf, -inf}), 3, 0},
  };
  for (const Case& c : cases) {
    const CountChoice got = pick_cluster_count(c.trials, 14.5, c.kept);
    EXPECT_EQ(got.pick, c.pick) << c.what << ": " << got.reason;
  }
}

TEST(AutoResolution, SceneFilesSayAuto) {
  const std::string text = R"({"camera": {"position": [0, 2, 4], "target": [0, 0, 0]},
    "shadows": {"resolution": "auto", "texels_per_pixel": 1.5, "max_resolution": 1024},
    "objects": [{"mesh": {"type": "box"}}], "lights": [{"type": "directional", "direction": [0, -1, 0]}]})";
  const Scene sc = parse_scene(text, "auto.json", ".");
  EXPECT_TRUE(sc.shadows.auto_resolution());
  EXPECT_FALSE(sc.shadows.auto_clusters());
  EXPECT_EQ(sc.shadows.max_resolution, 1024);
  EXPECT_FLOAT_EQ(sc.shadows.texels_per_pixel, 1.5f);
  const std::string written = scene_to_json(sc);
  EXPECT_NE(written.find("\"resolution\": \"auto\""), std::string::npos) << written;
  EXPECT_TRUE(parse_scene(written, "again.json", ".").shadows.auto_resolution());
  // Anything else spelled as a string names itself.
  std::string bad = text;
  bad.replace(bad.find("\"auto\""), 6, "\"automatic\"");
  try {
    parse_scene(bad, "bad.json", ".");
    ADD_FAILURE() << "\"automatic\" was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/shadows/resolution"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("\"auto\""), std::string::npos) << e.what();
  }
}

TEST(AutoClusters, SceneFilesSayAuto) {
  const std::string text = R"({"camera": {"position": [0, 2, 4], "target": [0, 0, 0]},
    "shadows": {"clusters": "auto", "max_clusters": 4},
    "objects": [{"mesh": {"type": "box"}}], "lights": [{"type": "directional", "direction": [0, -1, 0]}]})";
  const Scene sc = parse_scene(text, "auto.json", ".");
  EXPECT_TRUE(sc.shadows.auto_clusters());
  EXPECT_TRUE(sc.shadows.clustering());
  EXPECT_EQ(sc.shadows.cluster_limit, 4);
  const std::string written = scene_to_json(sc);
  EXPECT_NE(written.find("\"clusters\": \"auto\""), std::string::npos) << written;
  const Scene again = parse_scene(written, "again.json", ".");
  EXPECT_TRUE(again.shadows.auto_clusters());
  EXPECT_EQ(again.shadows.cluster_limit, 4);
  // A literal 0 is not "auto"; a limit beyond the maps a light may have is refused.
  for (auto [from, to, where] : {std::tuple{"\"auto\", \"max", "0, \"max", "/shadows/clusters"},
                                 std::tuple{"\"max_clusters\": 4", "\"max_clusters\": 9", "/shadows/max_clusters"}}) {
    std::string bad = text;
    bad.replace(bad.find(from), std::string(from).size(), to);
    try {
      parse_scene(bad, "bad.json", ".");
      ADD_FAILURE() << bad << " was read";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(where), std::string::npos) << e.what();
    }
  }
}

}  // namespace
