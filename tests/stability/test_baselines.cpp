// The benchmark's baselines (shadows/hd/baselines.h) on the same hard
// inputs: physical node lists, the right answers where each method is exact.
#include "stability_util.h"

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

TEST(Baselines, EveryMethodRendersFiniteOnHardInputs) {
  Renderer r;
  RenderOptions o = cpu_options();
  for (auto [method, param] : {std::pair<ShadowMethod, float>{ShadowMethod::ShadowMap, 0.0f},
                               {ShadowMethod::OpacitySlices, 0.0f},
                               {ShadowMethod::OpacitySlices, 1.0f},
                               {ShadowMethod::FixedNodes, 0.0f},
                               {ShadowMethod::FixedNodes, 2.0f}}) {
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
