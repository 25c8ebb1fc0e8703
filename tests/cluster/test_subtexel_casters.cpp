// Casters smaller than a texel (issue 25, hard case c): a 10 km scene with
// 1 m casters and one map shows no shadow at all. The frame says so, once
// per light: the light's name, the map's resolution, the texel's world size
// at the casters, and what to change (clusters, resolution). The same scene
// with one caster as large as a texel, the same casters in clusters, and the
// shipped scenes say nothing.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <regex>
#include <string>

#include "cdsm/procedural.h"
#include "cdsm/scene_io.h"
#include "frame.h"
#include "common/system_frame.h"

namespace cdsm {
namespace {

// A 10 km receive-only ground, four 1 m boxes 2 km apart, a spot light 3 km
// above (59 degrees: one map of 512^2, a texel ~20 m wide at the ground).
Scene ten_km(int clusters) {
  Scene s;
  s.source = "ten_km";
  Object ground;
  ground.name = "ground";
  ground.mesh = std::make_shared<const TriangleMesh>(make_ground(10000.0f, 10000.0f, 1.0f));
  ground.casts_shadows = false;
  s.objects.push_back(ground);
  const auto box = std::make_shared<const TriangleMesh>(make_box({1, 1, 1}));
  const Vec3 at[4] = {{-2000, 0.5f, -2000}, {2000, 0.5f, -2000}, {-2000, 0.5f, 2000}, {2000, 0.5f, 2000}};
  for (int i = 0; i < 4; ++i) {
    Object o;
    o.name = "box" + std::to_string(i);
    o.mesh = box;
    o.transform = make_transform(at[i], {0, 0, 0}, {1, 1, 1});
    s.objects.push_back(o);
  }
  s.lights.push_back(cdsm_test::spot_light({0, 3000, 0}, {0, -1, 0}, 59.0f, 55.0f));
  s.lights.back().name = "sun";
  s.camera = cdsm_test::camera_at({0, 2500, 7000}, {0, 0, 0}, 64, 48);
  s.camera.near = 1.0f;
  s.camera.far = 20000.0f;
  s.shadows.resolution = 512;
  s.shadows.max_clusters = clusters;
  return s;
}

// A frame built by a ShadowSystem (common/system_frame.h).
using Built = cdsm_test::SystemFrame;
void build(const Scene& scene, Built& b) { b.build(scene); }

size_t subtexel_warnings(const ShadowFrame& f) {
  size_t n = 0;
  for (const std::string& w : f.warnings) n += w.find("smaller than a texel") != std::string::npos;
  return n;
}

TEST(SubtexelCasters, TenKmSceneWithMetreCastersInOneMapWarns) {
  const Scene s = ten_km(1);
  Built b;
  build(s, b);
  ASSERT_EQ(b.frame.maps.size(), 1u);
  ASSERT_EQ(b.frame.warnings.size(), 1u);
  const std::string& w = b.frame.warnings[0];
  std::printf("[ warning  ] %s\n", w.c_str());
  EXPECT_NE(w.find("light 'sun'"), std::string::npos) << w;
  EXPECT_NE(w.find("512x512"), std::string::npos) << w;
  EXPECT_NE(w.find("/shadows/clusters"), std::string::npos) << w;
  EXPECT_NE(w.find("/shadows/resolution"), std::string::npos) << w;
  // The texel's world size at the casters (their top, 2999 m from the light).
  std::smatch m;
  ASSERT_TRUE(std::regex_search(w, m, std::regex("a texel is ([0-9.e+]+) world units wide"))) << w;
  const DsmMap& map = b.frame.headers[0];
  const double texel = texel_footprint(map, 2999.0f);
  EXPECT_GT(texel, 15.0);
  EXPECT_NEAR(std::stod(m[1]), texel, 0.01 * texel) << w;
  // Once per frame, and again for a frame that rebuilds nothing.
  b.system->set_camera(s.camera);
  b.system->update();
  const ShadowFrame& again = b.snapshot().frame();
  EXPECT_EQ(again.reused, 1u);
  EXPECT_EQ(again.warnings, b.frame.warnings);
}

TEST(SubtexelCasters, OneCasterAsLargeAsATexelSaysNothing) {
  Scene s = ten_km(1);
  s.objects[1].transform = make_transform({-2000, 20, -2000}, {0, 0, 0}, {40, 40, 40});
  Built b;
  build(s, b);
  EXPECT_EQ(subtexel_warnings(b.frame), 0u) << b.frame.warnings[0];
}

TEST(SubtexelCasters, ClustersFocusedOnTheCastersSayNothing) {
  const Scene s = ten_km(4);
  Built b;
  build(s, b);
  ASSERT_TRUE(b.frame.clusters[0].clustered) << b.frame.clusters[0].fallback_reason;
  EXPECT_GT(b.frame.maps.size(), 1u);
  EXPECT_EQ(subtexel_warnings(b.frame), 0u) << b.frame.warnings[0];
}

TEST(SubtexelCasters, ShippedScenesSayNothing) {
  const std::filesystem::path dir = std::filesystem::path(CDSM_CONTENT_DIR_TEST) / "scenes";
  int scenes = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().extension() != ".json") continue;
    const Scene s = load_scene(e.path().string());
    Built b;
    build(s, b);
    EXPECT_EQ(subtexel_warnings(b.frame), 0u) << e.path() << ": " << b.frame.warnings[0];
    std::printf("[ scene    ] %s: %zu maps, no caster-size warning\n", e.path().filename().c_str(),
                b.frame.maps.size());
    ++scenes;
  }
  EXPECT_GE(scenes, 5);
}

}  // namespace
}  // namespace cdsm
