// The benchmark's baselines (shadows/hd/baselines.h) on the same hard
// inputs: physical node lists, the right answers where each method is exact.
#include "stability_util.h"

#include <algorithm>

#include "cdsm/method_params.h"
#include "hd/series.h"

namespace stab {
namespace {

Scene layered(ShadowMethod method, float param) {
  Scene s = scene_named("baselines");
  TriangleMesh quad = make_quad(3, 3);
  s.objects.push_back(surface_object("glass", quad, at({0, 3.2f, 0}), 0.3f));
  s.objects.push_back(surface_object("glass", quad, at({0, 3.0f, 0}), 0.3f));
  add_uniform_volume(s, "fog", {-1.5f, 1, -1.5f}, {1.5f, 2, 1.5f}, 2.0f, box_mesh({-1.5f, 1, -1.5f}, {1.5f, 2, 1.5f}),
                     16);
  s.objects.push_back(surface_object("ground", make_quad(10, 10), Mat4{}, 1.0f, false));
  s.lights.push_back(spot_light({0, 6, 0}, {0, -1, 0}, 15, 10));
  s.shadows.resolution = 17;  // odd: the centre texel's ray is the axis
  s.shadows.epsilon = 0.0f;
  s.shadows.method = method;
  s.shadows.method_param = param;
  return s;
}

std::vector<DsmNode> centre(const Rig& rig) { return rig.texel(0, 8, 8); }

TEST(Baselines, ShadowMapIsOneStepWhereTheRayTurnsOpaque) {
  // Threshold 0.5: the 0.3 panes are skipped (alpha test); the fog (sigma 2)
  // reaches opacity 0.5 at ln 2 / 2 below its top.
  Rig rig(layered(ShadowMethod::ShadowMap, 0.5f));
  EXPECT_TRUE(all_physical(rig));
  std::vector<DsmNode> n = centre(rig);
  ASSERT_EQ(n.size(), 2u);
  EXPECT_EQ(n[0].z, n[1].z);
  EXPECT_EQ(n[0].alpha, 0.0f);
  EXPECT_EQ(n[1].alpha, 1.0f);
  EXPECT_NEAR(n[0].z, 6.0f - 2.0f + std::log(2.0f) / 2.0f, 0.002f);
  // A lower threshold takes the first pane.
  Rig low(layered(ShadowMethod::ShadowMap, 0.25f));
  std::vector<DsmNode> m = centre(low);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_NEAR(m[0].z, 6.0f - 3.2f, 1e-5f);
}

TEST(Baselines, OpacitySlicesSampleTheExactOpacityAtUniformBoundaries) {
  const int slices = 16;
  Rig rig(layered(ShadowMethod::OpacitySlices, float(slices)));
  EXPECT_TRUE(all_physical(rig));
  std::vector<DsmNode> n = centre(rig);
  ASSERT_EQ(n.size(), size_t(slices + 1));
  Vec3 L = rig.scene.lights[0].position;
  Vec3 dir = pixel_ray(rig.frame.setup.maps[0].view, 8, 8);
  float dz = n[1].z - n[0].z;
  for (int k = 0; k <= slices; ++k) {
    if (k > 0) {
      EXPECT_NEAR(n[size_t(k)].z - n[size_t(k - 1)].z, dz, 1e-4f);
    }
    // Right-continuous exact opacity at the boundary (panes and fog).
    Vec3 p = L + dir * (n[size_t(k)].z + 1e-4f);
    EXPECT_NEAR(n[size_t(k)].alpha, 1.0f - rig.reference_T(p), 3e-3f) << "slice " << k;
  }
  // The slices span the casters the ray meets: the first pane to the fog's bottom.
  EXPECT_NEAR(n.front().z, 6.0f - 3.2f, 1e-4f);
  EXPECT_NEAR(n.back().z, 6.0f - 1.0f, 1e-4f);
  // Empty texels stay empty.
  Scene s = layered(ShadowMethod::OpacitySlices, float(slices));
  s.lights[0].outer_cone_deg = 40;
  Rig wide(s);
  EXPECT_TRUE(wide.texel(0, 0, 0).empty());
}

TEST(Baselines, FixedNodesKeepAtMostNAndTheExactEnds) {
  Rig exact(layered(ShadowMethod::Dsm, 0.0f));
  std::vector<DsmNode> e = centre(exact);
  ASSERT_GT(e.size(), 8u);
  for (int nodes : {2, 4, 8}) {
    Rig rig(layered(ShadowMethod::FixedNodes, float(nodes)));
    EXPECT_TRUE(all_physical(rig));
    for (const DsmBuildStats& st : rig.frame.map_stats) EXPECT_LE(st.max_nodes, uint32_t(nodes));
    std::vector<DsmNode> n = centre(rig);
    ASSERT_EQ(n.size(), size_t(nodes));
    EXPECT_EQ(n.front().z, e.front().z);
    EXPECT_NEAR(n.back().alpha, e.back().alpha, 1e-6f);
  }
  // With room for every sample it is exact (the same samples the wedge sees at eps = 0).
  Rig all(layered(ShadowMethod::FixedNodes, 512.0f));
  std::vector<DsmNode> n = centre(all);
  Span<const DsmNode> sn{n.data(), n.size()}, se{e.data(), e.size()};
  for (float z = e.front().z - 0.1f; z < e.back().z + 0.1f; z += 0.013f)
    EXPECT_NEAR(lookup_alpha(sn, z), lookup_alpha(se, z), 1e-5f) << "depth " << z;
}

// ---- deep opacity maps, Fourier opacity maps, moments (issue 31) --------
// Analytic cases down the centre texel's ray (the spot's axis, from y = 6
// downwards: depth z = 6 - y): a constant-sigma slab (Beer-Lambert), two
// stacked translucent quads, one quad (a step in depth).
enum class Case { Slab, Quads, Step };

Scene analytic(Case c, ShadowMethod method, float param, float thickness = 0.0f) {
  Scene s = scene_named("analytic");
  if (c == Case::Slab)
    s.objects.push_back(medium_object("slab", box_mesh({-1.5f, 1, -1.5f}, {1.5f, 2, 1.5f}), {}, 2.0f));
  if (c == Case::Quads) {
    s.objects.push_back(surface_object("upper", make_quad(3, 3), at({0, 3.2f, 0}), 0.3f));
    s.objects.push_back(surface_object("lower", make_quad(3, 3), at({0, 3.0f, 0}), 0.3f));
  }
  if (c == Case::Step) s.objects.push_back(surface_object("pane", make_quad(3, 3), at({0, 3.0f, 0}), 0.6f));
  s.objects.push_back(surface_object("ground", make_quad(10, 10), Mat4{}, 1.0f, false));
  s.lights.push_back(spot_light({0, 6, 0}, {0, -1, 0}, 15, 10));
  s.shadows.resolution = 17;
  s.shadows.method = method;
  s.shadows.method_param = param;
  s.shadows.layer_thickness = thickness;
  return s;
}

// The exact opacity at depth z (right-continuous at the surfaces).
float exact_alpha(Case c, float z) {
  if (c == Case::Slab) return 1.0f - std::exp(-2.0f * std::clamp(z - 4.0f, 0.0f, 1.0f));
  if (c == Case::Quads) return z < 2.8f ? 0.0f : z < 3.0f ? 0.3f : 0.51f;
  return z < 3.0f ? 0.0f : 0.6f;
}

float at_depth(const std::vector<DsmNode>& n, float z) {
  return lookup_alpha(Span<const DsmNode>{n.data(), n.size()}, z);
}

TEST(Baselines, DeepOpacityIsExactBehindALayerItsThicknessHolds) {
  // The slab (1 m) inside the first layer (1.5 m): exact from the layer's
  // end on, linear inside it, 0 at the first caster depth.
  Rig rig(analytic(Case::Slab, ShadowMethod::DeepOpacity, 4, 1.5f));
  EXPECT_TRUE(all_physical(rig));
  std::vector<DsmNode> n = centre(rig);
  ASSERT_EQ(n.size(), 5u);
  EXPECT_NEAR(n[0].z, 4.0f, 1e-4f);
  EXPECT_EQ(n[0].alpha, 0.0f);
  for (int k = 1; k <= 4; ++k) EXPECT_NEAR(n[size_t(k)].z - n[size_t(k - 1)].z, 1.5f, 1e-4f);
  for (float z = 5.5f; z < 5.99f; z += 0.05f) EXPECT_NEAR(at_depth(n, z), exact_alpha(Case::Slab, z), 2e-3f) << z;
  EXPECT_NEAR(at_depth(n, 4.75f), 0.5f * exact_alpha(Case::Slab, 5.0f), 2e-3f);  // inside: the layer's line
  // A step: 0 at the pane, its opacity a layer behind, exact from there.
  Rig step(analytic(Case::Step, ShadowMethod::DeepOpacity, 4, 0.5f));
  std::vector<DsmNode> m = centre(step);
  EXPECT_NEAR(at_depth(m, 3.0f), 0.0f, 1e-6f);
  EXPECT_NEAR(at_depth(m, 3.25f), 0.3f, 2e-3f);
  EXPECT_NEAR(at_depth(m, 3.5f), 0.6f, 1e-5f);
  EXPECT_NEAR(at_depth(m, 5.9f), 0.6f, 1e-5f);
  // What lies beyond the last layer is lost: one 0.1 m layer holds the
  // upper quad only.
  Rig thin(analytic(Case::Quads, ShadowMethod::DeepOpacity, 1, 0.1f));
  std::vector<DsmNode> q = centre(thin);
  EXPECT_NEAR(at_depth(q, 5.9f), 0.3f, 1e-5f);
}

TEST(Baselines, DeepOpacityLayersSpanTheCastersDepthExtentByDefault) {
  // layered(): panes at y 3.2 (nearest caster point 2.8 from the light) and
  // a fog box down to y = 1 whose farthest corner is |(1.5, -5, 1.5)| away.
  const int N = 8;
  Rig rig(layered(ShadowMethod::DeepOpacity, float(N)));
  EXPECT_TRUE(all_physical(rig));
  std::vector<DsmNode> n = centre(rig);
  ASSERT_EQ(n.size(), size_t(N + 1));
  const float extent = std::sqrt(1.5f * 1.5f * 2.0f + 25.0f) - 2.8f;
  EXPECT_NEAR(n[0].z, 2.8f, 1e-4f);
  EXPECT_NEAR(n[1].z - n[0].z, extent / N, 1e-3f);
  // Each boundary holds the exact opacity there.
  const Vec3 L = rig.scene.lights[0].position, dir = pixel_ray(rig.frame.setup.maps[0].view, 8, 8);
  for (size_t k = 1; k < n.size(); ++k)
    EXPECT_NEAR(n[k].alpha, 1.0f - rig.reference_T(L + dir * (n[k].z + 1e-4f)), 3e-3f) << "layer " << k;
}

// The worst |alpha - exact| down the axis, leaving out depths within `gap`
// of a surface or a slab face (the methods' transition zones).
float worst_away_from_surfaces(const std::vector<DsmNode>& n, Case c, float gap) {
  const std::vector<float> faces = c == Case::Slab    ? std::vector<float>{4.0f, 5.0f}
                                   : c == Case::Quads ? std::vector<float>{2.8f, 3.0f}
                                                      : std::vector<float>{3.0f};
  float worst = 0.0f;
  for (float z = 0.5f; z < 5.95f; z += 0.005f) {
    bool near_face = false;
    for (float f : faces) near_face = near_face || std::fabs(z - f) < gap;
    if (!near_face) worst = std::max(worst, std::fabs(at_depth(n, z) - exact_alpha(c, z)));
  }
  return worst;
}

TEST(Baselines, FourierOpacityKeepsTheTotalAndItsRingingIsBounded) {
  for (Case c : {Case::Slab, Case::Quads, Case::Step})
    for (int coefficients : {4, 8, 16}) {
      Rig rig(analytic(c, ShadowMethod::FourierOpacity, float(coefficients)));
      EXPECT_TRUE(all_physical(rig));  // clamped into [0, 1], nondecreasing
      std::vector<DsmNode> n = centre(rig);
      ASSERT_FALSE(n.empty());
      // Behind every caster: the total, exactly (float coefficients, the
      // tabulation's 1e-3).
      EXPECT_NEAR(at_depth(n, 5.95f), exact_alpha(c, 5.95f), 2e-3f) << int(c) << " N " << coefficients;
      // Ringing: the truncated series' optical depth overshoots by a Gibbs
      // share (< 0.1) of each jump; the clamp keeps it physical. Away from
      // the jumps (a quarter of the range over the harmonics) the opacity
      // misses by less than that share of the total absorbance.
      const float total = -std::log(1.0f - exact_alpha(c, 5.95f));
      const float range = c == Case::Slab ? 1.1f : c == Case::Quads ? 0.22f : 0.0f;
      const int harmonics = (coefficients - 1) / 2;
      const float gap = c == Case::Step ? 0.01f : 0.25f * range / float(harmonics) + 0.01f;
      const float worst = worst_away_from_surfaces(n, c, gap);
      std::printf("[ fourier  ] case %d N %2d: worst away from the jumps %.4f (total absorbance %.3f)\n", int(c),
                  coefficients, worst, total);
      // Bounds near what each case measures (2026-12-06, N 4 / 8 / 16): the
      // slab, a smooth ramp where only its faces ring, 0.0054 / 0.0084 /
      // 0.0029; the quads 0.0345 / 0.0133 / 0.0263 (a Gibbs share of the
      // total, 0.713); the step nothing (away from its one jump).
      if (c == Case::Slab)
        EXPECT_LT(worst, 0.015f) << "N " << coefficients;
      else
        EXPECT_LT(worst, c == Case::Step ? 2e-3f : 0.06f) << int(c) << " N " << coefficients;
    }
}

TEST(Baselines, MomentsBracketTheTrueOpacityAndKeepTheTotal) {
  for (Case c : {Case::Slab, Case::Quads, Case::Step})
    for (int moments : {4, 8}) {
      Rig rig(analytic(c, ShadowMethod::Moments, float(moments)));
      EXPECT_TRUE(all_physical(rig));
      std::vector<DsmNode> n = centre(rig);
      ASSERT_FALSE(n.empty());
      EXPECT_NEAR(at_depth(n, 5.95f), exact_alpha(c, 5.95f), 2e-3f) << int(c) << " n " << moments;
      EXPECT_EQ(at_depth(n, 2.0f), 0.0f);  // in front of every caster
    }
  // The stacked quads: the two surfaces span the range, u = -1 and +1.
  // Two atoms are what four or eight moments determine exactly, so between
  // them the map holds the true opacity of the front quad, 0.3, up to the
  // bias (beta b0: 3.6e-5 for eight moments) and the tabulation (measured
  // 2026-12-06: 0.29998 .. 0.30000 for 4 moments, 0.29990 .. 0.30000 for
  // 8). And the bound itself (PowerMoments::bound, which the maps use)
  // brackets that truth up to the bias.
  for (int moments : {4, 8}) {
    Rig rig(analytic(Case::Quads, ShadowMethod::Moments, float(moments)));
    std::vector<DsmNode> n = centre(rig);
    PowerMoments m(moments);
    const double A = -std::log(0.7);
    m.add_surface(-1.0, A);
    m.add_surface(1.0, A);
    m.store();
    const double beta = moment_bias(moments).beta;
    float map_lo = 1.0f, map_hi = 0.0f;
    for (float z = 2.82f; z < 2.99f; z += 0.01f) {
      map_lo = std::min(map_lo, at_depth(n, z));
      map_hi = std::max(map_hi, at_depth(n, z));
      double lower, at;
      m.bound(2.0 * (z - 2.8) / 0.2 - 1.0, moment_bias(moments), lower, at);
      const float lo = float(1.0 - std::exp(-m.b[0] * lower)), hi = float(1.0 - std::exp(-m.b[0] * (lower + at)));
      EXPECT_NEAR(at_depth(n, z), 0.3f, 1.5e-4f) << moments << " moments, z " << z;
      EXPECT_GE(0.3f, lo - float(beta * m.b[0]));
      EXPECT_LE(0.3f, hi + float(beta * m.b[0]));
    }
    std::printf("[ moments  ] n %d: between the quads alpha %.5f .. %.5f (true 0.3)\n", moments, map_lo, map_hi);
  }
}

TEST(Baselines, SeriesMethodsStoreAFixedCountPerTexel) {
  // What an engine stores per texel, by what each method is: N layers and
  // the first caster depth; N coefficients and the depth range (2); the
  // total b_0, N moments and the range (2).
  for (int n : {1, 4, 8, 16, 64}) EXPECT_EQ(stored_components(ShadowMethod::DeepOpacity, float(n)), n + 1) << n;
  for (int n : {3, 4, 8, 16, 32}) EXPECT_EQ(stored_components(ShadowMethod::FourierOpacity, float(n)), n + 2) << n;
  for (int n : {4, 8}) EXPECT_EQ(stored_components(ShadowMethod::Moments, float(n)), 1 + n + 2) << n;
  // Parameter 0: the method's default count (baselines.h).
  EXPECT_EQ(stored_components(ShadowMethod::Moments, 0), 1 + kDefaultMoments + 2);
  EXPECT_EQ(stored_components(ShadowMethod::DeepOpacity, 0), kDefaultLayers + 1);
  for (ShadowMethod m :
       {ShadowMethod::Dsm, ShadowMethod::ShadowMap, ShadowMethod::OpacitySlices, ShadowMethod::FixedNodes})
    EXPECT_EQ(stored_components(m, 8), 0);  // node lists: their nodes are their memory
  // The scene validator takes 4 or 8 moments only.
  Scene s = analytic(Case::Step, ShadowMethod::Moments, 6);
  try {
    validate_scene(s);
    ADD_FAILURE() << "6 moments accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("4 or 8"), std::string::npos) << e.what();
  }
}

TEST(Baselines, EveryMethodRendersFiniteOnHardInputs) {
  Renderer r;
  RenderOptions o = cpu_options();
  for (auto [method, param] : {std::pair<ShadowMethod, float>{ShadowMethod::ShadowMap, 0.0f},
                               {ShadowMethod::OpacitySlices, 0.0f},
                               {ShadowMethod::OpacitySlices, 1.0f},
                               {ShadowMethod::FixedNodes, 0.0f},
                               {ShadowMethod::FixedNodes, 2.0f},
                               {ShadowMethod::DeepOpacity, 0.0f},
                               {ShadowMethod::DeepOpacity, 1.0f},
                               {ShadowMethod::FourierOpacity, 3.0f},
                               {ShadowMethod::FourierOpacity, 32.0f},
                               {ShadowMethod::Moments, 4.0f},
                               {ShadowMethod::Moments, 8.0f}}) {
    // A light inside the fog, a saturating absorber, coincident panes.
    Scene s = layered(method, param);
    s.objects.push_back(medium_object("ink", box_mesh({-1, 0.2f, -1}, {1, 0.4f, 1}), Mat4{}, 1e30f));
    s.objects.push_back(surface_object("glass", make_quad(3, 3), at({0, 3.0f, 0}), 0.6f));
    s.lights.push_back(point_light({0.2f, 1.5f, 0.1f}));
    Rig rig(s);
    EXPECT_TRUE(all_physical(rig)) << "method " << int(method) << " param " << param;
    FrameStats st;
    ASSERT_TRUE(finite_image(r.render(s, o, &st)));
    TransmittanceError te = r.transmittance_error(s, o);
    EXPECT_TRUE(std::isfinite(te.mean) && std::isfinite(te.max));
  }
}

TEST(Baselines, SceneFilesNameTheMethod) {
  const char* json = R"({
    "camera": {"position": [0, 2, 6], "target": [0, 0, 0]},
    "shadows": {"method": "opacity_slices", "method_param": 64},
    "objects": [{"name": "box", "mesh": {"type": "box", "size": [1, 1, 1]}}],
    "lights": [{"type": "point", "position": [0, 3, 0]}]
  })";
  Scene s = parse_scene(json, "m.json", ".");
  EXPECT_EQ(s.shadows.method, ShadowMethod::OpacitySlices);
  EXPECT_EQ(s.shadows.method_param, 64.0f);
  std::string bad = R"({"camera": {"position": [0, 2, 6], "target": [0, 0, 0]},
                        "shadows": {"method": "fixed_nodes", "method_param": 1.5},
                        "objects": [{"name": "box", "mesh": {"type": "box", "size": [1, 1, 1]}}],
                        "lights": [{"type": "point", "position": [0, 3, 0]}]})";
  try {
    parse_scene(bad, "bad.json", ".");
    ADD_FAILURE() << "a fractional node count accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/shadows/method_param"), std::string::npos) << e.what();
  }
  try {
    parse_scene(R"({"camera": {"position": [0, 2, 6], "target": [0, 0, 0]}, "shadows": {"method": "vsm"}})", "bad.json",
                ".");
    ADD_FAILURE() << "an unknown method accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("unknown method"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace stab
