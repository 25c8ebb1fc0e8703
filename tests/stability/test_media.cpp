// Stability with participating media: the camera inside an object and
// inside a volume, a light inside a volume, a very dense volume, a slab
// thinner than the march step, and a depth range of 1e-3 .. 1e5.
#include "stability_util.h"

namespace stab {
namespace {

// Distance from the origin to the boundary of the cube [-h, h]^3 along unit d.
float exit_distance(Vec3 d, float h) {
  float t = 3.0e38f;
  for (int a = 0; a < 3; ++a)
    if (d[a] != 0.0f) t = std::fmin(t, h / std::fabs(d[a]));
  return t;
}

// ---- the camera inside an object or a volume ----------------------------------

TEST(CameraInside, AConstantMediumAttenuatesTheBackgroundFromTheEye) {
  Scene s = scene_named("camera in medium");
  s.objects.push_back(medium_object("fog box", box_mesh({-5, -5, -5}, {5, 5, 5}), Mat4{}, 0.2f));
  s.camera.position = {0, 0, 0};
  s.camera.target = {0, 0, -1};
  s.camera.near = 0.05f;
  s.background = {0.5f, 0.5f, 0.5f};
  Renderer r;
  Image img = r.render(s, cpu_options());
  ASSERT_TRUE(finite_image(img));
  PinholeView v = camera_view(s.camera);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      float expect = 0.5f * std::exp(-0.2f * exit_distance(pixel_ray(v, x, y), 5.0f));
      ASSERT_NEAR(pixel(img, x, y).x, expect, 1e-3f * expect) << "pixel " << x << "," << y;
    }
}

TEST(CameraInside, TheReferenceAttenuatesFromTheEyeToo) {
  Scene s = scene_named("camera in medium (reference)");
  s.objects.push_back(medium_object("fog box", box_mesh({-5, -5, -5}, {5, 5, 5}), Mat4{}, 0.2f));
  s.camera.position = {0, 0, 0};
  s.camera.target = {0, 0, -1};
  s.camera.near = 0.5f;  // large enough to tell eye from near plane apart
  s.background = {0.5f, 0.5f, 0.5f};
  Renderer r;
  Image ref = r.render_reference(s, cpu_options());
  ASSERT_TRUE(finite_image(ref));
  PinholeView v = camera_view(s.camera);
  int cx = s.camera.width / 2, cy = s.camera.height / 2;
  float expect = 0.5f * std::exp(-0.2f * exit_distance(pixel_ray(v, cx, cy), 5.0f));
  float got = pixel(ref, cx, cy).x;
  EXPECT_NEAR(got, expect, 1e-3f * expect) << "the reference absorbs from the eye, not the near plane";
}

TEST(CameraInside, AnOpaqueClosedObjectAroundCameraAndLightIsLitInside) {
  Scene s = scene_named("camera in box");
  s.objects.push_back(surface_object("room", box_mesh({-3, -3, -3}, {3, 3, 3}), Mat4{}, 1.0f));
  s.objects.push_back(surface_object("block", make_box({0.6f, 0.6f, 0.6f}), at({0.5f, -2.7f, -1}), 1.0f));
  s.lights.push_back(point_light({0.2f, 1.5f, 0.3f}));
  s.camera.position = {0, 0, 2};
  s.camera.target = {0, -1, -1};
  s.shadows.resolution = 128;
  Renderer r;
  const ImagePair both = render_both(r, s);
  ASSERT_TRUE(both.finite);
  EXPECT_GT(both.psnr(), 30.0);
  TransmittanceError te = r.transmittance_error(s, cpu_options());
  EXPECT_GT(te.points, 0u);
  EXPECT_LT(te.mean, 0.05);
}

TEST(CameraInside, AVolumeEmitsAndAbsorbsFromTheEye) {
  // Ambient light only: every sample scatters albedo x ambient, so a pixel is
  // albedo (1 - T) + background T with T = exp(-sigma L) to the fog's wall.
  Scene s = scene_named("camera in volume");
  const float sigma = 0.3f, albedo = 0.8f;
  add_uniform_volume(s, "fog", {-5, -5, -5}, {5, 5, 5}, sigma, box_mesh({-5, -5, -5}, {5, 5, 5}), 16,
                     {albedo, albedo, albedo});
  s.camera.position = {0, 0, 0};
  s.camera.target = {0, -0.3f, -1};
  s.camera.near = 1e-3f;
  s.background = {0.2f, 0.2f, 0.2f};
  s.shadows.ambient_light = {1, 1, 1};
  Renderer r;
  RenderOptions o = cpu_options();
  Image img = r.render(s, o);
  ASSERT_TRUE(finite_image(img));
  PinholeView v = camera_view(s.camera);
  for (int y = 0; y < img.height; y += 3)
    for (int x = 0; x < img.width; x += 3) {
      float T = std::exp(-sigma * exit_distance(pixel_ray(v, x, y), 5.0f));
      ASSERT_NEAR(pixel(img, x, y).x, albedo * (1.0f - T) + 0.2f * T, 2e-3f) << "pixel " << x << "," << y;
    }
  // With a light and a shadow caster inside the fog too, against the reference.
  s.objects.push_back(surface_object("block", make_box({1, 1, 1}), at({0, -1.5f, -2.5f}), 1.0f));
  s.lights.push_back(point_light({1.5f, 2, -1}));
  s.shadows.resolution = 96;
  img = r.render(s, o);
  ASSERT_TRUE(finite_image(img));
  EXPECT_GT(compare_images(img, r.render_reference(s, o)).psnr, 30.0);
}

// ---- a light inside a volume / a medium -----------------------------------------

TEST(LightInside, PointLightInAVolumeSeesExponentialOpacityInEveryFace) {
  Scene s = scene_named("light in volume");
  add_uniform_volume(s, "fog", {-2, -2, -2}, {2, 2, 2}, 0.3f, box_mesh({-2, -2, -2}, {2, 2, 2}), 32);
  s.lights.push_back(point_light({0, 0, 0}));
  s.shadows.epsilon = 0.001f;
  s.shadows.resolution = 32;
  Rig rig(s);
  for (Vec3 d : {Vec3{1, 0, 0}, Vec3{-1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, -1, 0}, Vec3{0, 0, 1}, Vec3{0, 0, -1},
                 normalize(Vec3{1, 1, 1}), normalize(Vec3{-1, 0.5f, -0.3f})}) {
    for (float dist : {0.4f, 1.2f, 1.9f}) {
      Vec3 p = d * dist;
      float exact = 1.0f - std::exp(-0.3f * dist);
      EXPECT_NEAR(rig.alpha(p), exact, 0.001f + 1e-3f) << "direction " << d.x << "," << d.y << "," << d.z;
      EXPECT_NEAR(1.0f - rig.reference_T(p), exact, 1e-4f);
    }
  }
  EXPECT_TRUE(all_physical(rig));
}

TEST(LightInside, PointLightInAConstantMedium) {
  Scene s = scene_named("light in medium");
  s.objects.push_back(medium_object("fog", box_mesh({-2, -2, -2}, {2, 2, 2}), Mat4{}, 0.5f));
  s.lights.push_back(point_light({0.1f, -0.2f, 0.05f}));
  s.shadows.epsilon = 0.001f;
  s.shadows.resolution = 32;
  Rig rig(s);
  Vec3 L = s.lights[0].position;
  for (Vec3 p : {Vec3{1.5f, 0, 0}, Vec3{0, 1.7f, 0.2f}, Vec3{-1, -1, 1}, Vec3{0.2f, 0.1f, -1.8f}}) {
    float exact = 1.0f - std::exp(-0.5f * length(p - L));
    EXPECT_NEAR(rig.alpha(p), exact, 0.001f + 2e-4f);
  }
  // Outside the box: the chord to its face only.
  Vec3 far{3.5f, -0.2f, 0.05f};
  EXPECT_NEAR(rig.alpha(far), 1.0f - std::exp(-0.5f * (2.0f - 0.1f)), 0.0015f);
  EXPECT_TRUE(all_physical(rig));
}

// ---- a very dense volume ----------------------------------------------------------

TEST(Dense, SaturatingMediaStayMonotoneFiniteAndTerminateEarly) {
  for (float sigma : {1e6f, 1e30f}) {
    Scene s = scene_named("dense");
    s.objects.push_back(medium_object("wall", box_mesh({-2, 1, -2}, {2, 1.5f, 2}), Mat4{}, sigma));
    add_uniform_volume(s, "ink", {-2, 2, -2}, {2, 2.5f, 2}, sigma, box_mesh({-2, 2, -2}, {2, 2.5f, 2}), 16);
    s.lights.push_back(spot_light({0, 5, 0}, {0, -1, 0}, 20, 15));
    Rig rig(s);
    EXPECT_TRUE(all_physical(rig)) << "sigma " << sigma;
    std::vector<DsmNode> n = rig.texel_at(0, {0, 0, 0});
    ASSERT_FALSE(n.empty());
    EXPECT_GE(n.back().alpha, kSaturatedAlpha);
    EXPECT_LE(n.size(), 4u) << "a saturated ray ends early";
    EXPECT_NEAR(rig.alpha({0.1f, 0.5f, 0.1f}), 1.0f, 1e-4f);
    EXPECT_EQ(rig.alpha({0.1f, 3.0f, 0.1f}), 0.0f);
    for (const DsmBuildStats& st : rig.frame.map_stats) EXPECT_LE(st.max_nodes, 4u);
    Renderer r;
    ASSERT_TRUE(finite_image(r.render(s, cpu_options())));
  }
}

// ---- a slab thinner than the march step ------------------------------------------

TEST(ThinSlab, AbsorptionIsExactBelowTheMarchStep) {
  const float sigma = 50.0f, thick = 0.004f;
  Scene s = scene_named("thin slab");
  // The grid's voxels are 0.25 wide (march step 0.125); the bounding slab is 0.004 thick.
  add_uniform_volume(s, "sheet", {-2, -1, -2}, {2, 1, 2}, sigma, box_mesh({-2, 0, -2}, {2, thick, 2}), 8);
  s.objects.push_back(medium_object("film", box_mesh({-2, -0.5f, -2}, {2, -0.5f + 1e-4f, 2}), Mat4{}, 1000.0f));
  s.lights.push_back(spot_light({0, 5, 0}, {0, -1, 0}, 20, 15));
  s.shadows.epsilon = 0.0f;
  Rig rig(s);
  // Straight below the light: chords exactly `thick` and 1e-4.
  EXPECT_NEAR(rig.alpha({0, -0.25f, 0}), 1.0f - std::exp(-sigma * thick), 1e-3f);
  EXPECT_NEAR(rig.alpha({0, -1, 0}), 1.0f - std::exp(-sigma * thick - 1000.0f * 1e-4f), 1e-3f);
  // The camera straight above, black albedo: the centre pixel is background x T.
  s.lights.clear();
  s.objects.pop_back();
  s.camera.position = {0, 3, 0};
  s.camera.target = {0, 0, 0};
  s.camera.up = {0, 0, -1};
  s.camera.width = s.camera.height = 33;
  s.background = {1, 1, 1};
  Renderer r;
  RenderOptions o = cpu_options();
  float expect = std::exp(-sigma * thick);
  EXPECT_NEAR(pixel(r.render(s, o), 16, 16).x, expect, 1e-3f);
  EXPECT_NEAR(pixel(r.render_reference(s, o), 16, 16).x, expect, 1e-3f);
}

// ---- depth range near = 1e-3, far = 1e5 ----------------------------------------------

TEST(DepthRange, RadialDepthResolvesMillimetresNextToTenKilometres) {
  Scene s = scene_named("depth range");
  s.objects.push_back(surface_object("upper", make_quad(4, 4), at({0, 5, 0}), 0.5f));
  s.objects.push_back(surface_object("lower", make_quad(4, 4), at({0, 5 - 1e-3f, 0}), 0.5f));
  s.objects.push_back(surface_object("far ground", make_quad(3e4f, 3e4f), at({0, -1e4f, 0}), 1.0f));
  s.lights.push_back(spot_light({0, 10, 0}, {0, -1, 0}, 30, 25));
  s.camera.position = {3, 7, 3};
  s.camera.target = {0, 5, 0};
  s.camera.near = 1e-3f;
  s.camera.far = 1e5f;
  s.shadows.epsilon = 0.001f;
  s.shadows.resolution = 129;  // odd: the centre texel's ray is the axis
  s.shadows.filtering = false;
  {
    Rig rig(s);
    ASSERT_GT(rig.frame.setup.maps[0].view.far, 1e4f);
    EXPECT_NEAR(rig.alpha({0, 5 - 0.5e-3f, 0}), 0.5f, 1e-5f) << "between the two quads, 1 mm apart, 5 from the light";
    EXPECT_NEAR(rig.alpha({0, 5 + 0.5e-3f, 0}), 0.0f, 1e-5f);
    EXPECT_NEAR(rig.alpha({0, 4.9f, 0}), 0.75f, 1e-5f);
    EXPECT_NEAR(rig.alpha({0, -1e4f + 1.0f, 0}), 0.75f, 1e-5f) << "10 km below";
    std::vector<DsmNode> n = rig.texel(0, 64, 64);
    ASSERT_GE(n.size(), 4u);
    EXPECT_NEAR(n[2].z - n[0].z, 1e-3f, 2e-6f) << "the steps keep their 1 mm";
    EXPECT_TRUE(all_physical(rig));
  }
  s.shadows.filtering = true;
  Renderer r;
  RenderOptions o = cpu_options();
  Image img = r.render(s, o);
  ASSERT_TRUE(finite_image(img));
  // Shadow edges on the far ground are blurred over texels ~90 units wide.
  EXPECT_GT(compare_images(img, r.render_reference(s, o)).psnr, 28.0);
  // The far ground (1e4 away) is drawn, not clipped.
  int drawn = 0;
  for (int x = 0; x < img.width; ++x) drawn += pixel(img, x, img.height - 1).x != s.background.x;
  EXPECT_GT(drawn, 0);
}

}  // namespace
}  // namespace stab
