// Soak test through the public API (issue "Reliability"): frames at
// 160x120 with 128^2 maps and clusters on, the camera orbiting every frame,
// the light moving every 50 frames, epsilon changing every 200, an object
// added and removed every 100. Asserts: resident memory after warm-up grows
// less than 1% (and so do the GL scene buffers, the compiled scene and the
// map store the library counts) and every frame rebuilds exactly the maps
// its changes imply; the frame time of the same frames early and late is
// printed (a figure, not a gate: it moves with the machine's load).
// CDSM_SOAK_FRAMES sets the length (2,000; 300 under the sanitizers).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "cdsm/cdsm.h"
#include "cdsm/loaders.h"
#include "common/builders.h"

using namespace cdsm;

namespace {

long resident_kib() {
  std::ifstream in("/proc/self/status");
  std::string key;
  long value = 0;
  while (in >> key) {
    if (key == "VmRSS:") {
      in >> value;
      return value;
    }
    std::getline(in, key);
  }
  return 0;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

int frames_to_run() {
  const char* v = std::getenv("CDSM_SOAK_FRAMES");
  int n = v ? std::atoi(v) : 2000;
  return std::max(n, 300);
}

Object make(const std::string& name, TriangleMesh mesh, Vec3 at, float opacity, float sigma = 0.0f) {
  Object o = cdsm_test::surface_object(name, std::move(mesh), make_transform(at, {0, 0, 0}, {1, 1, 1}), opacity);
  if (sigma > 0.0f) {
    o.interior = InteriorKind::Constant;
    o.sigma = vec3(sigma);
  }
  return o;
}

Scene soak_scene() {
  Scene s;
  s.source = "soak";
  s.camera.width = 160;
  s.camera.height = 120;
  s.camera.target = {0, 0.4f, 0};
  s.shadows.resolution = 128;
  s.shadows.max_clusters = 3;
  s.shadows.epsilon = 0.01f;
  Object ground = make("ground", make_ground(8, 8, 0.05f), {0, 0, 0}, 1.0f);
  ground.casts_shadows = false;
  s.objects.push_back(ground);
  s.objects.push_back(make("box", make_box({0.5f, 0.8f, 0.5f}), {-1.2f, 0.41f, 0.3f}, 1.0f));
  s.objects.push_back(make("glass", make_sphere(0.35f, 24, 12), {0.4f, 0.36f, -0.6f}, 0.4f, 1.5f));
  s.objects.push_back(make("pane", make_box({0.7f, 0.5f, 0.04f}), {1.3f, 0.26f, 0.9f}, 0.5f));
  NoiseVolumeParams np;
  np.nx = np.ny = np.nz = 20;
  np.seed = 5;
  Volume v;
  v.name = "puff";
  v.grid = make_noise_volume(np);
  v.index_to_object = make_transform({0.02f, 0.02f, 0.02f}, {0, 0, 0}, {0.04f, 0.04f, 0.04f});
  v.transfer = {TransferPoint{0.0f, vec3(0.0f), {0.9f, 0.9f, 0.9f}},
                TransferPoint{1.0f, vec3(6.0f), {0.9f, 0.9f, 0.9f}}};
  s.volumes.push_back(v);
  Object puff;
  puff.name = "puff";
  puff.mesh = std::make_shared<TriangleMesh>(make_volume_proxy(s.volumes[0]));
  puff.transform = make_transform({0.9f, 0.3f, 0.2f}, {0, 0, 0}, {1, 1, 1});
  puff.surface.opacity = 0.0f;
  puff.interior = InteriorKind::Volume;
  puff.volume = 0;
  s.objects.push_back(puff);
  Light l;
  l.type = LightType::Spot;
  l.outer_cone_deg = 45.0f;
  l.inner_cone_deg = 40.0f;
  s.lights.push_back(l);
  return s;
}

// The scene of frame f, from scratch: the camera orbits every frame, the
// light moves every 50 frames, epsilon changes every 200, the visitor is
// added every 200 frames from frame 100 on and removed 100 frames later.
void frame_state(Scene& s, const Scene& base, const Object& visitor, int f) {
  s = base;
  const float a = 0.013f * float(f);
  s.camera.position = {4.0f * std::cos(a), 2.2f, 4.0f * std::sin(a)};
  const float b = 0.7f * float(f / 50);
  s.lights[0].position = {1.5f * std::cos(b), 4.5f, 1.5f * std::sin(b)};
  s.lights[0].direction = normalize(Vec3{0, 0.3f, 0} - s.lights[0].position);
  s.shadows.epsilon = (f / 200) % 2 ? 0.02f : 0.01f;
  if (f % 200 >= 100) s.objects.push_back(visitor);
}

}  // namespace

TEST(Soak, ThousandsOfChangingFrames) {
  const int frames = frames_to_run();
  const Scene base = soak_scene();
  const Object visitor = make("visitor", make_sphere(0.25f, 16, 8), {-0.2f, 0.26f, 1.1f}, 1.0f);
  Scene s;
  Renderer r;
  RenderOptions opt;
  std::vector<double> ms;
  std::vector<long> rss;
  std::vector<uint64_t> gl_bytes, held_bytes;  // GL scene buffers; compiled scene + map store
  uint64_t rebuilds = 0, wrong = 0;
  std::string first_wrong;
  auto render = [&](int f, FrameStats& st) {
    frame_state(s, base, visitor, f);
    auto t0 = std::chrono::steady_clock::now();
    Image img = r.render(s, opt, &st);
    double t = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_EQ(img.rgb.size(), size_t(160 * 120 * 3));
    return t;
  };
  for (int f = 0; f < frames; ++f) {
    FrameStats st;
    ms.push_back(render(f, st));
    rss.push_back(resident_kib());
    gl_bytes.push_back(st.update.gl_scene_bytes);
    held_bytes.push_back(st.update.scene_bytes + st.update.map_store_bytes);
    // Rebuilds: everything when the light, epsilon or the objects changed
    // (a new object set changes every cluster's members); else exactly the
    // clusters whose members or focused frustum changed (the camera moved).
    const bool all = f == 0 || f % 50 == 0 || f % 100 == 0;
    uint32_t maps = st.maps_rebuilt + st.maps_reused, expected = 0;
    if (all) {
      expected = maps;
    } else {
      for (const LightClusterStats& c : st.clusters)
        if (c.clustered)
          for (uint8_t ch : c.changed) expected += ch;
    }
    rebuilds += st.maps_rebuilt;
    if (st.maps_rebuilt != expected) {
      ++wrong;
      if (first_wrong.empty())
        first_wrong = "frame " + std::to_string(f) + ": " + std::to_string(st.maps_rebuilt) + " rebuilt, expected " +
                      std::to_string(expected) + " of " + std::to_string(maps);
    }
  }
  EXPECT_EQ(wrong, 0u) << first_wrong;
  std::printf("[ soak ] %d frames, %llu maps rebuilt\n", frames, (unsigned long long)rebuilds);
  if (frames <= 500) {
    // soak_short (the stability label, also under ASan+UBSan, whose
    // LeakSanitizer checks leaks at exit): the rebuild counts above only.
    // The resident-memory and time-drift checks below need the full run.
    std::printf(
        "[ soak ] %d frames: memory and time drift not checked (they need more than 500 frames: the "
        "`soak` test, label slow)\n",
        frames);
    return;
  }
  // Memory: the peak of the last 500 frames against the peak of frames
  // 300..800 (single readings move by 1-2% with the allocator's buffers).
  const long warm = *std::max_element(rss.begin() + 300, rss.begin() + 800);
  const long late = *std::max_element(rss.end() - 500, rss.end());
  // Time: frames 100..300 again, at the end of the run (the same work, so
  // a drift is the process slowing down), against their first time.
  std::vector<double> replay;
  for (int f = 100; f < 300; ++f) {
    FrameStats st;
    replay.push_back(render(f, st));
  }
  const double early = median(std::vector<double>(ms.begin() + 100, ms.begin() + 300));
  const double again = median(replay);
  const double last = median(std::vector<double>(ms.end() - 200, ms.end()));
  std::printf(
      "[ soak ] resident memory peak %ld KiB (frames 300-800) -> %ld KiB (last 500); median frame %.1f ms "
      "(frames 100-300), %.1f ms (the same frames replayed at the end), %.1f ms (the last 200)\n",
      warm, late, early, again, last);
  // The window peaks move between runs with no trend (112176-113300 KiB
  // for frames 300-800 over three runs on one machine; a CI run read
  // 112468 -> 113644, +1.05%, and passed on rerun): 1% plus 2 MiB, about
  // 3.1 MiB here. A leak of 3 KiB a frame still fails it over the 1200
  // frames between the windows' centres.
  EXPECT_LT(double(late), 1.01 * double(warm) + 2048.0) << "resident memory grew after warm-up";
  // The library's own counters (FrameStats::update), the same windows.
  const uint64_t gl_warm = *std::max_element(gl_bytes.begin() + 300, gl_bytes.begin() + 800);
  const uint64_t gl_late = *std::max_element(gl_bytes.end() - 500, gl_bytes.end());
  EXPECT_LE(gl_late, gl_warm) << "GL scene buffers grew after warm-up";
  const uint64_t held_warm = *std::max_element(held_bytes.begin() + 300, held_bytes.begin() + 800);
  const uint64_t held_late = *std::max_element(held_bytes.end() - 500, held_bytes.end());
  EXPECT_LE(double(held_late), 1.01 * double(held_warm)) << "compiled scene and map store grew after warm-up";
  std::printf("[ soak ] GL scene buffers peak %llu -> %llu bytes; compiled scene + map store peak %llu -> %llu bytes\n",
              (unsigned long long)gl_warm, (unsigned long long)gl_late, (unsigned long long)held_warm,
              (unsigned long long)held_late);
  // Frame time is reported, not asserted: on a shared machine it moves with
  // the load (a concurrent build made the same frames 1.12x slower once);
  // growth is caught by the memory and counter checks above.
  std::printf("[ soak ] the same frames replayed at the end took %.2fx their first median\n", again / early);
}
