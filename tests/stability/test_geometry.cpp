// Stability on hard geometry: coincident faces, rays exactly through shared
// edges and vertices, grazing incidence, open meshes, degenerate triangles,
// more than 1,000 fragments in a pixel.
#include <random>

#include "hd/bvh.h"
#include "stability_util.h"

namespace stab {
namespace {

// ---- coincident faces ------------------------------------------------------

Scene two_quads(bool swap) {
  Scene s = scene_named("coincident quads");
  Object a = surface_object("a", make_quad(8, 8), at({0, 1, 0}), 0.3f);
  Object b = surface_object("b", make_quad(8, 8), at({0, 1, 0}), 0.6f);
  s.objects.push_back(swap ? b : a);
  s.objects.push_back(swap ? a : b);
  s.objects.push_back(surface_object("ground", make_quad(10, 10), at({0, 0, 0}), 1.0f, false));
  s.lights.push_back(spot_light({0, 4, 0}, {0, -1, 0}, 30, 25));
  s.shadows.epsilon = 0.001f;
  return s;
}

TEST(Coincident, TwoTranslucentQuadsAtEqualDepthCompositeIndependentOfOrder) {
  Rig ab(two_quads(false)), ba(two_quads(true));
  const float exact = 1.0f - 0.7f * 0.4f;
  for (Vec3 p : {Vec3{0, 0.5f, 0}, Vec3{0.4f, 0.2f, -0.3f}, Vec3{-0.7f, 0.01f, 0.6f}}) {
    EXPECT_NEAR(ab.alpha(p), exact, 1e-5f);
    EXPECT_NEAR(ba.alpha(p), exact, 1e-5f);
    EXPECT_NEAR(ab.alpha(p), ba.alpha(p), 1e-6f);
  }
  // Above the quads nothing; at the quads' own depth the light arriving there.
  EXPECT_EQ(ab.alpha({0, 1.5f, 0}), 0.0f);
  // One depth, the two objects' steps each with its own upper node (so each
  // quad can leave out its own, DESIGN.md §8): the same nodes but for the
  // order of the two layers, the same final opacity.
  std::vector<DsmNode> na = ab.texel_at(0, {0, 0.5f, 0}), nb = ba.texel_at(0, {0, 0.5f, 0});
  ASSERT_EQ(na.size(), nb.size());
  ASSERT_EQ(na.size(), 3u) << "one depth: the light before, then each quad's step";
  for (size_t i = 0; i < na.size(); ++i) EXPECT_EQ(na[i].z, na[0].z);
  EXPECT_EQ(na[0].alpha, 0.0f);
  EXPECT_NEAR(na[2].alpha, nb[2].alpha, 1e-6f);
  EXPECT_NEAR(na[2].alpha, exact, 1e-5f);
  EXPECT_TRUE(all_physical(ab));
  // The image too: same colour, so compositing order does not matter.
  Renderer r;
  Image ia = r.render(two_quads(false), cpu_options());
  Image ib = r.render(two_quads(true), cpu_options());
  ASSERT_TRUE(finite_image(ia));
  EXPECT_LT(max_abs_diff(ia, ib), 1e-5f);
}

Scene stacked_media(bool swap, bool identical) {
  Scene s = scene_named("touching media");
  // a: y in [0.5, 1.5], b: y in [1.5, 2.5] (sharing the face y = 1.5), or both the same box.
  Object a = medium_object("a", box_mesh({-1, 0.5f, -1}, {1, 1.5f, 1}), Mat4{}, 1.0f);
  Object b = medium_object(
      "b", identical ? box_mesh({-1, 0.5f, -1}, {1, 1.5f, 1}) : box_mesh({-1, 1.5f, -1}, {1, 2.5f, 1}), Mat4{}, 2.0f);
  s.objects.push_back(swap ? b : a);
  s.objects.push_back(swap ? a : b);
  s.lights.push_back(spot_light({0, 4, 0}, {0, -1, 0}, 30, 25));
  s.shadows.epsilon = 0.001f;
  return s;
}

TEST(Coincident, MediaSharingAFaceOrIdenticalBoxesAbsorbExactly) {
  const Vec3 L{0, 4, 0};
  for (bool identical : {false, true})
    for (bool swap : {false, true}) {
      Rig rig(stacked_media(swap, identical));
      for (Vec3 p : {Vec3{0, 0.2f, 0}, Vec3{0.3f, 0.1f, -0.2f}, Vec3{-0.25f, 0.3f, 0.3f}}) {
        float cos_t = (L.y - p.y) / length(p - L);
        float exact = 1.0f - std::exp(-3.0f / cos_t);  // a unit chord of each, along the ray
        EXPECT_NEAR(rig.alpha(p), exact, 0.001f + 2e-4f) << "identical " << identical << " swap " << swap;
        EXPECT_NEAR(1.0f - rig.reference_T(p), exact, 1e-4f);
      }
      for (const DsmBuildStats& st : rig.frame.map_stats) EXPECT_EQ(st.walk.unmatched, 0u);
      EXPECT_TRUE(all_physical(rig));
    }
}

// ---- rays exactly through shared edges and vertices (CPU producer) ----------

// A flat grid in the plane z = 0 facing +z, vertices every 0.25 (on the
// axes too), cells split along alternating diagonals.
TriangleMesh grid_mesh(int cells, float cell) {
  TriangleMesh m;
  float o = -0.5f * cells * cell;
  for (int j = 0; j <= cells; ++j)
    for (int i = 0; i <= cells; ++i) m.positions.push_back({o + i * cell, o + j * cell, 0});
  auto v = [&](int i, int j) { return uint32_t(j * (cells + 1) + i); };
  for (int j = 0; j < cells; ++j)
    for (int i = 0; i < cells; ++i) {
      if ((i + j) % 2 == 0)
        m.indices.insert(m.indices.end(),
                         {v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j), v(i + 1, j + 1), v(i, j + 1)});
      else
        m.indices.insert(m.indices.end(),
                         {v(i, j), v(i + 1, j), v(i, j + 1), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)});
    }
  return m;
}

// 41 x 41 pixels: the centre row and column have ray directions with an
// exactly zero y (x) component, so they cross edges on the axes exactly,
// and the centre ray goes exactly through the vertex at the origin.
PinholeView axis_view(Vec3 eye, Vec3 forward, Vec3 up) {
  return light_view(eye, forward, up, 0.45f, 41, 0, 0.01f, 100.0f);
}

TEST(SharedEdges, RaysThroughGridEdgesAndVerticesHitExactlyOnce) {
  Scene s = scene_named("grid");
  s.objects.push_back(surface_object("grid", grid_mesh(16, 0.25f), Mat4{}, 1.0f));
  SceneBuffers sb = compiled_scene(s);
  ViewCounts c = count_fragments(sb, axis_view({0, 0, 4}, {0, 0, -1}, {0, 1, 0}));
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) ASSERT_EQ(c.total(x, y), 1) << "pixel " << x << "," << y;
  // Seen from behind: still exactly once, now back-facing.
  c = count_fragments(sb, axis_view({0, 0, -4}, {0, 0, 1}, {0, 1, 0}));
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) ASSERT_EQ(c.back[size_t(y) * c.width + x], 1) << "pixel " << x << "," << y;
}

TEST(SharedEdges, ClosedMeshesThroughDiagonalsAndPolesEnterOnceExitOnce) {
  Scene s = scene_named("closed");
  s.objects.push_back(surface_object("box", make_box({2, 2, 2}), Mat4{}, 1.0f));
  SceneBuffers sb = compiled_scene(s);
  // The centre ray crosses the front and back faces exactly on their diagonals.
  ViewCounts c = count_fragments(sb, axis_view({0, 0, 4}, {0, 0, -1}, {0, 1, 0}));
  EXPECT_EQ(c.front[20 * 41 + 20], 1);
  EXPECT_EQ(c.back[20 * 41 + 20], 1);
  for (int i = 0; i < 41 * 41; ++i) ASSERT_EQ(c.front[size_t(i)], c.back[size_t(i)]) << "pixel " << i;

  Scene t = scene_named("sphere");
  t.objects.push_back(surface_object("sphere", make_sphere(1.0f, 24, 12), Mat4{}, 1.0f));
  SceneBuffers tb = compiled_scene(t);
  // Down the axis: the centre ray goes through both poles (24 triangles each).
  c = count_fragments(tb, axis_view({0, 4, 0}, {0, -1, 0}, {0, 0, -1}));
  EXPECT_EQ(c.front[20 * 41 + 20], 1);
  EXPECT_EQ(c.back[20 * 41 + 20], 1);
  for (int i = 0; i < 41 * 41; ++i) ASSERT_EQ(c.front[size_t(i)], c.back[size_t(i)]) << "pixel " << i;
}

TEST(SharedEdges, ConvexMeshesAreWatertightUnderRandomRotations) {
  std::mt19937 rng(12345);
  std::uniform_real_distribution<float> angle(0.0f, 360.0f);
  for (int k = 0; k < 12; ++k) {
    Scene s = scene_named("rotated");
    Vec3 r{angle(rng), angle(rng), angle(rng)};
    s.objects.push_back(surface_object("box", make_box({1.5f, 1, 0.7f}), at({0, 0, 0}, {1, 1, 1}, r), 1.0f));
    s.objects.push_back(surface_object("sphere", make_sphere(0.6f, 16, 8), at({0.9f, 0.2f, 0}, {1, 1, 1}, r), 1.0f));
    SceneBuffers sb = compiled_scene(s);
    PinholeView v = light_view({0.3f, 0.2f, 5}, {0, 0, -1}, {0, 1, 0}, 0.4f, 64, 0, 0.01f, 100.0f);
    for (uint32_t o = 0; o < 2; ++o) {
      ViewCounts c = count_fragments(sb, v, o);
      for (size_t i = 0; i < c.front.size(); ++i) {
        ASSERT_EQ(c.front[i], c.back[i]) << "rotation " << k << " object " << o << " pixel " << i;
        ASSERT_LE(c.front[i], 1) << "a convex mesh is entered at most once";
      }
    }
  }
}

// ---- grazing incidence ------------------------------------------------------

TEST(Grazing, LightGrazingAPlaneLeavesItLitAndFinite) {
  // The light 0.15 above the plane, 6 away: about 1.4 degrees of elevation.
  Scene s = scene_named("grazing plane");
  s.objects.push_back(surface_object("ground", make_quad(12, 12), Mat4{}, 1.0f));
  Vec3 L{-6, 0.15f, 0};
  s.lights.push_back(spot_light(L, Vec3{0, 0, 0} - L, 20, 15));
  s.camera.position = {1, 4, 4};
  s.shadows.resolution = 128;
  Renderer r;
  const ImagePair both = render_both(r, s);
  ASSERT_TRUE(both.finite);
  EXPECT_GT(both.psnr(), 40.0);  // the diffuse term fades with the incidence
  // The plane's own step must not shadow it: T = 1 on the lit plane, with the
  // lookup the camera pass makes (its plane, stopped short of its own step).
  Rig rig(s);
  ShadowView v = rig.view();
  DsmVisibility vis{v};
  double sum = 0.0;
  float worst = 1.0f;
  int n = 0;
  for (float x = -3; x <= 5; x += 0.25f)
    for (float z = -1.5f; z <= 1.5f; z += 0.25f) {
      Vec3 p{x, 0, z};
      if (cone_factor(v.lights[0], p) <= 0.0f) continue;
      float T = grey_of(vis(0, Receiver{p, {0, 1, 0}, 0u}));
      ASSERT_TRUE(std::isfinite(T) && T >= 0.0f && T <= 1.0f);
      sum += T;
      worst = std::min(worst, T);
      ++n;
    }
  ASSERT_GT(n, 100);
  EXPECT_GE(worst, 0.99f) << "a lit plane at grazing incidence shadows itself";
  EXPECT_GT(sum / n, 0.99);
}

TEST(Grazing, LightRaysInTheFacePlaneOfABoxStayMatched) {
  // The centre row of the light's view lies exactly in the plane of the
  // box's top face: edge-on triangles, rays through its edges.
  Scene s = scene_named("edge-on");
  s.objects.push_back(medium_object("box", box_mesh({-1, -1, -1}, {1, 0, 1}), Mat4{}, 2.0f, 0.2f));
  SceneBuffers sb = compiled_scene(s);
  ViewCounts c = count_fragments(sb, axis_view({-5, 0, 0}, {1, 0, 0}, {0, 1, 0}));
  for (size_t i = 0; i < c.front.size(); ++i) ASSERT_EQ(c.front[i], c.back[i]) << "pixel " << i;
  s.lights.push_back(spot_light({-5, 0, 0}, {1, 0, 0}, 25, 20));
  Rig rig(s);
  EXPECT_TRUE(all_physical(rig));
  // Just below the face: through the whole box (two surfaces of opacity 0.2, chord ~2).
  Vec3 p{1.5f, -0.05f, 0};
  EXPECT_NEAR(1.0f - rig.alpha(p), rig.reference_T(p), 0.03f);
  // Just above: nothing.
  EXPECT_NEAR(rig.alpha({1.5f, 0.2f, 0}), 0.0f, 1e-6f);
}

// ---- open meshes -------------------------------------------------------------

// The box [lo, hi] without the faces whose outward normal is +-y (`drop`: bit 0 = +y, bit 1 = -y).
TriangleMesh open_box(Vec3 lo, Vec3 hi, int drop) {
  TriangleMesh full = box_mesh(lo, hi), m;
  m.positions = full.positions;
  m.normals = full.normals;
  for (size_t t = 0; t < full.indices.size(); t += 3) {
    Vec3 n = full.normals[full.indices[t]];
    if ((drop & 1) && n.y > 0.5f) continue;
    if ((drop & 2) && n.y < -0.5f) continue;
    m.indices.insert(m.indices.end(), {full.indices[t], full.indices[t + 1], full.indices[t + 2]});
  }
  return m;
}

TEST(OpenMeshes, HaveNoInteriorAndDoNotLeaveTheRayInside) {
  Scene s = scene_named("open");
  // Open at the top: light from above crosses its bottom only; its "interior" is ignored.
  Object cup = medium_object("open box", open_box({-1, 1, -1}, {1, 2, 1}, 1), Mat4{}, 5.0f, 0.5f);
  ASSERT_FALSE(is_closed(*cup.mesh));
  s.objects.push_back(cup);
  // A closed absorber below it: still absorbs exactly (the walk is not left "inside").
  s.objects.push_back(medium_object("slab", box_mesh({-2, 0.2f, -2}, {2, 0.6f, 2}), Mat4{}, 1.5f));
  s.lights.push_back(spot_light({0, 5, 0}, {0, -1, 0}, 25, 20));
  s.shadows.epsilon = 0.001f;
  Rig rig(s);
  Vec3 L{0, 5, 0};
  for (Vec3 p : {Vec3{0, 0.8f, 0}, Vec3{0.3f, 0.0f, 0.2f}}) {
    float cos_t = (L.y - p.y) / length(p - L);
    float slab = p.y < 0.2f ? 0.4f / cos_t : 0.0f;
    float exact_T = 0.5f * std::exp(-1.5f * slab);
    EXPECT_NEAR(1.0f - rig.alpha(p), exact_T, 0.002f);
    EXPECT_NEAR(rig.reference_T(p), exact_T, 1e-4f);
  }
  EXPECT_TRUE(all_physical(rig));
  Renderer r;
  ASSERT_TRUE(finite_image(r.render(s, cpu_options())));
}

TEST(OpenMeshes, ATubeSeenSideOnAttenuatesTwice) {
  Scene s = scene_named("tube");
  s.objects.push_back(medium_object("tube", open_box({-0.5f, -1, -0.5f}, {0.5f, 1, 0.5f}, 3), Mat4{}, 4.0f, 0.5f));
  s.lights.push_back(spot_light({-5, 0, 0}, {1, 0, 0}, 20, 15));
  Rig rig(s);
  EXPECT_NEAR(rig.alpha({2, 0.1f, 0.05f}), 0.75f, 1e-5f);
  EXPECT_NEAR(rig.alpha({0, 0.1f, 0.05f}), 0.5f, 1e-5f) << "inside the tube: one wall crossed, no medium";
  EXPECT_TRUE(all_physical(rig));
}

// ---- degenerate triangles -----------------------------------------------------

TEST(Degenerate, ZeroAreaTrianglesAddNoFragmentsAndNoNaN) {
  TriangleMesh box = box_mesh({-1, -1, -1}, {1, 1, 1});
  TriangleMesh with = box;
  uint32_t n = uint32_t(with.positions.size());
  // Repeated index; repeated position (distinct vertices at one point).
  with.positions.push_back(with.positions[0]);
  with.normals.push_back({0, 0, 0});
  with.indices.insert(with.indices.end(), {0, 0, 1, 2, n, 2});
  Scene s = scene_named("degenerate");
  s.objects.push_back(medium_object("box", with, Mat4{}, 1.0f, 0.3f));
  // An object made of nothing but zero-area triangles.
  TriangleMesh dust;
  dust.positions = {{0, 3, 0}, {0, 3, 0}, {1, 3, 0}, {2, 3, 0}};
  dust.indices = {0, 1, 2, 0, 2, 3, 1, 1, 1};
  s.objects.push_back(surface_object("dust", dust, Mat4{}, 1.0f));
  s.lights.push_back(spot_light({0, 5, 0.01f}, {0, -1, 0}, 30, 25));
  ASSERT_TRUE(is_closed(with)) << "zero-area triangles do not open a mesh";
  SceneBuffers sb = compiled_scene(s);
  for (const Vec3& nrm : sb.tri_normals) ASSERT_TRUE(is_finite(nrm));
  Scene plain = scene_named("plain");
  plain.objects.push_back(medium_object("box", box, Mat4{}, 1.0f, 0.3f));
  SceneBuffers pb = compiled_scene(plain);
  PinholeView v = axis_view({0, 4, 0}, {0, -1, 0}, {0, 0, -1});
  ViewCounts a = count_fragments(sb, v), b = count_fragments(pb, v);
  EXPECT_EQ(a.front, b.front);
  EXPECT_EQ(a.back, b.back);
  Rig rig(s);
  Vec3 p{0.1f, -1.5f, 0.1f};
  EXPECT_NEAR(1.0f - rig.alpha(p), rig.reference_T(p), 0.01f);
  EXPECT_TRUE(all_physical(rig));
  Renderer r;
  ASSERT_TRUE(finite_image(r.render(s, cpu_options())));
}

TEST(Degenerate, CollinearSliverKeepsAClosedMeshClosed) {
  // Three distinct, collinear vertices on a face: zero area, but its edges
  // have no partners, and is_closed() calls the box open — dropping its medium.
  TriangleMesh with = box_mesh({-1, -1, -1}, {1, 1, 1});
  uint32_t n = uint32_t(with.positions.size());
  with.positions.insert(with.positions.end(), {{-0.5f, 1, 0}, {0, 1, 0}, {0.5f, 1, 0}});
  with.normals.insert(with.normals.end(), {{0, 1, 0}, {0, 1, 0}, {0, 1, 0}});
  with.indices.insert(with.indices.end(), {n, n + 1, n + 2});
  ASSERT_TRUE(is_closed(with)) << "a collinear sliver must not open a closed mesh";
  Scene s = scene_named("sliver");
  s.objects.push_back(medium_object("box", with, Mat4{}, 1.0f));
  s.lights.push_back(spot_light({0, 5, 0}, {0, -1, 0}, 30, 25));
  Rig rig(s);
  EXPECT_NEAR(rig.alpha({0, -1.5f, 0}), 1.0f - std::exp(-2.0f), 0.02f);
}

// ---- more than 1,000 fragments in a pixel --------------------------------------

TEST(ManyFragments, OverAThousandLayersInALightTexel) {
  // 1,200 layers on every light ray; every 100th is a 0.05 pane, the rest
  // invisible (opacity 0): sorting and walking 1,200 fragments, 24 nodes.
  const int layers = 1200;
  Scene s = scene_named("light stack");
  TriangleMesh quad = make_quad(3, 3);
  for (int i = 0; i < layers; ++i)
    s.objects.push_back(
        surface_object("layer", quad, at({0, 1.0f + 0.0005f * float(i), 0}), i % 100 == 0 ? 0.05f : 0.0f));
  s.lights.push_back(spot_light({0, 5, 0}, {0, -1, 0}, 15, 10));
  s.shadows.resolution = 16;
  s.shadows.epsilon = 0.001f;
  Rig rig(s);
  ViewCounts c = count_fragments(rig.sb, rig.frame.setup.maps[0].view);
  EXPECT_EQ(c.total(8, 8), layers) << "every layer once, none doubled";
  EXPECT_NEAR(rig.alpha({0.05f, 0.5f, 0.05f}), 1.0f - std::pow(0.95f, 12.0f), 1e-5f);
  EXPECT_NEAR(rig.alpha({0.05f, 1.0f + 0.0005f * 650.0f, 0.05f}), 1.0f - std::pow(0.95f, 5.0f), 1e-5f);
  EXPECT_EQ(rig.overflow_texels(), 0u);
  EXPECT_TRUE(all_physical(rig));
}

TEST(ManyFragments, OverAThousandTranslucentLayersOverflowTheTexelBufferSafely) {
  // 1,200 panes of opacity 0.001: 2,400 step nodes for a 1,024-node buffer.
  ASSERT_LE(probe_step_overflow(), 16) << "the node buffer must never write past its capacity";
  const int layers = 1200;
  Scene s = scene_named("translucent stack");
  TriangleMesh quad = make_quad(3, 3);
  for (int i = 0; i < layers; ++i)
    s.objects.push_back(surface_object("layer", quad, at({0, 1.0f + 0.0005f * float(i), 0}), 0.001f));
  s.lights.push_back(spot_light({0, 5, 0}, {0, -1, 0}, 15, 10));
  s.shadows.resolution = 16;
  s.shadows.epsilon = 0.01f;
  Rig rig(s);
  float extra = 0.0f;
  for (const DsmBuildStats& st : rig.frame.map_stats) extra = std::max(extra, st.max_extra_error);
  EXPECT_GT(rig.overflow_texels(), 0u) << "re-compressed, and counted";
  EXPECT_GT(extra, 0.0f) << "the extra error is recorded";
  // Below every layer the function's last node holds: node removal keeps
  // it, so the answer is exact up to eps and float accumulation.
  EXPECT_NEAR(rig.alpha({0.05f, 0.5f, 0.05f}), 1.0f - std::pow(0.999f, float(layers)), 0.01f + 1e-4f);
  EXPECT_LT(extra, 0.1f) << "1,200 equal steps into 1,024 nodes change the function little";
  EXPECT_TRUE(all_physical(rig));
}

TEST(ManyFragments, OverAThousandLayersInAPixelCompositeExactly) {
  // 1,200 white layers of opacity 0.001 lit by the ambient term only, on black:
  // the pixel is 1 - 0.999^1200 (front-to-back compositing, no early stop).
  const int layers = 1200;
  Scene s = scene_named("pixel stack");
  TriangleMesh quad = make_quad(3, 3);
  for (int i = 0; i < layers; ++i) {
    Object o = surface_object("layer", quad, at({0, 1.0f + 0.0005f * float(i), 0}), 0.001f);
    o.surface.color = {1, 1, 1};
    o.surface.ambient = 1.0f;
    o.surface.diffuse = o.surface.specular = 0.0f;
    s.objects.push_back(o);
  }
  s.background = {0, 0, 0};
  s.shadows.ambient_light = {1, 1, 1};
  s.camera.position = {0, 4, 0};
  s.camera.target = {0, 0, 0};
  s.camera.up = {0, 0, -1};
  s.camera.width = s.camera.height = 9;
  Renderer r;
  RenderOptions o = cpu_options();
  FrameStats st;
  Image img = r.render(s, o, &st);
  ASSERT_TRUE(finite_image(img));
  EXPECT_EQ(st.camera_fragments, uint64_t(layers) * 81);
  const float exact = 1.0f - std::pow(0.999f, float(layers));
  EXPECT_NEAR(pixel(img, 4, 4).x, exact, 1e-4f);
  EXPECT_NEAR(pixel(r.render_reference(s, o), 4, 4).x, exact, 1e-4f);
}

// ---- extreme coordinates in the BVH (issue "Reliability") -------------------------

// The teapot's triangles placed straight into the scene's arrays at scales
// the compile refuses or that sit at the ends of float's range (1e-30,
// 1e-45 denormals, 3e38, everything at one point): the BVH builder's binning
// and the traversal never index out of bounds (ASan checks it in the
// sanitizer build), every triangle is in exactly one leaf, and the
// traversal stays finite.
TEST(Degenerate, ExtremeCoordinatesBuildAValidBvh) {
  const TriangleMesh pot = make_newell_mesh(content_dir() + "/meshes/newell/teapot", 6);
  for (float scale : {1e-30f, 1e-45f, 3e38f / 4.0f, 0.0f, 1.0f}) {
    SceneBuffers sb;
    ObjectData od{};
    od.opacity = 1.0f;
    od.volume = -1;
    od.flags = kObjCastsShadows;
    od.tri_count = uint32_t(pot.triangle_count());
    sb.objects.push_back(od);
    for (size_t t = 0; t < pot.triangle_count(); ++t) {
      for (int k = 0; k < 3; ++k) {
        Vec3 p = pot.positions[pot.indices[3 * t + size_t(k)]] * scale;
        sb.tri_vertices.push_back(p);
        sb.tri_normals.push_back({0, 1, 0});
      }
      sb.tri_object.push_back(0);
    }
    build_bvh(sb);
    // Every triangle in exactly one leaf.
    std::vector<int> seen(pot.triangle_count(), 0);
    for (const BvhNode& n : sb.bvh)
      for (uint32_t i = 0; i < n.count; ++i) ++seen.at(sb.bvh_prims.at(n.first + i));
    for (size_t t = 0; t < seen.size(); ++t) ASSERT_EQ(seen[t], 1) << "scale " << scale << " triangle " << t;
    for (const BvhNode& n : sb.bvh)
      if (n.count == 0) {
        ASSERT_LT(n.first, sb.bvh.size()) << "scale " << scale;
      }
    // Traversal: a ray through the middle returns (finite depths only).
    SceneView sv = sb.view();
    int hits = 0;
    bool complete = for_each_hit(sv, ObjectMask{}, Vec3{0.05f, 1.2f, -10.0f} * scale,
                                 normalize(Vec3{0.01f, 0.02f, 1.0f}), 0.0f, 3e38f, [&](uint32_t, const TriHit& h) {
                                   EXPECT_TRUE(std::isfinite(h.t));
                                   ++hits;
                                 });
    EXPECT_TRUE(complete) << "scale " << scale;
    if (scale == 1.0f) {
      EXPECT_GE(hits, 2);
    }
  }
}

}  // namespace
}  // namespace stab
