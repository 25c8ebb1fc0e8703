// Coloured shadows against analytic answers (issue "Coloured shadows"):
// per-channel Beer-Lambert through a sphere and a slab, stacked tinted
// filters multiplying per channel, early termination only when every
// channel is done, the camera pass through pure filters, RGB maps in all
// three layouts, and the shipped stained-glass scene against the reference.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "cdsm/renderer.h"
#include "cdsm/scene_io.h"
#include "cdsm/shadow_system.h"
#include "reference/reference.h"
#include "frame_snapshot.h"
#include "scene_sync.h"
#include "unit/unit_util.h"

using namespace cdsm;
using namespace cdsm_test;

namespace {

const Vec3 kSigma{0.5f, 2.0f, 8.0f};

double worst_channel(Vec3 a, Vec3 b) {
  return std::max({std::fabs(double(a.x) - b.x), std::fabs(double(a.y) - b.y), std::fabs(double(a.z) - b.z)});
}

// A medium of sigma kSigma (white, invisible boundary) under a spot light
// looking down; points along texel-centre rays at random depths through it
// and beyond: T_k = exp(-sigma_k chord_k) with the chord of the tessellated
// mesh up to the point, in the DSM (no filtering: one texel) and the
// reference.
void check_beer_lambert(TriangleMesh mesh, const char* what) {
  const float eps = 0.001f;
  Scene s = empty_scene(what);
  Object o = surface_object(what, std::move(mesh), translation({0.01f, 1.0f, -0.02f}), 0.0f);
  o.interior = InteriorKind::Constant;
  o.sigma = kSigma;
  s.objects.push_back(o);
  s.lights.push_back(spot_light({0.0f, 4.0f, 0.0f}, {0, -1, 0}, 12.0f, 10.0f));
  s.shadows.epsilon = eps;
  s.shadows.resolution = 128;
  s.shadows.filtering = false;
  ShadowFixture fx(s);
  ASSERT_EQ(fx.frame.headers.size(), 1u);
  EXPECT_EQ(fx.frame.headers[0].rgb, 1u) << "a coloured medium must make an RGB map";
  const ShadowView sv = fx.view();
  const SceneView scene = fx.scene_view();
  ReferenceRenderer ref(scene, fx.frame.setup.lights, ReferenceOptions{0.25f});
  const LightData& L = fx.frame.setup.lights[0];
  const PinholeView& mv = fx.map_view(L.first_map);
  std::mt19937 rng(7u);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  double dsm_err = 0.0, ref_err = 0.0, deepest = 1.0;
  int probes = 0, through = 0;
  for (int i = 0; i < 40000 && probes < 4000; ++i) {
    const int tx = std::min(mv.width - 1, int(u(rng) * float(mv.width)));
    const int ty = std::min(mv.height - 1, int(u(rng) * float(mv.height)));
    const Vec3 dir = pixel_ray(mv, tx, ty);
    const float depth = 2.0f + 3.0f * u(rng);  // from above the medium to below it
    const Vec3 p = L.position + dir * depth;
    const ViewProjection pr = project(mv, p);
    if (int(std::floor(pr.u)) != tx || int(std::floor(pr.v)) != ty || cone_factor(L, p) <= 0.0f) continue;
    const double len = chord(scene, 0, L.position, dir, pr.depth);
    const Vec3 expect{float(std::exp(-kSigma.x * len)), float(std::exp(-kSigma.y * len)),
                      float(std::exp(-kSigma.z * len))};
    dsm_err = std::max(dsm_err, worst_channel(one_minus(shadow_alpha(sv, L, p)), expect));
    ref_err = std::max(ref_err, worst_channel(ref.transmittance(0, p), expect));
    deepest = std::min(deepest, double(expect.z));
    through += len > 0.0;
    ++probes;
  }
  std::printf("%s, sigma (0.5, 2, 8): %d points (%d through it), max |dT_k| DSM %.2e, reference %.2e\n", what, probes,
              through, dsm_err, ref_err);
  EXPECT_GE(probes, 4000);
  EXPECT_GT(through, 1000);
  EXPECT_LT(deepest, 1e-3) << "the blue channel must be nearly opaque through the medium";
  // The wedge's eps plus the constant medium's chord sampling (eps-sized,
  // hd/segments.h) plus 1e-3 of tessellation-free slack; a channel
  // computed with another channel's sigma would be off by up to 0.6.
  EXPECT_LE(dsm_err, 2 * eps + 1e-3);
  EXPECT_LE(ref_err, 1e-4);
}

TEST(BeerLambertRgb, Sphere) { check_beer_lambert(make_sphere(0.5f, 32, 16), "sphere"); }
TEST(BeerLambertRgb, Slab) { check_beer_lambert(make_box({2.0f, 1.0f, 2.0f}), "slab"); }

// Three stacked tinted quads: below all of them T_k is the product of the
// (1 - a_i) f_ik; between them the partial products. DSM (every layout) and
// reference within 1e-6.
TEST(TintedFilters, ThreeStackedQuadsMultiplyPerChannel) {
  const float a[3] = {0.2f, 0.0f, 0.5f};
  const Vec3 f[3] = {{1.0f, 0.5f, 0.2f}, {0.3f, 0.9f, 0.6f}, {0.7f, 0.7f, 1.0f}};
  for (DsmLayout layout : {DsmLayout::Packed, DsmLayout::Fixed, DsmLayout::Chunked}) {
    Scene s = empty_scene("filters");
    for (int i = 0; i < 3; ++i) {
      Object q = surface_object("quad", make_quad(2.0f, 2.0f), translation({0.0f, 1.4f - 0.2f * float(i), 0.0f}), a[i]);
      q.surface.transmission_color = f[i];
      s.objects.push_back(q);
    }
    s.lights.push_back(spot_light({0.0f, 4.0f, 0.0f}, {0, -1, 0}, 12.0f, 10.0f));
    s.shadows.resolution = 64;
    s.shadows.layout = layout;
    ShadowFixture fx(s);
    const ShadowView sv = fx.view();
    ReferenceRenderer ref(fx.scene_view(), fx.frame.setup.lights, ReferenceOptions{});
    const LightData& L = fx.frame.setup.lights[0];
    EXPECT_EQ(fx.frame.headers[0].rgb, 1u);
    double worst = 0.0;
    for (int level = 0; level < 4; ++level) {  // above all, below one, two, three quads
      Vec3 expect{1, 1, 1};
      for (int i = 0; i < level; ++i) expect = expect * (f[i] * (1.0f - a[i]));
      const float y = 1.5f - 0.2f * float(level);
      for (float x = -0.5f; x <= 0.5f; x += 0.05f)
        for (float z = -0.5f; z <= 0.5f; z += 0.07f) {
          const Vec3 p{x, y, z};
          worst = std::max(worst, worst_channel(one_minus(shadow_alpha(sv, L, p)), expect));
          worst = std::max(worst, worst_channel(ref.transmittance(0, p), expect));
        }
    }
    EXPECT_LE(worst, 1e-6) << "layout " << int(layout);
  }
}

// A ray saturated in two channels goes on in the third: a filter passing
// only blue, then one halving blue: T = (0, 0, 0.5) below both (the light
// pass stops only when every channel is saturated).
TEST(TintedFilters, TerminationWaitsForEveryChannel) {
  Scene s = empty_scene("blue");
  Object q1 = surface_object("blue filter", make_quad(2.0f, 2.0f), translation({0.0f, 1.4f, 0.0f}), 0.0f);
  q1.surface.transmission_color = {0.0f, 0.0f, 1.0f};
  Object q2 = surface_object("half blue", make_quad(2.0f, 2.0f), translation({0.0f, 1.0f, 0.0f}), 0.0f);
  q2.surface.transmission_color = {1.0f, 1.0f, 0.5f};
  s.objects = {q1, q2};
  s.lights.push_back(spot_light({0.0f, 4.0f, 0.0f}, {0, -1, 0}, 12.0f, 10.0f));
  s.shadows.resolution = 32;
  ShadowFixture fx(s);
  const ShadowView sv = fx.view();
  const LightData& L = fx.frame.setup.lights[0];
  const Vec3 between = one_minus(shadow_alpha(sv, L, Vec3{0.1f, 1.2f, 0.1f}));
  const Vec3 below = one_minus(shadow_alpha(sv, L, Vec3{0.1f, 0.5f, 0.1f}));
  EXPECT_NEAR(between.x, 0.0f, 1e-6f);
  EXPECT_NEAR(between.z, 1.0f, 1e-6f);
  EXPECT_NEAR(below.x, 0.0f, 1e-6f);
  EXPECT_NEAR(below.y, 0.0f, 1e-6f);
  EXPECT_NEAR(below.z, 0.5f, 1e-6f) << "the ray stopped when red and green saturated";
}

// The camera pass through pure filters (opacity 0, tinted: not skipped) and
// through a white opacity-0 proxy (skipped): the background times the
// filters' product, per channel; the camera ray goes on behind a filter
// that blocks two channels.
TEST(TintedFilters, CameraSeesThroughFiltersPerChannel) {
  Scene s = empty_scene("camera");
  s.camera.position = {0, 3, 0};
  s.camera.target = {0, 0, 0};
  s.camera.up = {0, 0, 1};
  s.camera.width = 16;
  s.camera.height = 16;
  s.background = {0.5f, 0.6f, 0.7f};
  s.shadows.ambient_light = {0, 0, 0};
  Object proxy = surface_object("proxy", make_quad(4.0f, 4.0f), translation({0, 2.0f, 0}), 0.0f);
  Object red = surface_object("red", make_quad(4.0f, 4.0f), translation({0, 1.5f, 0}), 0.0f);
  red.surface.transmission_color = {1.0f, 0.0f, 0.0f};
  Object dim = surface_object("dim", make_quad(4.0f, 4.0f), translation({0, 1.0f, 0}), 0.0f);
  dim.surface.transmission_color = {0.25f, 0.5f, 0.5f};
  s.objects = {proxy, red, dim};
  SystemOptions opt;
  opt.fragments = FragmentSource::Cpu;
  ShadowSystem sys(opt);
  sync_scene(sys, s);
  const Image img = sys.render();
  const float* px = img.rgb.data() + (size_t(8) * 16 + 8) * 3;
  EXPECT_NEAR(px[0], 0.5f * 0.25f, 1e-6f);
  EXPECT_EQ(px[1], 0.0f);
  EXPECT_EQ(px[2], 0.0f);
  // Only the white proxy: invisible, the background exactly.
  s.objects = {proxy};
  sync_scene(sys, s);
  const Image clear = sys.render();
  EXPECT_EQ(clear.rgb[(size_t(8) * 16 + 8) * 3 + 2], 0.7f);
}

// Grey casters keep scalar maps even beside coloured ones in another
// light; rgb_maps = false keeps every map scalar (the cost comparison);
// memory per kind adds up.
TEST(RgbMaps, OnlyWhereAMapHoldsColour) {
  Scene s = empty_scene("kinds");
  Object grey = surface_object("grey", make_quad(1.0f, 1.0f), translation({-3.0f, 1.0f, 0.0f}), 0.5f);
  Object tint = surface_object("tint", make_quad(1.0f, 1.0f), translation({3.0f, 1.0f, 0.0f}), 0.0f);
  tint.surface.transmission_color = {0.9f, 0.5f, 0.1f};
  s.objects = {grey, tint};
  s.lights.push_back(spot_light({-3.0f, 4.0f, 0.0f}, {0, -1, 0}, 20.0f, 15.0f));
  s.lights.push_back(spot_light({3.0f, 4.0f, 0.0f}, {0, -1, 0}, 20.0f, 15.0f));
  s.shadows.resolution = 32;
  s.shadows.max_clusters = 2;
  s.camera.position = {0, 6, 6};
  SystemOptions opt;
  opt.fragments = FragmentSource::Cpu;
  ShadowSystem sys(opt);
  sync_scene(sys, s);
  FrameStats st;
  sys.update(&st);
  const ShadowFrame& f = FrameSnapshot(sys).frame();
  uint32_t rgb = 0;
  for (size_t k = 0; k < f.headers.size(); ++k) {
    bool coloured = false;
    for (uint32_t o : f.setup.maps[k].members) coloured = coloured || o == 1u;
    EXPECT_EQ(f.headers[k].rgb, coloured ? 1u : 0u) << "map " << k;
    rgb += f.headers[k].rgb;
    EXPECT_EQ(f.map_stats[k].node_bytes_used, f.map_stats[k].nodes * (coloured ? 16u : 8u));
  }
  EXPECT_GE(rgb, 1u);
  EXPECT_EQ(st.memory.rgb_maps, rgb);
  EXPECT_EQ(st.memory.grey_bytes + st.memory.rgb_bytes, st.memory.index_bytes + st.memory.node_bytes +
                                                            st.memory.slack_bytes + st.memory.tag_bytes +
                                                            st.memory.pyramid_bytes);
  s.shadows.rgb_maps = false;
  sync_scene(sys, s);
  sys.update(&st);
  EXPECT_EQ(st.memory.rgb_maps, 0u);
  for (const DsmMap& m : FrameSnapshot(sys).frame().headers) EXPECT_EQ(m.rgb, 0u);
}

Scene stained_glass(int width, int height, DsmLayout layout = DsmLayout::Packed) {
  Scene s = load_scene(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/stained_glass.json");
  s.camera.width = width;
  s.camera.height = height;
  s.shadows.resolution = 512;
  s.shadows.layout = layout;
  return s;
}

// The three layouts store the same RGB functions (texels within L), so the
// stained-glass scene renders the same image in each.
TEST(RgbMaps, LayoutsAgreeOnStainedGlass) {
  std::vector<float> images[3];
  for (int l = 0; l < 3; ++l) {
    SystemOptions opt;
    opt.fragments = FragmentSource::Cpu;
    ShadowSystem sys(opt);
    Scene s = stained_glass(96, 64, DsmLayout(l));
    s.shadows.resolution = 128;
    sync_scene(sys, s);
    FrameStats st;
    images[l] = sys.render(&st).rgb;
    EXPECT_EQ(st.memory.rgb_maps, st.memory.maps);
    EXPECT_EQ(st.memory.overflow_texels, 0u);
  }
  EXPECT_EQ(images[0], images[1]) << "fixed differs from packed";
  EXPECT_EQ(images[0], images[2]) << "chunked differs from packed";
}

// End to end: the stained-glass scene at 512^2 against the reference, at
// the lookups the camera pass made: per-channel mean |dT| <= 0.01.
TEST(StainedGlass, MatchesReferencePerChannel) {
  Scene s = stained_glass(240, 160);
  Renderer r;
  RenderOptions opt;
  opt.fragments = FragmentSource::Cpu;
  opt.error_samples = 20000;
  const TransmittanceError e = r.transmittance_error(s, opt);
  std::printf("stained glass 512^2: %llu lookups, mean |dT| per channel %.5f %.5f %.5f, p99 %.4f (max over channels)\n",
              (unsigned long long)e.points, e.channel_mean[0], e.channel_mean[1], e.channel_mean[2], e.p99);
  EXPECT_GT(e.points, 5000u);
  for (int k = 0; k < 3; ++k) EXPECT_LE(e.channel_mean[k], 0.01) << "channel " << k;
  EXPECT_GT(std::max({e.channel_mean[0], e.channel_mean[1], e.channel_mean[2]}), 0.0)
      << "no error at all: not compared";
}

// The default scene with its tinted pane and box: per-channel mean |dT|
// <= 0.01 at the camera pass's lookups (160x120, 512^2), and its shadows
// are tinted: under the amber pane T = (0.25, 0.09, 0.0036).
TEST(DefaultScene, TintedShadowsMatchReferencePerChannel) {
  Scene s = load_scene(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/default.json");
  s.camera.width = 160;
  s.camera.height = 120;
  Renderer r;
  RenderOptions opt;
  opt.fragments = FragmentSource::Cpu;
  const TransmittanceError e = r.transmittance_error(s, opt);
  std::printf("default scene (tinted): mean |dT| per channel %.5f %.5f %.5f, p99 %.4f, rmse %.4f (max over channels)\n",
              e.channel_mean[0], e.channel_mean[1], e.channel_mean[2], e.p99, e.rmse);
  for (int k = 0; k < 3; ++k) EXPECT_LE(e.channel_mean[k], 0.01) << "channel " << k;
  // The amber pane's shadow: exact per channel through the reference, and
  // the DSM's lookup there.
  SystemOptions so;
  so.fragments = FragmentSource::Cpu;
  ShadowSystem sys(so);
  sync_scene(sys, s);
  sys.update();
  const ShadowView sv = FrameSnapshot(sys).shadow_view();
  const LightData& L = sv.lights[0];
  size_t pane = 0;
  for (size_t i = 0; i < s.objects.size(); ++i)
    if (s.objects[i].name == "amber pane") pane = i;
  const Vec3 c = s.objects[pane].transform.point({0, 0, 0});
  const Vec3 dir = normalize(c - L.position);
  const float t = -L.position.y / dir.y;  // where the light ray through the pane's centre meets the ground
  const Vec3 ground = L.position + dir * t;
  const Vec3 T = one_minus(shadow_alpha(sv, L, Receiver{ground, {0, 1, 0}, kNoObject}));
  std::printf("under the amber pane: T = (%.3f, %.3f, %.3f)\n", T.x, T.y, T.z);
  // The pane is a thin box: the light crosses two faces, each passing
  // (1 - 0.5) f, f = (1, 0.6, 0.12).
  EXPECT_NEAR(T.x, 0.25f, 0.01f);
  EXPECT_NEAR(T.y, 0.09f, 0.01f);
  EXPECT_NEAR(T.z, 0.0036f, 0.01f);
}

}  // namespace
