// Rebuild only on change (issue 5): a DSM is rebuilt only when its light,
// its objects, its cluster (members and frustum) or the settings changed.
#include <cstdio>
#include <gtest/gtest.h>

#include <set>

#include "cdsm/procedural.h"
#include "cdsm/renderer.h"
#include "cdsm/scene_io.h"
#include "hd/lights.h"
#include "reference/reference.h"
#include "frame.h"
#include "common/system_frame.h"

namespace cdsm {
namespace {

RenderOptions cpu_options() {
  RenderOptions o;
  o.fragments = FragmentSource::Cpu;
  return o;
}

Scene sparse(int m) {
  Scene s = load_scene(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/sparse.json");
  s.camera.width = 64;
  s.camera.height = 48;
  s.shadows.max_clusters = m;
  s.shadows.resolution = 128;
  return s;
}

std::set<std::vector<int>> member_sets(const FrameStats& st, size_t light) {
  return {st.clusters[light].members.begin(), st.clusters[light].members.end()};
}

TEST(Rebuild, UnchangedFrameReusesEveryMap) {
  Scene s = sparse(4);
  Renderer r;
  FrameStats a, b;
  r.render(s, cpu_options(), &a);
  r.render(s, cpu_options(), &b);
  EXPECT_EQ(a.maps_rebuilt, a.clusters[0].maps);
  EXPECT_EQ(b.maps_rebuilt, 0u);
  EXPECT_EQ(b.maps_reused, a.maps_rebuilt);
}

TEST(Rebuild, SmallCameraMoveRebuildsNothing) {
  Scene s = sparse(4);
  Renderer r;
  FrameStats a, b;
  r.render(s, cpu_options(), &a);
  s.camera.position = s.camera.position + Vec3{0.05f, 0.02f, -0.04f};
  s.camera.target = s.camera.target + Vec3{0.03f, 0.0f, 0.02f};
  r.render(s, cpu_options(), &b);
  EXPECT_TRUE(b.clusters[0].clustered);
  EXPECT_EQ(member_sets(a, 0), member_sets(b, 0));
  EXPECT_EQ(b.maps_rebuilt, 0u);
}

TEST(Rebuild, LargeCameraMoveReclustersAndRebuildsOnlyChangedClusters) {
  Scene s = sparse(4);
  Renderer r;
  FrameStats a, b;
  r.render(s, cpu_options(), &a);
  // Fly to another group (at x = 48, z = 0).
  s.camera.position = Vec3{50.6f, 2.0f, 3.0f};
  s.camera.target = Vec3{48.0f, 0.6f, 0.0f};
  r.render(s, cpu_options(), &b);
  ASSERT_TRUE(b.clusters[0].clustered);
  EXPECT_TRUE(b.clusters[0].reclustered);
  std::set<std::vector<int>> before = member_sets(a, 0), after = member_sets(b, 0);
  EXPECT_NE(before, after) << "a large move must re-cluster";
  // Only clusters whose member set or focused frustum changed are rebuilt;
  // a new member set always counts as changed.
  uint32_t changed = 0;
  for (size_t k = 0; k < b.clusters[0].members.size(); ++k) {
    if (!before.count(b.clusters[0].members[k])) {
      EXPECT_TRUE(b.clusters[0].changed[k]);
    }
    changed += b.clusters[0].changed[k];
  }
  std::printf("[ rebuild ] large move: %u maps, %u changed clusters, %u rebuilt, %u reused\n", b.clusters[0].maps,
              changed, b.maps_rebuilt, b.maps_reused);
  EXPECT_EQ(b.maps_rebuilt, changed);
  // Every map is either rebuilt or reused, and the unchanged ones are reused.
  EXPECT_EQ(b.maps_rebuilt + b.maps_reused, b.clusters[0].maps);
  EXPECT_EQ(b.maps_reused, b.clusters[0].maps - changed);
}

TEST(Rebuild, MovingOneObjectRebuildsOnlyTheMapsContainingIt) {
  Scene s = sparse(4);
  Renderer r;
  FrameStats a, b;
  r.render(s, cpu_options(), &a);
  // Object 1 (a teapot) moves a little.
  s.objects[1].transform.m[0][3] += 0.01f;
  r.render(s, cpu_options(), &b);
  ASSERT_EQ(member_sets(a, 0), member_sets(b, 0));
  uint32_t containing = 0;
  for (const auto& m : b.clusters[0].members)
    for (int o : m) containing += o == 1 ? 1u : 0u;
  EXPECT_EQ(containing, 1u);
  EXPECT_EQ(b.maps_rebuilt, 1u);
  EXPECT_EQ(b.maps_reused, b.clusters[0].maps - 1u);
}

TEST(Rebuild, MovingALightRebuildsItsMapsOnly) {
  Scene s = sparse(1);
  Light omni;
  omni.type = LightType::Point;
  omni.position = {40.0f, 3.0f, 40.0f};
  omni.intensity = 0.3f;
  s.lights.push_back(omni);
  Renderer r;
  FrameStats a, b;
  r.render(s, cpu_options(), &a);
  EXPECT_EQ(a.maps_rebuilt, 7u);  // the spot's map and six cube faces
  s.lights[1].position = s.lights[1].position + Vec3{0.2f, 0.0f, 0.0f};
  r.render(s, cpu_options(), &b);
  EXPECT_EQ(b.maps_rebuilt, 6u);
  EXPECT_EQ(b.maps_reused, 1u);
}

TEST(Rebuild, ChangingEpsilonRebuildsEverything) {
  Scene s = sparse(1);
  Renderer r;
  FrameStats a, b;
  r.render(s, cpu_options(), &a);
  s.shadows.epsilon = 0.05f;
  r.render(s, cpu_options(), &b);
  EXPECT_EQ(b.maps_rebuilt, a.maps_rebuilt);
  EXPECT_EQ(b.maps_reused, 0u);
}

// An omni light inside a ring of casters shadows all sides, and the six
// faces meet without a seam: along a circle on the ground crossing every
// face border, the DSM transmittance follows the reference within eps plus
// the filtering error, and never jumps between neighbouring samples more
// than the reference does.
TEST(OmniLight, RingOfCastersShadowsAllSidesWithoutSeams) {
  Scene s = cdsm_test::empty_scene("omni ring (test)");
  s.camera = cdsm_test::camera_at({0, 6, 0.01f}, {0, 0, 0}, 32, 32);
  s.shadows.resolution = 512;
  s.shadows.epsilon = 0.005f;
  Object ground;
  ground.mesh = std::make_shared<TriangleMesh>(make_ground(12, 12, 0.05f));
  ground.casts_shadows = false;
  s.objects.push_back(ground);
  auto box = std::make_shared<TriangleMesh>(make_box({0.4f, 1.0f, 0.4f}));
  const int kRing = 12;
  for (int i = 0; i < kRing; ++i) {
    float a = 2.0f * 3.14159265f * (float(i) + 0.5f) / kRing;
    Object o;
    o.mesh = box;
    o.transform = make_transform({2.0f * std::cos(a), 0.5f, 2.0f * std::sin(a)}, {0, 0, 0}, {1, 1, 1});
    o.surface.opacity = i % 2 ? 1.0f : 0.5f;  // opaque and translucent alternate
    s.objects.push_back(o);
  }
  Light omni;
  omni.type = LightType::Point;
  omni.position = {0.0f, 0.6f, 0.0f};
  s.lights.push_back(omni);

  const cdsm_test::SystemFrame f(s);
  SceneView sv = f.scene_view();
  const ShadowFrame& frame = f.frame;
  ASSERT_EQ(frame.setup.lights[0].map_count, 6u);
  ShadowView shv = frame.view(s.shadows);
  ReferenceRenderer ref(sv, frame.setup.lights);
  int shadowed = 0, n = 0;
  double max_err = 0.0;
  const int kSamples = 4000;
  for (int i = 0; i <= kSamples; ++i) {
    float a = 2.0f * 3.14159265f * float(i) / kSamples;
    Vec3 p{3.5f * std::cos(a), 0.0f, 3.5f * std::sin(a)};
    float t_dsm = 1.0f - grey_of(shadow_alpha(shv, shv.lights[0], Receiver{p, {0, 1, 0}, kNoObject}));
    float t_ref = grey_of(ref.transmittance(0, p));
    if (t_ref < 0.9f) ++shadowed;
    ++n;
    // Away from shadow edges (where bilinear filtering blurs by design) the
    // maps must match the reference.
    bool edge = false;
    for (float da : {-0.01f, 0.01f}) {
      Vec3 q{3.5f * std::cos(a + da), 0.0f, 3.5f * std::sin(a + da)};
      edge = edge || std::fabs(grey_of(ref.transmittance(0, q)) - t_ref) > 1e-3f;
    }
    if (!edge) max_err = std::max(max_err, double(std::fabs(t_dsm - t_ref)));
  }
  EXPECT_GT(shadowed, n / 4) << "every caster of the ring shadows the ground behind it";
  EXPECT_LE(max_err, s.shadows.epsilon + 2e-3);
  // Across each face border (at 45, 135, 225, 315 degrees, in the middle of
  // a caster's shadow) the maps of the two faces agree: no seam.
  for (int k = 0; k < 4; ++k) {
    float a = 3.14159265f * (0.25f + 0.5f * float(k));
    for (float r : {2.6f, 3.0f, 3.5f, 4.5f}) {
      Vec3 pl{r * std::cos(a - 2e-4f), 0.0f, r * std::sin(a - 2e-4f)};
      Vec3 pr{r * std::cos(a + 2e-4f), 0.0f, r * std::sin(a + 2e-4f)};
      ASSERT_NE(cube_face_of(pl - omni.position), cube_face_of(pr - omni.position));
      float dl = 1.0f - grey_of(shadow_alpha(shv, shv.lights[0], Receiver{pl, {0, 1, 0}, kNoObject}));
      float dr = 1.0f - grey_of(shadow_alpha(shv, shv.lights[0], Receiver{pr, {0, 1, 0}, kNoObject}));
      float rl = grey_of(ref.transmittance(0, pl)), rr = grey_of(ref.transmittance(0, pr));
      EXPECT_LT(rl, 0.9f) << "the border at " << k << " lies in a shadow";
      EXPECT_LE(std::fabs(dl - dr), std::fabs(rl - rr) + 2.0f * s.shadows.epsilon + 2e-3f)
          << "seam at border " << k << ", radius " << r;
    }
  }
}

}  // namespace
}  // namespace cdsm
