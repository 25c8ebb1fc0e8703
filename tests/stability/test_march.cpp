// Marching always advances (issue "No silent wrong answers", item 3): a
// march step below the float resolution at a segment's depth is lengthened
// to it (counted and warned about), and a step that cannot be marched where
// the volume lies is a clear error — never a hang. Each case runs under a
// watchdog: a hang fails the test (and ends the process) instead of
// stalling the suite.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <future>
#include <thread>

#include "cdsm/scene_io.h"
#include "stability_util.h"

using namespace stab;

namespace {

// Runs f on a thread; if it has not returned after `seconds`, the test
// fails and the process exits (a hung thread cannot be joined).
template <class F>
void within(double seconds, const char* what, F&& f) {
  std::packaged_task<void()> task(std::forward<F>(f));
  std::future<void> done = task.get_future();
  std::thread t(std::move(task));
  if (done.wait_for(std::chrono::duration<double>(seconds)) != std::future_status::ready) {
    std::fprintf(stderr, "%s: still running after %.0f s (a march that does not advance)\n", what, seconds);
    std::fflush(stderr);
    std::_Exit(3);
  }
  t.join();
  done.get();  // rethrows
}

// An n^3 uniform volume of `voxel` world units per voxel centred at `at`,
// seen by a camera from `camera` with vertical field of view `fov` and lit
// by a spot light from `light` with half-angle `cone`.
Scene volume_scene(float voxel, int n, Vec3 at, Vec3 camera, float fov, Vec3 light, float cone, int res) {
  Scene s = scene_named("march");
  float half = 0.5f * float(n) * voxel;
  Vec3 h{half, half, half};
  add_uniform_volume(s, "fog", at - h, at + h, 0.5f / voxel, box_mesh(at - h, at + h), n, {0.8f, 0.8f, 0.8f});
  s.camera.position = camera;
  s.camera.target = at;
  s.camera.fov_y_deg = fov;
  s.camera.near = 1e-3f * length(camera - at);
  s.lights.push_back(spot_light(light, at - light, cone, 0.8f * cone));
  s.shadows.resolution = res;
  return s;
}

}  // namespace

// Ordinary voxels (0.9 units) lit from 10^7 units away, in a 0.05-degree
// spot whose 512^2 map resolves them: at that depth a float step is 1, so
// the light pass's step of 0.45 would never advance.
TEST(March, VoxelsFarFromTheLightFinishWithAWarning) {
  Scene s = volume_scene(0.9f, 64, {0, 0, 0}, {10, 20, 80}, 45.0f, {0, 0, 1.0e7f}, 0.05f, 512);
  FrameStats st;
  within(60.0, "far light", [&] {
    Renderer r;
    r.render(s, cpu_options(), &st);
  });
  EXPECT_GT(st.light_fragments, 0u) << "the map must see the volume";
  EXPECT_GT(st.march_lengthened, 0u);
  bool warned = false;
  for (const std::string& w : st.warnings) warned = warned || w.find("float resolution") != std::string::npos;
  EXPECT_TRUE(warned) << "no warning about lengthened march steps";
}

// The camera's own march: a volume of 1e-8-unit voxels (a step of 5e-9)
// seen from 1 unit away through a field of view narrow enough to see it
// (a float step there is 1.2e-7).
TEST(March, TinyVoxelsInCodeFinish) {
  Scene s = volume_scene(1e-8f, 16, {0, 0, 0}, {0, 0.3f, 1.0f}, 2e-5f, {0, 0, 1.0f}, 1.0f, 64);
  FrameStats st;
  within(60.0, "tiny voxels", [&] {
    Renderer r;
    r.render(s, cpu_options(), &st);
  });
  EXPECT_GT(st.camera_fragments, 0u) << "the camera must see the volume";
  EXPECT_GT(st.march_lengthened, 0u);
}

// Where the volume itself lies, its step is below float resolution: no
// distance from the eye can march it. A clear error naming the volume.
TEST(March, UnmarchableVolumeIsAnError) {
  Scene s = volume_scene(0.01f, 32, {1.0e5f, 0, 0}, {1.0e5f, 0.3f, 2.0f}, 45.0f, {1.0e5f, 0, 10.0f}, 30.0f, 64);
  within(20.0, "unmarchable", [&] {
    try {
      compiled_scene(s);
      ADD_FAILURE() << "no error for a volume that cannot be marched";
    } catch (const Error& e) {
      std::string m = e.what();
      EXPECT_NE(m.find("fog"), std::string::npos) << m;
      EXPECT_NE(m.find("cannot be marched"), std::string::npos) << m;
    }
  });
}

// In a scene file a voxel_size of 1e-8 is out of range.
TEST(March, TinyVoxelSizeInAFileIsAnError) {
  std::string path = std::string(CDSM_TEST_OUTPUT_DIR) + "/tiny_voxels.json";
  std::ofstream(path)
      << R"({"camera": {"position": [0, 0, 3], "target": [0, 0, 0]}, "volumes": [{"name": "fog", "grid": {"type": "dense", "size": [4, 4, 4], "fill": 1},
    "voxel_size": [1e-8, 1e-8, 1e-8], "transfer": [{"density": 0, "extinction": 1}]}],
    "objects": [{"name": "fog", "mesh": {"type": "volume_box", "volume": "fog"},
                 "interior": {"type": "volume", "volume": "fog"}}],
    "lights": [{"type": "point", "position": [0, 1, 0]}]})";
  within(20.0, "tiny voxel_size", [&] {
    try {
      load_scene(path);
      ADD_FAILURE() << "no error for voxel_size 1e-8";
    } catch (const Error& e) {
      std::string m = e.what();
      EXPECT_NE(m.find(path), std::string::npos) << m;
      EXPECT_NE(m.find("voxel_size"), std::string::npos) << m;
      EXPECT_NE(m.find("1e-6"), std::string::npos) << m;
    }
  });
}

// The default scene with its smoke volume (and, separately, its ground)
// scaled by 1e12 .. 1e20: the march used to crawl at a minimum step across
// the huge segment (13.7 s for a 64^2 map at 1e20, about a minute at 128^2);
// now each volume is marched with its own step inside its own box only, and
// the light's near plane follows the nearest caster (issue "Reliability").
// The frame says that float cannot hold such a scene's detail (a warning
// naming the object), every pixel stays finite (the ground at 1e20 shaded
// NaN once: its triangles' cross products overflowed float), and the maps'
// lookups match exact rays through their texels.
TEST(March, HugeScalesFinishQuickly) {
  for (float scale : {1e12f, 1e16f, 1e20f})
    for (const char* which : {"smoke", "ground"}) {
      Scene s = load_scene(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/default.json");
      s.camera.width = 96;
      s.camera.height = 64;
      s.shadows.resolution = 128;
      bool found = false;
      for (Object& o : s.objects)
        if (o.name == which) {
          o.transform = o.transform * make_transform({0, 0, 0}, {0, 0, 0}, {scale, scale, scale});
          found = true;
        }
      ASSERT_TRUE(found) << which;
      FrameStats st;
      Image img;
      TransmittanceError e;
      within(30.0, "huge scale", [&] {
        Renderer r;
        img = r.render(s, cpu_options(), &st);
        RenderOptions probe = cpu_options();
        probe.error_samples = 1000;
        e = r.transmittance_error(s, probe);
      });
      EXPECT_GT(st.light_fragments, 0u) << which << " x " << scale;
      bool warned = false;
      for (const std::string& w : st.warnings)
        warned = warned || (w.find(std::string("'") + which + "'") != std::string::npos &&
                            w.find("float positions are") != std::string::npos);
      EXPECT_TRUE(warned) << which << " x " << scale << ": no warning that float cannot hold it";
      size_t bad = 0;
      for (float v : img.rgb) bad += !std::isfinite(v) || v < 0.0f;
      EXPECT_EQ(bad, 0u) << which << " x " << scale << ": pixels not finite or negative";
      std::printf("[ huge     ] %s x %g: %llu lookups, map error p99 %.5f max %.5f\n", which, double(scale),
                  (unsigned long long)e.points, e.map.p99, e.map.max);
      EXPECT_GT(e.points, 100u) << which << " x " << scale;
      EXPECT_LE(e.map.p99, s.shadows.epsilon + 0.005) << which << " x " << scale;
    }
}

// A volume with a 5 mm step whose proxy mesh is far larger than its grid (a
// 200 km box around a 32 cm grid): the grid's step applies inside the grid's
// box only, outside it the volume reads its background (one sample per
// stretch), so the march does not take 4e7 steps per ray (issue
// "Reliability": marching only where a volume is).
// The reference's camera march of a volume whose background is clear stays
// inside the box of the grid's values: a 1e5 m proxy gives the image a proxy
// around the grid gives, and in about the same time (it marched the whole
// proxy at step_voxels before: past the watchdog under ASan).
TEST(March, ReferenceImageOfAnOversizedProxyEqualsATightOne) {
  auto fog_scene = [](TriangleMesh proxy) {
    Scene s = scene_named("reference proxy");
    add_uniform_volume(s, "fog", {-0.16f, 0.5f, -0.16f}, {0.16f, 0.82f, 0.16f}, 3.0f, std::move(proxy), 32,
                       {0.8f, 0.8f, 0.8f}, 0.5f);
    s.volumes.back().grid = [] {
      auto g = std::make_shared<DenseGrid>();
      g->nx = g->ny = g->nz = 32;
      g->values.assign(32 * 32 * 32, 1.0f);
      g->background = 0.0f;
      return g;
    }();
    s.objects.back().casts_shadows = false;  // the fog shows only along camera rays: what this tests
    s.objects.push_back(surface_object("ground", make_ground(4, 4, 0.02f), Mat4{}, 1.0f, false));
    s.lights.push_back(spot_light({0.3f, 3.0f, 0.2f}, {-0.3f, -3.0f, -0.2f}, 20.0f, 15.0f));
    s.camera.width = 96;
    s.camera.height = 72;
    return s;
  };
  // One voxel (0.01 m) of reach around the grid, as the value box has.
  const Scene tight = fog_scene(box_mesh({-0.171f, 0.489f, -0.171f}, {0.171f, 0.831f, 0.171f}));
  const Scene big = fog_scene(box_mesh({-1e5f, -1e5f, -1e5f}, {1e5f, 1e5f, 1e5f}));
  Scene none = tight;  // the same view without the fog
  none.volumes.clear();
  none.objects.erase(none.objects.begin());
  Image a, b, c;
  within(30.0, "reference, oversized proxy", [&] {
    RenderOptions o = cpu_options();
    a = Renderer().render_reference(tight, o);
    b = Renderer().render_reference(big, o);
    c = Renderer().render_reference(none, o);
  });
  ASSERT_EQ(a.rgb.size(), b.rgb.size());
  ASSERT_EQ(a.rgb.size(), c.rgb.size());
  ASSERT_FALSE(a.rgb.empty());
  double worst = 0.0, fog_tight = 0.0, fog_big = 0.0;
  for (size_t i = 0; i < a.rgb.size(); ++i) {
    worst = std::max(worst, double(std::fabs(a.rgb[i] - b.rgb[i])));
    fog_tight = std::max(fog_tight, double(std::fabs(a.rgb[i] - c.rgb[i])));
    fog_big = std::max(fog_big, double(std::fabs(b.rgb[i] - c.rgb[i])));
  }
  EXPECT_GT(fog_tight, 0.05) << "the fog must show in the reference (tight proxy)";
  EXPECT_GT(fog_big, 0.05) << "the fog must show in the reference (oversized proxy)";
  EXPECT_LE(worst, 0.02) << "the oversized proxy's reference differs from the tight one's";
}

TEST(March, ProxyFarLargerThanItsGridMarchesOnlyTheGrid) {
  Scene s = scene_named("big proxy");
  add_uniform_volume(s, "fog", {-0.16f, 0.5f, -0.16f}, {0.16f, 0.82f, 0.16f}, 3.0f,
                     box_mesh({-1e5f, -1e5f, -1e5f}, {1e5f, 1e5f, 1e5f}), 32, {0.8f, 0.8f, 0.8f}, 0.5f);
  s.volumes.back().grid = [] {  // data in the middle, background 0 around it
    auto g = std::make_shared<DenseGrid>();
    g->nx = g->ny = g->nz = 32;
    g->values.assign(32 * 32 * 32, 1.0f);
    g->background = 0.0f;
    return g;
  }();
  s.objects.push_back(surface_object("ground", make_ground(4, 4, 0.02f), Mat4{}, 1.0f, false));
  s.lights.push_back(spot_light({0.3f, 3.0f, 0.2f}, {-0.3f, -3.0f, -0.2f}, 20.0f, 15.0f));
  s.shadows.resolution = 128;
  FrameStats st;
  within(30.0, "big proxy", [&] {
    Renderer r;
    RenderOptions o = cpu_options();
    o.compare_reference = true;
    r.render(s, o, &st);
  });
  EXPECT_GT(st.light_fragments, 0u);
  EXPECT_LE(st.transmittance.mean, 0.02) << "the fog's shadow on the ground";
}
