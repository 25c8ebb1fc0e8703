// End to end on the default scene (DESIGN.md §7): the DSM path against the
// reference renderer's shadow rays — exactly at texel-centre light rays with
// filtering off, and on the camera's shaded points with filtering on.
#include <gtest/gtest.h>

#include <iostream>
#include <random>
#include <vector>

#include "cdsm/renderer.h"
#include "cdsm/scene_io.h"
#include "reference/reference.h"
#include "unit_util.h"

using namespace cdsm;
using namespace cdsm_test;

namespace {

Scene default_scene(int width, int height) {
  Scene s = load_scene(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/default.json");
  s.camera.width = width;
  s.camera.height = height;
  return s;
}

struct ProbeResult {
  int probes = 0, partial = 0, through_constant = 0;
  double mean = 0.0;
  double worst = 0.0;              // over all probes
  double worst_no_constant = 0.0;  // over probes whose light ray crosses no constant medium
  Vec3 worst_at;
};

// Filtering off, eps 0.01, 256^2: points on texel-centre light rays (through
// surfaces, translucent boxes, the gel sphere, the smoke and the steam),
// compared with the reference shadow ray.
ProbeResult texel_centre_probe() {
  Scene scene = default_scene(160, 120);
  scene.shadows.filtering = false;
  scene.shadows.resolution = 256;
  scene.shadows.epsilon = 0.01f;
  ShadowFixture fx(scene);
  ShadowView sv = fx.view();
  SceneView sc = fx.scene_view();
  ReferenceRenderer ref(sc, fx.frame.setup.lights, ReferenceOptions{0.25f});
  EXPECT_EQ(fx.frame.headers.size(), 1u) << "the default scene has one spot light, one map";
  const PinholeView& mv = fx.map_view(0);
  std::vector<uint32_t> casters =
      fx.sb.mask_where([&](uint32_t o) { return (sc.objects[o].flags & kObjCastsShadows) != 0u; });
  ObjectMask mask{{casters.data(), casters.size()}};
  std::vector<uint32_t> constant_media;
  for (uint32_t o = 0; o < sc.objects.size(); ++o)
    if (sc.objects[o].interior == InteriorKind::Constant) constant_media.push_back(o);

  ProbeResult r;
  std::mt19937 rng(71u);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  double sum = 0.0;
  for (int i = 0; i < 400000 && r.probes < 12000; ++i) {
    int tx = std::min(mv.width - 1, int(u(rng) * float(mv.width)));
    int ty = std::min(mv.height - 1, int(u(rng) * float(mv.height)));
    Vec3 dir = pixel_ray(mv, tx, ty);
    std::vector<float> hits;
    for_each_hit(sc, mask, mv.eye, dir, 0.0f, 3.0e38f, [&](uint32_t, const TriHit& h) { hits.push_back(h.t); });
    if (hits.empty()) continue;
    std::sort(hits.begin(), hits.end());
    float t0 = std::max(0.1f, hits.front() - 0.2f), t1 = hits.back() + 0.3f;
    float t = t0 + (t1 - t0) * u(rng);
    bool near_surface = false;  // the two sides read a surface at the point itself differently
    for (float h : hits) near_surface = near_surface || std::fabs(h - t) < 1e-4f * t;
    if (near_surface) continue;
    Vec3 p = mv.eye + dir * t;
    ViewProjection pr = project(mv, p);
    if (int(std::floor(pr.u)) != tx || int(std::floor(pr.v)) != ty) continue;
    double T_dsm = sample_visibility(sv, 0, p);
    double T_ref = grey_of(ref.transmittance(0, p));
    double e = std::fabs(T_dsm - T_ref);
    bool constant = false;
    for (uint32_t o : constant_media) constant = constant || chord(sc, o, mv.eye, dir, pr.depth) > 0.0;
    if (e > r.worst) {
      r.worst = e;
      r.worst_at = p;
    }
    if (!constant) r.worst_no_constant = std::max(r.worst_no_constant, e);
    r.through_constant += constant ? 1 : 0;
    sum += e;
    if (T_ref > 0.01 && T_ref < 0.99) ++r.partial;
    ++r.probes;
  }
  r.mean = sum / std::max(1, r.probes);
  std::cout << r.probes << " probes (" << r.partial << " partly transmitted, " << r.through_constant
            << " through a constant medium): mean |dT| " << r.mean << ", max " << r.worst << " at (" << r.worst_at.x
            << ", " << r.worst_at.y << ", " << r.worst_at.z << "), max without constant media " << r.worst_no_constant
            << "\n";
  return r;
}

}  // namespace

// Surfaces, translucent boxes and volumes (every probe whose light ray
// crosses no constant medium): |dT| <= eps + 1e-3.
TEST(EndToEnd, TexelCentreProbeWithinEpsilon) {
  ProbeResult r = texel_centre_probe();
  RecordProperty("texel_centre_max_dT", std::to_string(r.worst_no_constant));
  EXPECT_GE(r.probes, 12000);
  EXPECT_GT(r.partial, 2000);
  EXPECT_LE(r.worst_no_constant, 0.01 + 1e-3);
}

// The same probe including rays through the gel sphere (constant sigma 2.5).
TEST(EndToEnd, TexelCentreProbeThroughConstantMedium) {
  ProbeResult r = texel_centre_probe();
  EXPECT_GT(r.through_constant, 100);
  EXPECT_LE(r.worst, 0.01 + 1e-3) << "at (" << r.worst_at.x << ", " << r.worst_at.y << ", " << r.worst_at.z << ")";
}

// Filtering on, eps 0.01, 512^2: the transmittance error over the shaded
// points of a 160x120 view inside the light's cone.
TEST(EndToEnd, FilteredTransmittanceErrorOnShadedPoints) {
  Scene scene = default_scene(160, 120);
  // The figures below were measured on the grey default scene (before its
  // pane and box were tinted); tests/colour checks the tinted one per channel.
  for (Object& o : scene.objects) o.surface.transmission_color = {1, 1, 1};
  scene.shadows.filtering = true;
  scene.shadows.resolution = 512;
  scene.shadows.epsilon = 0.01f;
  Renderer r;
  RenderOptions opt;
  opt.fragments = FragmentSource::Cpu;
  TransmittanceError e = r.transmittance_error(scene, opt);
  std::cout << "transmittance error: " << e.points << " points, mean " << e.mean << ", p99 " << e.p99 << ", max "
            << e.max << ", rmse " << e.rmse << "\n";
  RecordProperty("mean", std::to_string(e.mean));
  RecordProperty("p99", std::to_string(e.p99));
  RecordProperty("max", std::to_string(e.max));
  EXPECT_GT(e.points, 5000u);
  EXPECT_LE(e.mean, 0.01);
  // Measured rmse 0.036 and p99 0.115 with receiver-plane lookups (0.061
  // and 0.50 with the slope-scaled bias before, which let light leak under
  // the glass box resting 1 mm above the ground; issue "Shadows that are
  // right where they should be"): a regression anywhere moves them.
  EXPECT_LE(e.rmse, 0.042);
  EXPECT_LE(e.p99, 0.14);
}

// Every texel of the default scene's map is a physical visibility function:
// depths non-decreasing, alpha non-decreasing within [0, 1], at most two
// nodes per depth (a step), nothing re-compressed at these settings.
TEST(EndToEnd, DsmNodesPhysicalOnDefaultScene) {
  Scene scene = default_scene(160, 120);
  scene.shadows.resolution = 256;
  scene.shadows.epsilon = 0.01f;
  ShadowFixture fx(scene);
  DsmStorage st = fx.frame.view(fx.scene.shadows).storage;
  uint64_t texels = 0, nodes = 0, steps = 0, rgb_texels = 0;
  std::vector<DsmNodeRgb> rgb(4096);
  for (const DsmMap& m : fx.frame.headers)
    for (int ty = 0; ty < int(m.res); ++ty)
      for (int tx = 0; tx < int(m.res); ++tx) {
        // Grey maps' nodes, or each channel of an RGB map's (the tinted
        // pane and box make the default scene's map RGB).
        std::vector<DsmNode> channels[3];
        int kinds = 1;
        if (m.rgb == 0u) {
          Span<const DsmNode> n = texel_nodes<1>(st, m, tx, ty);
          channels[0].assign(n.begin(), n.end());
        } else {
          const uint32_t c = read_texel(st, m, tx, ty, rgb.data(), uint32_t(rgb.size()));
          ASSERT_LE(c, rgb.size());
          for (int k = 0; k < 3; ++k)
            for (uint32_t i = 0; i < c; ++i) channels[k].push_back({rgb[i].z, channel(rgb[i].alpha, k)});
          kinds = 3;
          ++rgb_texels;
        }
        ++texels;
        nodes += channels[0].size();
        for (int k = 0; k < kinds; ++k) {
          const std::vector<DsmNode>& n = channels[k];
          for (uint64_t i = 0; i < n.size(); ++i) {
            ASSERT_TRUE(n[i].alpha >= 0.0f && n[i].alpha <= 1.0f) << tx << ", " << ty << " node " << i;
            if (i == 0) continue;
            ASSERT_GE(n[i].z, n[i - 1].z) << tx << ", " << ty << " node " << i;
            ASSERT_GE(n[i].alpha, n[i - 1].alpha) << tx << ", " << ty << " node " << i << " channel " << k;
            if (n[i].z == n[i - 1].z && k == 0) ++steps;
            if (i >= 2) {
              ASSERT_FALSE(n[i].z == n[i - 1].z && n[i - 1].z == n[i - 2].z) << "three nodes at one depth";
            }
          }
        }
      }
  EXPECT_EQ(rgb_texels, texels) << "the default scene's map holds tinted casters: RGB";
  uint64_t overflow = 0;
  for (const DsmBuildStats& b : fx.frame.map_stats) overflow += b.overflow_texels;
  std::cout << texels << " texels, " << nodes << " nodes, " << steps << " steps\n";
  EXPECT_GT(steps, 1000u);
  EXPECT_EQ(overflow, 0u);
}

// The error decomposition (issue "Shadows that are right where they should
// be"): epsilon moves the map error |T - T_f| and leaves the resolution
// error |T_f - T_exact| where it is (the lookups and T_f do not depend on
// it); a finer map lowers the resolution error.
TEST(EndToEnd, ErrorDecompositionSeparatesEpsilonFromResolution) {
  Scene scene = default_scene(160, 120);
  Renderer r;
  RenderOptions opt;
  opt.fragments = FragmentSource::Cpu;
  opt.error_samples = 4000;
  auto run = [&](float eps, int res) {
    scene.shadows.epsilon = eps;
    scene.shadows.resolution = res;
    TransmittanceError e = r.transmittance_error(scene, opt);
    std::printf(
        "eps %.3f res %d: map p99 %.4f mean %.5f, resolution p99 %.4f mean %.5f, total p99 %.4f; "
        "interior %.1f%% (total p99 %.4f), edge %.1f%%\n",
        eps, res, e.map.p99, e.map.mean, e.resolution.p99, e.resolution.mean, e.total.p99, 100 * e.interior.share,
        e.interior.total.p99, 100 * e.edge.share);
    return e;
  };
  const TransmittanceError fine = run(0.001f, 256), coarse = run(0.1f, 256), sharp = run(0.001f, 1024);
  EXPECT_EQ(fine.points, coarse.points);
  EXPECT_NEAR(fine.resolution.mean, coarse.resolution.mean, 1e-6);
  EXPECT_NEAR(fine.resolution.p99, coarse.resolution.p99, 1e-6);
  EXPECT_GT(coarse.map.p99, 0.03);         // epsilon 0.1 shows in the map error (0.084 measured)
  EXPECT_LE(fine.map.p99, 0.001 + 0.005);  // map p99 <= eps + 0.005 (0.0006 measured)
  EXPECT_LT(sharp.resolution.mean, 0.7 * fine.resolution.mean);
  EXPECT_NEAR(fine.edge.share + fine.interior.share, 1.0, 1e-9);
  EXPECT_GT(fine.interior.share, 0.5);
  // The total stays the figure reported before the decomposition.
  EXPECT_EQ(fine.mean, fine.total.mean);
  EXPECT_EQ(fine.p99, fine.total.p99);
}
