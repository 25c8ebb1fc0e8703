// Media cut by a view's near or far plane (issue "No silent wrong answers",
// item 1). The rule (DESIGN.md §2.3): surfaces are clipped to the view's
// [near, far] on the view axis; media are not — they absorb from the eye
// (or light) up to the far distance t_end, whether their boundary lies
// before near, beyond far, or both. Checked for the camera pass against the
// reference renderer, and for a light view's deep shadow map against the
// closed form, with a fog box (a dense volume) and a constant-sigma sphere
// crossing near, crossing far and containing the whole view range.
//
// Built twice: here with the CPU ray caster, and in tests/gl with the OpenGL
// rasterizer (CDSM_CLIPPING_GL), so both producers follow the rule.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "cdsm/loaders.h"
#include "cdsm/renderer.h"
#include "common/host_maps.h"
#include "unit_util.h"

#if CDSM_CLIPPING_GL
#include "gl_test_util.h"
#endif

using namespace cdsm;
using namespace cdsm_test;

namespace {

enum class Medium { FogBox, Sphere };

const char* name_of(Medium m) { return m == Medium::FogBox ? "fog box" : "sphere"; }

// A medium of extinction `sigma` occupying the axis-aligned box [lo, hi]
// (fog box: a dense volume whose background equals its fill, so its density
// is uniform up to the proxy; sphere: a constant-sigma sphere inscribed in
// the box's x extent, centred in the box).
void add_medium(Scene& s, Medium kind, Vec3 lo, Vec3 hi, float sigma) {
  Vec3 c = (lo + hi) * 0.5f, e = hi - lo;
  if (kind == Medium::FogBox) {
    auto g = std::make_shared<DenseGrid>();
    g->nx = g->ny = g->nz = 16;
    g->values.assign(16 * 16 * 16, 1.0f);
    g->background = 1.0f;
    Volume v;
    v.name = "fog";
    v.grid = g;
    // Index box [-0.5, 15.5]^3 -> [lo, hi].
    v.index_to_object = make_transform(lo + e * (0.5f / 16), {0, 0, 0}, e * (1.0f / 16));
    v.transfer = {TransferPoint{0.0f, vec3(sigma), {0.9f, 0.9f, 0.9f}}};
    v.step_voxels = 0.25f;
    s.volumes.push_back(v);
    Object o;
    o.name = "fog";
    o.mesh = share(make_volume_proxy(s.volumes.back()));
    o.surface.opacity = 0.0f;
    o.interior = InteriorKind::Volume;
    o.volume = int32_t(s.volumes.size() - 1);
    s.objects.push_back(o);
  } else {
    Object o = surface_object("sphere", make_sphere(0.5f * e.x, 64, 32), translation(c), 0.0f);
    o.interior = InteriorKind::Constant;
    o.sigma = vec3(sigma);
    s.objects.push_back(o);
  }
}

struct Case {
  const char* name;
  float near, far;  // camera (view axis)
  Vec3 lo, hi;      // the medium's box
};

// The camera sits at the origin looking down -z; an opaque lit wall at
// z = -8 (beyond `far` in the far cases: the background shows through).
const Case kCameraCases[] = {
    {"entry before near", 1.0f, 20.0f, {-2.4f, -2.4f, -2.6f}, {2.4f, 2.4f, -0.25f}},
    {"eye inside, exit before near", 1.0f, 20.0f, {-0.45f, -0.45f, -0.45f}, {0.45f, 0.45f, 0.45f}},
    {"crossing far", 0.1f, 4.0f, {-3.0f, -3.0f, -7.0f}, {3.0f, 3.0f, -1.5f}},
    {"containing the view range", 0.5f, 4.0f, {-9.0f, -9.0f, -9.0f}, {9.0f, 9.0f, 9.0f}},
};

Scene camera_scene(const Case& c, Medium m) {
  Scene s = empty_scene(std::string("clip/") + c.name);
  s.camera.position = {0, 0, 0};
  s.camera.target = {0, 0, -1};
  s.camera.fov_y_deg = 50.0f;
  s.camera.near = c.near;
  s.camera.far = c.far;
  s.camera.width = 64;
  s.camera.height = 48;
  s.background = {0.6f, 0.7f, 0.8f};  // bright, so absorption before far shows
  s.objects.push_back(surface_object("wall", make_box({30, 30, 0.2f}), translation({0, 0, -8.1f})));
  // The sphere of the "containing" case has radius 9 and would swallow the
  // wall; the same medium either way.
  add_medium(s, m, c.lo, c.hi, 0.35f);
  s.lights.push_back(spot_light({3.0f, 3.0f, 1.0f}, normalize(Vec3{-3.0f, -3.0f, -9.0f}), 40.0f, 35.0f));
  s.shadows.resolution = 256;
  return s;
}

FragmentSource producer() {
#if CDSM_CLIPPING_GL
  return FragmentSource::Gl;
#else
  return FragmentSource::Cpu;
#endif
}

#if CDSM_CLIPPING_GL
class ViewClipping : public cdsm::test::GlTest {};
#define CLIP_TEST(name) TEST_F(ViewClipping, name)
#else
#define CLIP_TEST(name) TEST(ViewClipping, name)
#endif

// The camera's view of each medium against the reference renderer (which
// splits its ray at every hit and clips only surfaces).
CLIP_TEST(CameraPassMatchesReference) {
  for (const Case& c : kCameraCases)
    for (Medium m : {Medium::FogBox, Medium::Sphere}) {
      Scene s = camera_scene(c, m);
      Renderer r;
      RenderOptions opt;
      opt.fragments = producer();
      opt.compare_reference = true;
      opt.error_samples = 4000;
      FrameStats st;
      Image img = r.render(s, opt, &st);
      ASSERT_EQ(st.fragment_source, producer() == FragmentSource::Gl ? "gl" : "cpu");
      std::printf("[ clipping ] camera %-30s %-8s PSNR %6.2f dB, transmittance mean %.4f p99 %.4f max %.4f\n", c.name,
                  name_of(m), st.image.psnr, st.transmittance.mean, st.transmittance.p99, st.transmittance.max);
      EXPECT_GE(st.image.psnr, 45.0) << c.name << ", " << name_of(m);
      // Within eps (0.01, the fog's compression) on average; the max is at
      // the sphere's silhouette in the shadow (resolution, not clipping).
      EXPECT_LE(st.transmittance.mean, s.shadows.epsilon + 1e-3) << c.name << ", " << name_of(m);
      EXPECT_LE(st.transmittance.p99, 0.03) << c.name << ", " << name_of(m);
      EXPECT_EQ(st.unmatched_fragments, 0u) << c.name << ", " << name_of(m);
      // The reference itself against the closed form on the axis pixel
      // column's centre ray: the wall (or background) dimmed by the medium
      // between the eye and min(wall, far).
      const PinholeView v = camera_view(s.camera);
      SceneBuffers sb = compiled_scene(s);
      uint32_t medium = 1;
      Vec3 dir = pixel_ray(v, 32, 24);
      float t_far = v.far / dot(dir, v.forward);
      double len = chord(sb.view(), medium, v.eye, dir, std::min(t_far, 8.0f / -dir.z));
      double T = std::exp(-0.35 * len);
      EXPECT_GT(len, 0.1) << c.name;
      if (c.far < 8.0f) {  // the background through the medium (no in-scattering there for the sphere)
        if (m == Medium::Sphere) {
          const float* px = r.last_reference().rgb.data() + (size_t(24) * 64 + 32) * 3;
          EXPECT_NEAR(px[2], 0.8 * T, 2e-3) << c.name << ": reference at the centre pixel";
          const float* dp = img.rgb.data() + (size_t(24) * 64 + 32) * 3;
          EXPECT_NEAR(dp[2], 0.8 * T, 2e-3) << c.name << ": camera pass at the centre pixel";
        }
      }
    }
}

// A light view whose near or far plane cuts the medium: the deep shadow map
// along a texel's ray equals 1 - exp(-sigma * chord(0, min(z, t_end))).
struct LightCase {
  const char* name;
  float near, far;
  Vec3 lo, hi;
};
const LightCase kLightCases[] = {
    {"entry before near", 2.0f, 10.0f, {-1.5f, -1.5f, -4.0f}, {1.5f, 1.5f, -0.5f}},
    {"light inside, exit before near", 2.0f, 10.0f, {-1.0f, -1.0f, -1.0f}, {1.0f, 1.0f, 1.0f}},
    {"crossing far", 0.5f, 3.0f, {-1.5f, -1.5f, -5.0f}, {1.5f, 1.5f, -1.0f}},
    {"containing the view range", 0.5f, 3.0f, {-6.0f, -6.0f, -6.0f}, {6.0f, 6.0f, 6.0f}},
};

using Producer = std::function<void(const SceneBuffers&, const PinholeView&, FragmentBuffers&)>;

void check_light_views(const Producer& produce) {
  for (const LightCase& c : kLightCases)
    for (Medium m : {Medium::FogBox, Medium::Sphere}) {
      Scene s = empty_scene(std::string("clip light/") + c.name);
      add_medium(s, m, c.lo, c.hi, 0.6f);
      SceneBuffers sb = compiled_scene(s);
      SceneView sv = sb.view();
      PinholeView lv = light_view({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 0.25f, 32, 1, c.near, c.far);
      FragmentBuffers fb;
      produce(sb, lv, fb);
      std::vector<uint32_t> inside = objects_containing(sv, lv.eye, ObjectMask{});
      cdsm_test::HostMaps dsm;
      const float eps = 0.002f;
      LightPassParams lp{lv, eps, {inside.data(), inside.size()}};
      DsmBuildStats bs = cdsm_test::build_host_map(sb, lp, fb, dsm);
      EXPECT_EQ(bs.walk.unmatched, 0u) << c.name << ", " << name_of(m);
      DsmStorage st = dsm.storage();
      double worst = 0.0;
      int probed = 0;
      for (int tx : {5, 16, 27})
        for (int ty : {7, 16, 24}) {
          Vec3 dir = pixel_ray(lv, tx, ty);
          float t_end = lv.far / dot(dir, lv.forward);
          std::vector<float> hits = object_hits(sv, 0, lv.eye, dir);
          for (int k = 0; k <= 40; ++k) {
            float z = t_end * 1.2f * float(k) / 40.0f;
            double exact = 1.0 - std::exp(-0.6 * inside_length(hits, std::min(z, t_end)));
            float a = lookup_alpha(texel_nodes<1>(st, dsm.maps[0], tx, ty), z);
            worst = std::max(worst, std::fabs(double(a) - exact));
            ++probed;
          }
        }
      std::printf("[ clipping ] light  %-30s %-8s max |alpha - exact| %.2e over %d depths\n", c.name, name_of(m), worst,
                  probed);
      // eps, plus the march's sampling of a uniform medium (exact for the
      // sphere) and float rounding.
      EXPECT_LE(worst, eps + 2e-3) << c.name << ", " << name_of(m);
    }
}

#if CDSM_CLIPPING_GL
CLIP_TEST(LightViewMatchesClosedForm) {
  gl::FragmentRasterizer raster(context());
  check_light_views([&](const SceneBuffers& sb, const PinholeView& v, FragmentBuffers& out) {
    raster.upload_scene({sb.tri_vertices.data(), sb.tri_vertices.size()}, {sb.tri_object.data(), sb.tri_object.size()},
                        {sb.objects.data(), sb.objects.size()});
    raster.rasterize(v, ObjectMask{}, out);
  });
}
#else
CLIP_TEST(LightViewMatchesClosedForm) {
  check_light_views([](const SceneBuffers& sb, const PinholeView& v, FragmentBuffers& out) {
    cast_fragments(sb.view(), v, ObjectMask{}, out);
  });
}
#endif

}  // namespace
