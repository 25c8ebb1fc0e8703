// Stability at the limits: more nodes than a texel's buffer holds, epsilon
// = 0 and >= 1, a 170-degree spot light, view parallel to the light
// (LiSPSM degenerate), and NaN / Inf in the input.
#include <algorithm>
#include <functional>

#include "common/minimax_fit.h"
#include "stability_util.h"
#include "common/host_maps.h"

namespace stab {
namespace {

// A slab of uniform fog, `voxels_y` voxels thick (march step half a voxel):
// a vertical light ray through it yields 2 * voxels_y samples, none collinear.
Scene fog_slab(int voxels_y, float sigma) {
  Scene s = scene_named("fog slab");
  auto g = std::make_shared<DenseGrid>();
  g->nx = g->nz = 2;
  g->ny = voxels_y;
  g->values.assign(size_t(4) * voxels_y, 1.0f);
  g->background = 1.0f;
  Volume v;
  v.name = "fog";
  v.grid = g;
  Mat4 m;  // the grid spans [-2, 2] x [1, 3] x [-2, 2]
  m.m[0][0] = m.m[2][2] = 2.0f;
  m.m[1][1] = 2.0f / float(voxels_y);
  m.m[0][3] = m.m[2][3] = -1.0f;
  m.m[1][3] = 1.0f + 1.0f / float(voxels_y);
  v.index_to_object = m;
  v.transfer = {TransferPoint{0, vec3(0), {0, 0, 0}}, TransferPoint{1, vec3(sigma), {0, 0, 0}}};
  s.volumes.push_back(v);
  Object o;
  o.name = "fog";
  o.mesh = share(box_mesh({-2, 1, -2}, {2, 3, 2}));
  o.surface.opacity = 0.0f;
  o.interior = InteriorKind::Volume;
  o.volume = 0;
  s.objects.push_back(o);
  s.objects.push_back(surface_object("ground", make_quad(10, 10), Mat4{}, 1.0f, false));
  s.lights.push_back(spot_light({0, 5, 0}, {0, -1, 0}, 15, 10));
  s.shadows.resolution = 17;
  s.shadows.epsilon = 0.0f;
  s.camera.width = 24;
  s.camera.height = 16;
  return s;
}

TEST(Overflow, RecompressesRecordsTheErrorAndKeepsItWithinTheBound) {
  const int capacity = 16;
  const float sigma = 1.0f;
  Scene s = fog_slab(64, sigma);  // 128 samples per ray, 16 slots
  SceneBuffers sb = compiled_scene(s);
  LightSetup ls = setup_lights(s.lights, sb, s.shadows.resolution);
  const PinholeView& view = ls.maps[0].view;
  FragmentBuffers fb;
  cast_fragments(sb.view(), view, ObjectMask{}, fb);
  std::vector<uint32_t> inside;
  LightPassParams lp{view, 0.0f, {inside.data(), 0}};
  cdsm_test::HostMaps out;
  DsmBuildStats st = cdsm_test::build_host_map(sb, lp, fb, out, DsmLayoutParams{}, capacity);
  EXPECT_GT(st.overflow_texels, 0u);
  EXPECT_GT(st.max_extra_error, 0.0f);
  EXPECT_LE(st.max_nodes, uint32_t(capacity));
  // The centre texel (the axis): within the recorded bound of 1 - exp(-sigma d).
  const TexelRange& centre = out.grey.texels[size_t(8) * 17 + 8];
  std::vector<DsmNode> n(out.grey.nodes.begin() + centre.offset, out.grey.nodes.begin() + centre.offset + centre.count);
  ASSERT_TRUE(physical(n));
  Span<const DsmNode> sp{n.data(), n.size()};
  for (float y = 3.0f; y >= 0.9f; y -= 0.05f) {
    float d = std::clamp(3.0f - y, 0.0f, 2.0f);
    EXPECT_NEAR(lookup_alpha(sp, 5.0f - y), 1.0f - std::exp(-sigma * d), st.max_extra_error + 1e-4f) << "y " << y;
  }
  EXPECT_NEAR(lookup_alpha(sp, 4.5f), 1.0f - std::exp(-2.0f * sigma), 1e-4f) << "the slab's end is kept";
  for (size_t t = 0; t < out.grey.texels.size(); ++t) {
    std::vector<DsmNode> m(out.grey.nodes.begin() + out.grey.texels[t].offset,
                           out.grey.nodes.begin() + out.grey.texels[t].offset + out.grey.texels[t].count);
    ASSERT_TRUE(physical(m)) << "texel " << t;
  }
}

TEST(Overflow, FrameStatsReportIt) {
  Scene s = fog_slab(1100, 1.0f);  // 2,200 samples per ray: over the 1,024-node buffer
  // One system's frame, its maps built once (under ASan a build of these
  // rays takes ~17 s): what its update reported, an image over its maps,
  // and the maps against the reference through and under the slab.
  Rig rig(s);
  const FrameStats st = rig.snapshot().stats();
  ASSERT_TRUE(finite_image(rig.system->render()));
  EXPECT_GT(st.memory.overflow_texels, 0u);
  EXPECT_GT(st.memory.max_extra_error, 0.0f);
  EXPECT_LE(st.memory.max_nodes_per_texel, uint32_t(kTexelNodeCapacity));
  EXPECT_NEAR(rig.alpha({0.02f, 0.5f, 0.02f}), 1.0f - std::exp(-2.0f), st.memory.max_extra_error + 1e-3f);
  double worst = 0.0;
  for (float x : {-0.6f, 0.02f, 0.6f})
    for (float y = 2.95f; y > 0.0f; y -= 0.1f) {
      const Vec3 p{x, y, 0.02f};
      worst = std::max(worst, double(std::fabs(1.0f - rig.alpha(p) - rig.reference_T(p))));
    }
  std::printf("[ overflow ] worst |T - reference| %.5f, recorded extra error %.5f\n", worst,
              double(st.memory.max_extra_error));
  EXPECT_LT(worst, double(st.memory.max_extra_error) + 0.01);
}

TEST(Overflow, MoreStepsThanTheBufferHolds) {
  // Surfaces are steps: a texel crossing more translucent surfaces than its
  // buffer holds must still fit (steps merged into lines once the tolerance
  // allows), with the error recorded — probed on memory larger than the
  // declared capacity first, so a regression cannot corrupt the heap.
  const int capacity = 16;
  int written = probe_step_overflow();
  ASSERT_LE(written, capacity) << "NodeBuffer wrote past its capacity";
  std::vector<DsmNode> mem(static_cast<size_t>(capacity));
  NodeBuffer buf{mem.data(), capacity};
  WedgeCompressor c(0.0f);
  float alpha = 0.0f;
  std::vector<DsmNode> exact;
  for (int i = 0; i < 3 * capacity; ++i) {
    float z = 1.0f + 0.01f * float(i);
    c.push(buf, z, alpha);
    exact.push_back({z, alpha});
    alpha += 0.05f * (1.0f - alpha);
    c.step(buf, z, alpha);
    exact.push_back({z, alpha});
  }
  c.finish(buf);
  std::vector<DsmNode> kept(mem.begin(), mem.begin() + buf.count);
  EXPECT_LE(buf.count, capacity);
  EXPECT_GT(buf.removed, 0);
  EXPECT_TRUE(physical(kept));
  EXPECT_EQ(kept.back().alpha, alpha) << "the final opacity is a kept node";
  // Independent: the change from the exact staircase against the best fit
  // with as many nodes (exhaustive DP); the recorded error must cover it.
  double change = cdsm_test::sup_change(exact, kept);
  EXPECT_LE(change, 2.0 * cdsm_test::minimax_fit_error(exact, kept.size()) + 1e-6);
  EXPECT_GE(double(buf.extra_error) + 1e-6, change);
}

// ---- epsilon = 0 and epsilon >= 1 -----------------------------------------------------

Scene mixed(float eps) {
  Scene s = scene_named("mixed");
  TriangleMesh quad = make_quad(3, 3);
  for (int i = 0; i < 10; ++i) s.objects.push_back(surface_object("layer", quad, at({0, 3.0f + 0.05f * i, 0}), 0.1f));
  s.objects.push_back(medium_object("absorber", box_mesh({-1.5f, 2, -1.5f}, {1.5f, 2.5f, 1.5f}), Mat4{}, 1.2f));
  add_uniform_volume(s, "fog", {-1.5f, 1, -1.5f}, {1.5f, 1.8f, 1.5f}, 0.8f,
                     box_mesh({-1.5f, 1, -1.5f}, {1.5f, 1.8f, 1.5f}), 16);
  s.objects.push_back(surface_object("ground", make_quad(10, 10), Mat4{}, 1.0f, false));
  s.lights.push_back(spot_light({0, 6, 0}, {0, -1, 0}, 15, 10));
  s.shadows.epsilon = eps;
  s.shadows.resolution = 16;
  return s;
}

TEST(Epsilon, ZeroStoresEverySampleExactly) {
  Rig rig(mixed(0.0f));
  EXPECT_TRUE(all_physical(rig));
  Vec3 p{0.05f, 0.5f, 0.05f};
  EXPECT_NEAR(1.0f - rig.alpha(p), rig.reference_T(p), 2e-3f);  // the march (h = 0.5 voxel) vs the reference's 1/4
  // Just below the 10 layers (no medium there yet): 1 - 0.9^10, exactly.
  EXPECT_NEAR(rig.alpha({0.05f, 2.8f, 0.05f}), 1.0f - std::pow(0.9f, 10.0f), 1e-5f);
  // Every surface is a step: 20 nodes for 10 layers, before the media.
  std::vector<DsmNode> n = rig.texel_at(0, p);
  int steps = 0;
  for (size_t i = 1; i < n.size(); ++i) steps += n[i].z == n[i - 1].z;
  EXPECT_EQ(steps, 10);
}

TEST(Epsilon, LargeTolerancesStayPhysicalWithTheExactEnd) {
  Rig exact(mixed(0.0f));
  for (float eps : {0.5f, 1.0f}) {  // 1 is the largest: beyond it any function would do
    Rig rig(mixed(eps));
    EXPECT_TRUE(all_physical(rig)) << "eps " << eps;
    // Surfaces are steps at any eps: between the layers (no medium there
    // yet) alpha is exactly 1 - 0.9^k after k layers.
    for (int k = 1; k < 10; ++k) {
      float y = 3.0f + 0.05f * float(10 - k) - 0.025f;  // below the k-th layer from the top
      EXPECT_NEAR(rig.alpha({0.05f, y, 0.05f}), 1.0f - std::pow(0.9f, float(k)), 1e-5f) << "eps " << eps << ", " << k;
    }
    // Below everything: the last node is the exact final opacity.
    EXPECT_NEAR(rig.alpha({0.05f, 0.5f, 0.05f}), exact.alpha({0.05f, 0.5f, 0.05f}), 1e-5f) << "eps " << eps;
    Renderer r;
    ASSERT_TRUE(finite_image(r.render(mixed(eps), cpu_options())));
  }
}

TEST(Epsilon, NaNOrInfiniteIsAClearError) {
  Renderer r;
  for (float eps : {std::nanf(""), INFINITY, -0.5f, 10.0f}) {
    Scene s = mixed(eps);
    try {
      r.render(s, cpu_options());
      ADD_FAILURE() << "epsilon " << eps << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("epsilon"), std::string::npos) << e.what();
    }
  }
}

// ---- a spot light with a 170-degree cone ------------------------------------------------

Scene wide_spot() {
  Scene s = scene_named("170 degree spot");
  s.objects.push_back(surface_object("below", make_box({0.4f, 0.4f, 0.4f}), at({0, 1.5f, 0}), 1.0f));
  // 75 degrees off the axis, 2 from the light: its shadow lands near x = 11.2.
  const float a = 75.0f * 3.14159265f / 180.0f;
  s.objects.push_back(
      surface_object("aside", make_box({0.3f, 0.3f, 0.3f}), at({2 * std::sin(a), 3 - 2 * std::cos(a), 0}), 1.0f));
  s.objects.push_back(surface_object("ground", make_quad(200, 200), Mat4{}, 1.0f, false));
  s.lights.push_back(spot_light({0, 3, 0}, {0, -1, 0}, 85, 80));
  s.shadows.resolution = 128;
  s.camera.position = {0, 12, 14};
  s.camera.target = {4, 0, 0};
  return s;
}

TEST(WideSpot, A170DegreeConeUsesFacesAndShadowsAtItsRim) {
  Rig rig(wide_spot());
  ASSERT_EQ(rig.frame.setup.lights[0].map_mode, MapMode::CubeFaces);
  const LightData& L = rig.frame.setup.lights[0];
  auto at_angle = [](float deg, float dist) {
    float a = deg * 3.14159265f / 180.0f;
    return Vec3{dist * std::sin(a), 3 - dist * std::cos(a), 0};
  };
  EXPECT_EQ(cone_factor(L, at_angle(70, 5)), 1.0f);
  EXPECT_GT(cone_factor(L, at_angle(83, 5)), 0.0f);
  EXPECT_EQ(cone_factor(L, at_angle(86, 5)), 0.0f);
  const float t = 3.0f / std::cos(75.0f * 3.14159265f / 180.0f);
  Vec3 shadow{t * std::sin(75.0f * 3.14159265f / 180.0f), 0, 0};
  EXPECT_NEAR(rig.alpha(shadow), 1.0f, 1e-5f) << "the occluder at 75 degrees shadows the rim";
  EXPECT_NEAR(rig.reference_T(shadow), 0.0f, 1e-6f);
  EXPECT_EQ(rig.alpha({-shadow.x, 0, 0}), 0.0f);
  EXPECT_NEAR(rig.alpha({0, 0, 0}), 1.0f, 1e-5f);
  EXPECT_TRUE(all_physical(rig));
  Renderer r;
  RenderOptions o = cpu_options();
  Scene s = wide_spot();
  ASSERT_TRUE(finite_image(r.render(s, o)));
  TransmittanceError te = r.transmittance_error(s, o);
  EXPECT_GT(te.points, 0u);
  EXPECT_LT(te.mean, 0.02);
}

TEST(WideSpot, SceneFilesAcceptAn85DegreeHalfAngle) {
  const char* json = R"({
    "camera": {"position": [0, 2, 6], "target": [0, 0, 0]},
    "objects": [{"name": "box", "mesh": {"type": "box", "size": [1, 1, 1]}}],
    "lights": [{"type": "spot", "position": [0, 3, 0], "direction": [0, -1, 0], "outer_cone": 85, "inner_cone": 80}]
  })";
  Scene s = parse_scene(json, "wide.json", ".");
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_EQ(s.lights[0].outer_cone_deg, 85.0f);
}

// ---- view parallel to the light (LiSPSM degenerate) -----------------------------------------

// The camera looks straight down the light's axis (LiSPSM degenerates): the
// clustering measures in uniform light space instead (asserted), and the
// shadows — pillars' shadows the camera sees beside them — stay right.
Scene parallel_view(Vec3 camera_dir) {
  Scene s = scene_named("view parallel to light");
  for (int i = 0; i < 6; ++i)
    s.objects.push_back(surface_object("pillar", make_box({0.5f, 4.0f, 0.5f}),
                                       at({-3.0f + 1.2f * i, 2.0f, (i % 2) ? 1.5f : -1.5f}), 1.0f));
  s.objects.push_back(surface_object("ground", make_quad(14, 14), Mat4{}, 1.0f, false));
  s.lights.push_back(spot_light({0, 10, 0}, {0, -1, 0}, 35, 30));
  s.camera.position = {0.7f, 9.0f, 0.4f};
  s.camera.target = s.camera.position + camera_dir;
  s.camera.up = {0, 0, -1};
  s.camera.fov_y_deg = 60.0f;
  s.shadows.max_clusters = 4;
  s.shadows.resolution = 128;
  return s;
}

TEST(Lispsm, ViewParallelToTheLightFallsBackAndStaysCorrect) {
  Renderer r;
  RenderOptions o = cpu_options();
  FrameStats st, tilted;
  Scene s = parallel_view({0, -1, 0});
  Image img = r.render(s, o, &st);
  ASSERT_TRUE(finite_image(img));
  ASSERT_EQ(st.clusters.size(), 1u);
  ASSERT_TRUE(st.clusters[0].clustered) << st.clusters[0].fallback_reason;
  EXPECT_EQ(st.clusters[0].directions, 1);
  EXPECT_EQ(st.clusters[0].warped_directions, 0) << "view parallel to the light: uniform light space";
  Renderer r2;
  r2.render(parallel_view(normalize(Vec3{0.0f, -1.0f, -1.2f})), o, &tilted);
  EXPECT_EQ(tilted.clusters[0].warped_directions, 1) << "a tilted view uses the LiSPSM warp";
  // The shadows are in the picture: without them it differs.
  Scene unshadowed = s;
  for (Object& ob : unshadowed.objects) ob.casts_shadows = false;
  Renderer r3;
  ImageError seen = compare_images(img, r3.render(unshadowed, o));
  std::printf("[ lispsm ] with and without shadows: %.1f dB apart\n", seen.psnr);
  EXPECT_LT(seen.psnr, 30.0) << "the camera must see shadows for this test to mean anything";
  TransmittanceError te = r.transmittance_error(s, o);
  EXPECT_GT(te.points, 0u);
  EXPECT_LT(te.mean, 0.03);
}

// ---- NaN or Inf in the input ---------------------------------------------------------

// Renders and returns the cdsm::Error's message ("" if none was thrown).
std::string error_of(const Scene& s) {
  try {
    Renderer r;
    r.render(s, cpu_options());
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

Scene simple() {
  Scene s = scene_named("nan.json");
  s.objects.push_back(surface_object("ball", make_sphere(0.5f, 12, 6), at({0, 0.5f, 0}), 1.0f));
  add_uniform_volume(s, "puff", {-1, 1, -1}, {1, 2, 1}, 1.0f, box_mesh({-1, 1, -1}, {1, 2, 1}), 4);
  s.lights.push_back(spot_light({0, 5, 0}, {0, -1, 0}, 30, 25));
  return s;
}

TEST(BadNumbers, NaNOrInfInATransformAVertexOrAVoxelIsRejectedByName) {
  ASSERT_EQ(error_of(simple()), "");
  {
    Scene s = simple();
    s.objects[0].transform.m[1][3] = std::nanf("");
    std::string e = error_of(s);
    EXPECT_NE(e.find("transform"), std::string::npos) << e;
    EXPECT_NE(e.find("ball"), std::string::npos) << e;
  }
  {
    Scene s = simple();
    auto m = std::make_shared<TriangleMesh>(*s.objects[0].mesh);
    m->positions[3].y = INFINITY;
    s.objects[0].mesh = m;
    std::string e = error_of(s);
    EXPECT_NE(e.find("vertex 3"), std::string::npos) << e;
    EXPECT_NE(e.find("ball"), std::string::npos) << e;
  }
  {
    Scene s = simple();
    auto g = std::make_shared<DenseGrid>(*s.volumes[0].grid);
    g->values[7] = std::nanf("");
    s.volumes[0].grid = g;
    std::string e = error_of(s);
    EXPECT_NE(e.find("voxel 7"), std::string::npos) << e;
    EXPECT_NE(e.find("puff"), std::string::npos) << e;
  }
}

TEST(BadNumbers, NaNOrInfInLightsCameraAndMaterialsIsRejected) {
  struct Case {
    const char* what;
    void (*spoil)(Scene&);
  };
  const Case cases[] = {
      {"light position", [](Scene& s) { s.lights[0].position.x = std::nanf(""); }},
      {"light direction", [](Scene& s) { s.lights[0].direction.y = INFINITY; }},
      {"light intensity", [](Scene& s) { s.lights[0].intensity = INFINITY; }},
      {"spot cone", [](Scene& s) { s.lights[0].outer_cone_deg = std::nanf(""); }},
      {"camera position", [](Scene& s) { s.camera.position.z = std::nanf(""); }},
      {"surface opacity", [](Scene& s) { s.objects[0].surface.opacity = std::nanf(""); }},
      {"transmission colour", [](Scene& s) { s.objects[0].surface.transmission_color.y = std::nanf(""); }},
      {"medium sigma channel",
       [](Scene& s) {
         s.objects[0].interior = InteriorKind::Constant;
         s.objects[0].sigma = {1.0f, std::nanf(""), 1.0f};
       }},
      {"medium sigma",
       [](Scene& s) {
         s.objects[0].interior = InteriorKind::Constant;
         s.objects[0].sigma = vec3(INFINITY);
       }},
      {"transfer extinction", [](Scene& s) { s.volumes[0].transfer[1].extinction = vec3(std::nanf("")); }},
  };
  std::string bugs;
  for (const Case& c : cases) {
    Scene s = simple();
    c.spoil(s);
    std::string e = error_of(s);
    if (e.empty()) {
      Renderer r;
      Image img = r.render(s, cpu_options());
      size_t bad = 0;
      for (float v : img.rgb) bad += !std::isfinite(v);
      bugs += std::string(bugs.empty() ? "" : "; ") + c.what + " (" + std::to_string(bad) + " of " +
              std::to_string(img.rgb.size()) + " channels NaN/Inf)";
      continue;
    }
    SCOPED_TRACE(c.what);
    EXPECT_NE(e.find("nan.json"), std::string::npos) << "the error names the scene: " << e;
  }
  EXPECT_TRUE(bugs.empty()) << "NaN/Inf accepted without a cdsm::Error: " << bugs;
}

TEST(BadNumbers, SceneFilesRejectOutOfRangeNumbersWithTheirPath) {
  const char* json = R"({
    "camera": {"position": [0, 2, 6], "target": [0, 0, 0]},
    "objects": [{"name": "box", "mesh": {"type": "box", "size": [1, 1, 1]}, "transform": {"translate": [0, 1e999, 0]}}],
    "lights": [{"type": "point", "position": [0, 3, 0]}]
  })";
  try {
    parse_scene(json, "inf.json", ".");
    ADD_FAILURE() << "1e999 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("inf.json"), std::string::npos) << e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "not a cdsm::Error: " << e.what();
  }
}

// ---- up-front memory limits (issue "Reliability") --------------------------------------

// Expects the scene (or its settings) refused before anything large is
// allocated: an error naming the setting, the estimate and the limit.
void expect_refused(const std::function<void()>& f, const std::vector<std::string>& parts) {
  try {
    f();
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    std::string m = e.what();
    for (const std::string& p : parts) EXPECT_NE(m.find(p), std::string::npos) << "'" << p << "' not in: " << m;
  }
}

TEST(MemoryLimits, HugeSettingsAreRefusedUpFrontNamingTheSetting) {
  Renderer r;
  // A fixed layout of 8192^2 x 4096 layers: terabytes, refused at any limit.
  Scene s = simple();
  s.shadows.resolution = 8192;
  s.shadows.layout = DsmLayout::Fixed;
  s.shadows.fixed_layers = 4096;
  expect_refused([&] { r.render(s, cpu_options()); },
                 {"nan.json: /shadows/fixed_layers", "needs an estimated", "TiB", "more than the limit of"});
  // 8192^2 maps under a 1 GiB limit set in the scene.
  s = simple();
  s.shadows.resolution = 8192;
  s.shadows.max_memory_mib = 1024;
  expect_refused([&] { r.render(s, cpu_options()); }, {"/shadows/resolution", "1 GiB", "/shadows/max_memory"});
  // The same through the process-wide limit (--max-memory).
  s.shadows.max_memory_mib = 0;
  set_memory_limit_mib(1024);
  expect_refused([&] { r.render(s, cpu_options()); }, {"/shadows/resolution", "--max-memory"});
  set_memory_limit_mib(0);
  // Within the limit it renders.
  s = simple();
  s.shadows.max_memory_mib = 1024;
  EXPECT_TRUE(finite_image(r.render(s, cpu_options())));
}

TEST(MemoryLimits, TheSceneReaderRefusesHugeGridsAndMeshesBeforeMakingThem) {
  const std::string head =
      R"({"camera": {"position": [0, 2, 6], "target": [0, 0, 0]}, "shadows": {"max_memory": 2048},)";
  const std::string tail = R"("lights": [{"type": "point", "position": [0, 3, 0]}]})";
  // A 1024^3 noise grid (4 GiB of floats): refused in milliseconds, not generated for minutes.
  expect_refused(
      [&] {
        parse_scene(head + R"("volumes": [{"name": "fog", "grid": {"type": "noise", "size": [1024, 1024, 1024]},
          "transfer": [{"density": 0, "extinction": 1}]}], "objects": [{"name": "fog",
          "interior": {"type": "volume", "volume": "fog"}}],)" +
                        tail,
                    "big.json", ".");
      },
      {"big.json: /volumes/0/grid/size", "1024x1024x1024 grid needs 8 GiB", "limit of 2 GiB"});
  // A sphere of 4096 x 4096 segments (33 M triangles).
  expect_refused(
      [&] {
        parse_scene(
            head + R"("objects": [{"name": "ball", "mesh": {"type": "sphere", "segments": 4096, "rings": 4096}}],)" +
                tail,
            "ball.json", ".");
      },
      {"ball.json: /objects/0/mesh", "sphere of 4096 x 4096 segments", "limit of 2 GiB"});
}

}  // namespace
}  // namespace stab
