// Receivers and their own surface (issue "Shadows that are right where they
// should be"): the error probe records the camera pass's own lookups; volume
// samples and receive-only surfaces look up at their exact depth (no bias);
// casters do not shadow themselves head-on or at grazing light; a
// translucent caster 1 mm above a receive-only ground shadows it.
#include <gtest/gtest.h>

#include <cstring>

#include <cstdio>
#include <random>
#include <vector>

#include "cdsm/loaders.h"
#include "cluster/light_views.h"
#include "scene/fragments.h"
#include "reference/lookup_recorder.h"
#include "reference/reference.h"
#include "unit_util.h"

using namespace cdsm;
using namespace cdsm_test;

namespace {

// The camera pass's lookups over every `step`-th pixel, through `vis`.
template <class Visibility>
std::vector<RecordedLookup> camera_lookups(const Scene& scene, const SystemFrame& b, const Visibility& vis, int step) {
  SceneView sv = b.sb.view();
  ShadowView shv = b.view(scene);
  std::vector<uint32_t> inside;
  const CameraPassParams cam = camera_pass_params(scene, sv, inside);
  FragmentBuffers fb;
  cast_fragments(sv, cam.view, ObjectMask{}, fb);
  FragmentLists lists = fb.lists();
  std::vector<RecordedLookup> out;
  WalkStats ws;
  for (int py = step / 2; py < cam.view.height; py += step)
    for (int px = step / 2; px < cam.view.width; px += step)
      record_pixel_lookups(sv, shv.lights, vis, cam, lists.pixel(px, py), px, py, out, ws);
  return out;
}

double mean_error(const std::vector<RecordedLookup>& ls, const ReferenceRenderer& ref) {
  double se = 0, sw = 0;
  for (const RecordedLookup& l : ls) {
    se += l.weight * std::fabs(double(grey_of(l.transmittance)) - grey_of(ref.transmittance(l.light, l.at)));
    sw += l.weight;
  }
  return sw > 0 ? se / sw : 0.0;
}

// A dense 24^3 cube of density 1 shaded as Phong (a CT-like volume), lit
// from above at an angle, over a receive-only ground.
Scene phong_volume_scene() {
  Scene s = empty_scene("phong volume");
  s.camera.width = 96;
  s.camera.height = 72;
  s.camera.position = {2.2f, 1.6f, 2.6f};
  s.camera.target = {0, 0.4f, 0};
  auto g = std::make_shared<DenseGrid>();
  g->nx = g->ny = g->nz = 24;
  g->values.assign(24 * 24 * 24, 0.0f);
  for (int z = 4; z < 20; ++z)
    for (int y = 4; y < 20; ++y)
      for (int x = 4; x < 20; ++x) g->values[size_t((z * 24 + y) * 24 + x)] = 1.0f;
  Volume v;
  v.name = "cube";
  v.grid = g;
  const float voxel = 0.04f;
  v.index_to_object.m[0][0] = v.index_to_object.m[1][1] = v.index_to_object.m[2][2] = voxel;
  v.index_to_object.m[0][3] = v.index_to_object.m[2][3] = -12.0f * voxel;
  v.index_to_object.m[1][3] = 0.0f;
  v.transfer = {TransferPoint{0.0f, vec3(0.0f), {1, 1, 1}}, TransferPoint{1.0f, vec3(6.0f), {1, 1, 1}}};
  v.shading = VolumeShading::Phong;
  s.volumes.push_back(v);
  Object cube;
  cube.name = "cube";
  cube.interior = InteriorKind::Volume;
  cube.volume = 0;
  cube.mesh = share(make_volume_proxy(s.volumes[0]));
  cube.surface.opacity = 0.0f;
  s.objects.push_back(cube);
  Object ground = surface_object("ground", make_ground(6, 6, 0.05f));
  ground.casts_shadows = false;
  s.objects.push_back(ground);
  s.lights.push_back(spot_light({1.5f, 4.0f, 0.8f}, {-1.5f, -3.6f, -0.8f}, 35, 30));
  s.shadows.resolution = 256;
  s.shadows.epsilon = 0.01f;
  return s;
}

// The camera pass with a volume-sample bias (the defect this issue fixed:
// Phong volume samples took the surface bias): volume samples looked up
// 5 cm short of their depth.
struct VolumeBiasedVisibility {
  const ShadowView& sv;
  Vec3 operator()(int light, const Receiver& r) const {
    if (dot(r.plane, r.plane) > 0.0f) return DsmVisibility{sv}(light, r);
    const Vec3 to_light = normalize(sv.lights[uint32_t(light)].position - r.p);
    return one_minus(shadow_alpha(sv, sv.lights[uint32_t(light)], r.p + to_light * 0.05f));
  }
};

}  // namespace

// Item 1 and 2: no lookup of that scene is biased (volume samples, Phong
// ones included, and the receive-only ground look up at their depth), and
// breaking the camera pass's classification on purpose moves the probe's
// figures — the probe measures the lookups the image makes.
TEST(Receivers, ProbeRecordsTheCameraPassLookupsAndVolumesAreUnbiased) {
  Scene scene = phong_volume_scene();
  const ProbedFrame b(scene);
  std::vector<RecordedLookup> ls = camera_lookups(scene, b, b.vis, 2);
  ASSERT_GT(ls.size(), 500u);
  // Volume samples (Phong ones have a gradient normal: for shading only)
  // have no plane; the receive-only ground has its plane and no own step.
  size_t volume = 0, ground = 0, wrong = 0;
  for (const RecordedLookup& l : ls) {
    const bool on_ground = std::fabs(l.at.p.y) < 1e-4f;
    const bool plane = dot(l.at.plane, l.at.plane) > 0.0f;
    volume += !on_ground;
    ground += on_ground;
    wrong += l.at.object != kNoObject || plane != on_ground;
  }
  EXPECT_GT(volume, 200u);
  EXPECT_GT(ground, 200u);
  EXPECT_EQ(wrong, 0u) << "of " << ls.size() << " lookups";
  // Each recorded value is the functor's answer at the recorded arguments.
  for (size_t i = 0; i < ls.size(); i += 97) {
    const Vec3 again = b.vis(ls[i].light, ls[i].at);
    EXPECT_EQ(std::memcmp(&ls[i].transmittance, &again, sizeof again), 0);
  }

  ReferenceRenderer ref(b.sb.view(), b.frame.setup.lights);
  const double good = mean_error(ls, ref);
  VolumeBiasedVisibility broken{b.sv};
  const double moved = mean_error(camera_lookups(scene, b, broken, 2), ref);
  std::printf("phong volume: mean |dT| %.5f at the exact depth, %.5f with a volume-sample bias\n", good, moved);
  EXPECT_LT(good, 0.01);
  EXPECT_GT(moved, 3.0 * good + 0.002) << "the probe must see what the camera pass does";
}

// Item 3(b): an unoccluded lit caster plane does not shadow itself, head-on
// (the constant bias applies at tan = 0 too) up to 85 degrees incidence.
TEST(Receivers, NoAcneOnALitCasterPlaneFromHeadOnTo85Degrees) {
  for (int res : {128, 512, 2048}) {
    for (float deg : {0.0f, 30.0f, 60.0f, 75.0f, 85.0f}) {
      Scene s = empty_scene("plane");
      Object plane = surface_object("plane", make_quad(4, 4));  // y = 0, facing +y
      s.objects.push_back(plane);
      const float a = deg * 3.14159265f / 180.0f;
      const Vec3 pos{0.0f, 6.0f * std::cos(a), 6.0f * std::sin(a)};
      s.lights.push_back(spot_light(pos, -pos, 40, 38));
      s.shadows.resolution = res;
      const ProbedFrame b(s);
      const LightData& L = b.sv.lights[0];
      float worst = 0.0f;
      int n = 0;
      for (float x = -1.9f; x <= 1.9f; x += 0.05f)
        for (float z = -1.9f; z <= 1.9f; z += 0.05f) {
          const Vec3 p{x, 0.0f, z};
          if (cone_factor(L, p) <= 0.0f) continue;
          worst = std::max(worst, std::fabs(1.0f - grey_of(b.vis(0, Receiver{p, {0, 1, 0}, 0u}))));
          ++n;
        }
      EXPECT_GT(n, 100) << res << " " << deg;
      EXPECT_LE(worst, 1e-3f) << "self-shadowing at " << res << "^2, " << deg << " degrees incidence";
    }
  }
}

// Item 3(c): a lone translucent quad, fully lit, is not shadowed by itself.
TEST(Receivers, LoneTranslucentQuadIsLitOnItself) {
  Scene s = empty_scene("quad");
  s.objects.push_back(surface_object("quad", make_quad(2, 2), translation({0, 0.5f, 0}), 0.6f));
  s.lights.push_back(spot_light({0.5f, 4, 1}, {-0.5f, -3.5f, -1}, 30, 28));
  s.shadows.resolution = 512;
  const ProbedFrame b(s);
  float worst = 0.0f;
  for (float x = -0.95f; x <= 0.95f; x += 0.05f)
    for (float z = -0.95f; z <= 0.95f; z += 0.05f) {
      const Vec3 p{x, 0.5f, z};
      worst = std::max(worst, std::fabs(1.0f - grey_of(b.vis(0, Receiver{p, {0, 1, 0}, 0u}))));
    }
  EXPECT_LE(worst, 1e-3f);
}

// The translucent glass box resting 1 mm above a ground (receive-only or a
// casting slab), a spot light above, a camera looking down at them.
Scene box_over_ground(bool ground_casts) {
  Scene s = empty_scene(ground_casts ? "box over slab" : "box over ground");
  s.camera.width = 160;
  s.camera.height = 120;
  s.camera.position = {0.0f, 3.0f, 2.0f};
  s.camera.target = {0.0f, 0.0f, 0.0f};
  s.objects.push_back(surface_object("glass", make_box({0.6f, 0.6f, 0.6f}), translation({0, 0.301f, 0}), 0.35f));
  Object ground = surface_object("ground", make_ground(6, 6, 0.05f));
  ground.casts_shadows = ground_casts;
  s.objects.push_back(ground);
  s.lights.push_back(spot_light({1.0f, 5.0f, 0.6f}, {-1.0f, -5.0f, -0.6f}, 30, 26));
  s.shadows.resolution = 512;
  return s;
}

// Whether a ground point's light ray crosses the box's bottom face at least
// 2 cm inside its edges.
bool under_the_box(const LightData& L, Vec3 p) {
  const Vec3 d = normalize(L.position - p);
  const Vec3 q = p + d * (0.001f / d.y);
  return std::fabs(q.x) < 0.28f && std::fabs(q.z) < 0.28f;
}

// Item 3(a): the glass box resting 1 mm above a ground shadows it, whether
// the ground casts no shadow (it looks up at its plane, no offset) or is a
// slab in the maps itself (its own step lies on its plane; the box's bottom
// face 1 mm in front must still count). Before, the receiver's bias reached
// past the bottom face. The camera pass's own lookups on the ground: within
// the box's footprint, and on lit ground 3 cm or more from its shadow
// (the slab must not shadow itself).
TEST(Receivers, TranslucentBoxOneMillimetreAboveTheGround) {
  for (bool casts : {false, true}) {
    Scene s = box_over_ground(casts);
    const ProbedFrame b(s);
    const LightData& L = b.sv.lights[0];
    double sum = 0.0, worst = 0.0, lit_worst = 0.0;
    int n = 0, lit = 0;
    for (const RecordedLookup& l : camera_lookups(s, b, b.vis, 1)) {
      if (std::fabs(l.at.p.y) > 1e-3f) continue;  // the ground's top face
      const double e = std::fabs(double(grey_of(l.transmittance)) - grey_of(b.ref.transmittance(l.light, l.at)));
      if (under_the_box(L, l.at.p)) {
        sum += e;
        worst = std::max(worst, e);
        ++n;
        continue;
      }
      bool in_light = true;
      for (Vec3 o : {Vec3{0, 0, 0}, Vec3{0.03f, 0, 0}, Vec3{-0.03f, 0, 0}, Vec3{0, 0, 0.03f}, Vec3{0, 0, -0.03f}})
        in_light =
            in_light && grey_of(b.ref.transmittance(l.light, Receiver{l.at.p + o, l.at.plane, l.at.object})) >= 1.0f;
      if (in_light) {
        lit_worst = std::max(lit_worst, e);
        ++lit;
      }
    }
    ASSERT_GT(n, 200);
    ASSERT_GT(lit, 1000);
    std::printf("box over a %s: footprint %d lookups, mean |dT| %.4f, max %.4f; lit ground max %.4f\n",
                casts ? "casting slab" : "receive-only ground", n, sum / n, worst, lit_worst);
    EXPECT_LE(sum / n, 0.02) << (casts ? "casting slab" : "receive-only ground");
    EXPECT_LE(lit_worst, 1e-3) << (casts ? "the slab shadows itself" : "receive-only ground");
  }
}

// Item 3(e): translucent sheets 1 mm apart under a light from above; sheet k
// receives the product of (1 - a_j) of the sheets above it.
TEST(Receivers, StackedTranslucentSheetsOneMillimetreApart) {
  const float opacity[] = {0.3f, 0.5f, 0.2f, 0.6f, 0.4f};
  for (float tilt : {0.0f, 40.0f}) {
    Scene s = empty_scene("sheets");
    for (int j = 0; j < 5; ++j)
      s.objects.push_back(surface_object("sheet " + std::to_string(j), make_quad(1.5f, 1.5f),
                                         translation({0, 0.5f - 0.001f * float(j), 0}), opacity[j]));
    const float a = tilt * 3.14159265f / 180.0f;
    const Vec3 pos{0.0f, 0.5f + 4.0f * std::cos(a), 4.0f * std::sin(a)};
    s.lights.push_back(spot_light(pos, Vec3{0, 0.5f, 0} - pos, 25, 22));
    s.shadows.resolution = 512;
    s.shadows.epsilon = 0.0f;
    const ProbedFrame b(s);
    float worst = 0.0f;
    for (int k = 0; k < 5; ++k) {
      double expected = 1.0;
      for (int j = 0; j < k; ++j) expected *= 1.0 - opacity[j];
      for (float x = -0.6f; x <= 0.6f; x += 0.05f)
        for (float z = -0.6f; z <= 0.6f; z += 0.05f) {
          const Vec3 p{x, 0.5f - 0.001f * float(k), z};
          worst = std::max(worst, float(std::fabs(grey_of(b.vis(0, Receiver{p, {0, 1, 0}, uint32_t(k)})) - expected)));
        }
    }
    EXPECT_LE(worst, 1e-3f) << "light at " << tilt << " degrees";
  }
}

// Item 3(d): a sphere and the teapot lit from the side over a receive-only
// ground: the camera pass's lookups on them agree with the reference away
// from the band one texel wide around the shadows' edges (the terminator,
// the spout's and the handle's shadows on the body).
TEST(Receivers, NoLeakOrAcneAtTerminators) {
  Scene s = empty_scene("terminators");
  s.camera.width = 320;
  s.camera.height = 200;
  s.camera.position = {-2.5f, 1.6f, 3.0f};
  s.camera.target = {0.6f, 0.5f, 0.0f};
  s.objects.push_back(surface_object("sphere", make_sphere(0.5f), translation({0, 0.6f, 0})));
  const std::string newell = content_dir() + "/meshes/newell/teapot";
  s.objects.push_back(surface_object("teapot", make_newell_mesh(newell, 8),
                                     make_transform({1.5f, 0, 0}, {-90, 0, 0}, {0.25f, 0.25f, 0.25f})));
  Object ground = surface_object("ground", make_ground(8, 8, 0.05f));
  ground.casts_shadows = false;
  s.objects.push_back(ground);
  s.lights.push_back(spot_light({-4.0f, 1.0f, 0.5f}, {4.7f, -0.5f, -0.5f}, 30, 27));
  s.shadows.resolution = 512;
  const ProbedFrame b(s);
  const LightData& L = b.sv.lights[0];
  const DsmMap& m = b.sv.maps[L.first_map];
  double worst = 0.0;
  int n = 0, band = 0;
  for (const RecordedLookup& l : camera_lookups(s, b, b.vis, 1)) {
    if (l.at.p.y < 0.01f) continue;  // the ground
    const double t_ref = grey_of(b.ref.transmittance(l.light, l.at));
    // The band: the reference changes within one texel footprint around p.
    const float fp = texel_footprint(m, project(m.view, l.at.p).axial);
    const Vec3 n0 = l.at.plane;
    const Vec3 t1 = normalize(std::fabs(n0.y) < 0.9f ? cross(n0, Vec3{0, 1, 0}) : cross(n0, Vec3{1, 0, 0}));
    const Vec3 t2 = cross(n0, t1);
    // and the terminator itself: n.l below 0.05 (3 degrees; one texel of
    // these maps spans about 0.02 of n.l on the 0.5 m sphere).
    bool edge = dot(normalize(L.position - l.at.p), n0) < 0.05f;
    for (Vec3 o : {t1, t1 * -1.0f, t2, t2 * -1.0f}) {
      const Vec3 q = l.at.p + o * (1.5f * fp);
      edge = edge || std::fabs(grey_of(b.ref.transmittance(l.light, Receiver{q, n0, l.at.object})) - t_ref) > 0.02 ||
             dot(normalize(L.position - q), n0) <= 0.0f;
    }
    if (edge) {
      ++band;
      continue;
    }
    const double e = std::fabs(double(grey_of(l.transmittance)) - t_ref);
    if (e > 0.02 && std::getenv("CDSM_TEST_VERBOSE"))
      std::printf("  at %.3f %.3f %.3f n.l %.3f: dsm %.4f b.ref %.4f\n", l.at.p.x, l.at.p.y, l.at.p.z,
                  dot(normalize(L.position - l.at.p), n0), grey_of(l.transmittance), t_ref);
    worst = std::max(worst, e);
    ++n;
  }
  std::printf("sphere and teapot: %d lookups off the band (%d in it), max |dT| %.4f\n", n, band, worst);
  ASSERT_GT(n, 2000);
  EXPECT_LE(worst, 0.02);
}

// The depth a tap reads a surface at (PlaneRays, set up once per lookup,
// a few multiply-adds per tap) is where the tap's texel-centre ray meets the
// receiver's plane: against the crossing computed in double from the view's
// own rays (view_direction, pixel_origin), for off-centre perspective
// windows (focused cluster frusta), non-square ones, orthographic ones, and
// planes at every angle to them.
TEST(Receivers, TapDepthsAreWhereTheTexelRaysCrossTheReceiversPlane) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  int compared = 0;
  for (int c = 0; c < 300; ++c) {
    PinholeView v;
    v.projection = c % 3 == 2 ? Projection::Orthographic : Projection::Perspective;
    v.forward = normalize(Vec3{u(rng), u(rng), u(rng)});
    cluster::make_frame(v.forward, Vec3{0.0f, 1.0f, 0.0f}, v.right, v.up);
    v.eye = Vec3{u(rng), u(rng), u(rng)} * 10.0f;
    v.tan_half_x = 0.05f + std::fabs(u(rng));
    v.tan_half_y = 0.05f + std::fabs(u(rng));
    v.center = Vec2{0.3f * u(rng), 0.3f * u(rng)};
    v.width = 16 + c % 97;
    v.height = 16 + (c * 7) % 61;
    const Vec3 n = normalize(Vec3{u(rng), u(rng), u(rng)});
    const Vec3 p = v.eye + v.forward * (3.0f + 2.0f * u(rng)) + v.right * u(rng) + v.up * u(rng);
    const PlaneRays rays = plane_rays(v, p, n);
    for (int ty = 0; ty < v.height; ty += 5)
      for (int tx = 0; tx < v.width; tx += 3) {
        const Vec3 d = view_direction(v, float(tx) + 0.5f, float(ty) + 0.5f), o = pixel_origin(v, tx, ty);
        const double dl = std::sqrt(double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z);
        const double dn = (double(d.x) * n.x + double(d.y) * n.y + double(d.z) * n.z) / dl;
        if (std::fabs(dn) < 0.05) continue;  // nearly parallel: the lookup clamps it to its reach
        const double num = (double(p.x) - o.x) * n.x + (double(p.y) - o.y) * n.y + (double(p.z) - o.z) * n.z;
        const double want = num / dn;
        const float got = plane_depth_of(rays, tx, ty, float(want), 1.0e30f);
        ASSERT_NEAR(got, want, 2.0e-5 * (std::fabs(want) + 10.0))
            << (v.projection == Projection::Orthographic ? "orthographic" : "perspective") << " view " << c
            << ", texel " << tx << ", " << ty;
        ++compared;
      }
  }
  EXPECT_GT(compared, 30000);
}
