// Frame costs of the persistent shadow system (not a ctest test):
//   build/tests/bench/bench_frames [--benchmark_filter=...]
// Each case renders 720x480 frames through one ShadowSystem, changing one
// thing per frame, with CPU (arg 0) or GL (arg 1) fragments. Counters:
//   frame_ms   wall time of update + render per frame
//   base_ms    what the change itself needs: camera fragments + camera pass
//              (+ the light fragments and builds of the maps it rebuilt)
//   ratio      frame_ms / base_ms (targets: issue 12, docs/persistent-frames.md)
//   overhead_ms frame_ms - base_ms
//   rebuilt / compiles per frame
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <memory>

#include "cdsm/procedural.h"
#include "cdsm/scene_io.h"
#include "cdsm/shadow_system.h"
#include "scene_compile.h"
#include "common/system_frame.h"

using namespace cdsm;

namespace {

Scene shipped(const std::string& name) {
  Scene s = load_scene(std::string(CDSM_CONTENT_DIR_BENCH) + "/scenes/" + name + ".json");
  s.camera.width = 720;
  s.camera.height = 480;
  return s;
}

// A box holding a dense n^3 grid (a soft ball of density), a ground, a spot.
Scene dense_ct(int n) {
  Scene s;
  s.source = "dense_ct_" + std::to_string(n);
  auto g = std::make_shared<DenseGrid>();
  g->nx = g->ny = g->nz = n;
  g->values.resize(size_t(n) * n * n);
  const float c = 0.5f * float(n - 1);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const float r = std::sqrt((i - c) * (i - c) + (j - c) * (j - c) + (k - c) * (k - c)) / c;
        g->values[(size_t(k) * n + j) * n + i] = std::max(0.0f, 1.0f - r);
      }
  Volume v;
  v.name = "ct";
  v.grid = g;
  v.index_to_object = make_transform({-0.5f, -0.5f, -0.5f}, {0, 0, 0}, vec3(1.0f / float(n - 1)));
  v.transfer = {{0.0f, vec3(0.0f), {1, 1, 1}}, {1.0f, vec3(6.0f), {1, 1, 1}}};
  v.step_voxels = 0.5f;
  s.volumes.push_back(v);
  Object box;
  box.name = "ct box";
  box.mesh = std::make_shared<TriangleMesh>(make_box({1.02f, 1.02f, 1.02f}));
  box.transform = make_transform({0, 0.8f, 0}, {0, 0, 0}, {1, 1, 1});
  box.surface.opacity = 0.0f;
  box.interior = InteriorKind::Volume;
  box.volume = 0;
  s.objects.push_back(box);
  Object ground;
  ground.name = "ground";
  ground.mesh = std::make_shared<TriangleMesh>(make_ground(8, 8));
  s.objects.push_back(ground);
  s.lights.push_back(cdsm_test::spot_light({1.5f, 4.0f, 1.0f}, {-1.5f, -4.0f, -1.0f}, 35.0f, 30.0f));
  s.camera = cdsm_test::camera_at({0, 1.6f, 3.2f}, {0, 0.7f, 0}, 720, 480);
  return s;
}

std::unique_ptr<ShadowSystem> make_system(const Scene& s, bool gl) {
  auto sys = std::make_unique<ShadowSystem>(SystemOptions{gl ? FragmentSource::Gl : FragmentSource::Cpu, s.source});
  std::vector<VolumeHandle> vols;
  for (const Volume& v : s.volumes) vols.push_back(sys->add_volume(v));
  for (const Object& o : s.objects)
    sys->add_object(o, o.interior == InteriorKind::Volume ? vols[size_t(o.volume)] : VolumeHandle{});
  for (const Light& l : s.lights) sys->add_light(l);
  sys->set_camera(s.camera);
  sys->set_settings(s.shadows);
  sys->set_background(s.background);
  return sys;
}

// Renders frames, calling `change(frame)` before each; reports the counters.
void run_frames(benchmark::State& state, const Scene& scene, const std::function<void(ShadowSystem&, int)>& change) {
  const bool gl = state.range(0) == 1;
  std::unique_ptr<ShadowSystem> sys;
  try {
    sys = make_system(scene, gl);
    sys->render();  // first frame: everything compiled and built
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  double frame = 0, base = 0, rebuilt = 0, compiles = 0;
  int frames = 0;
  for (auto _ : state) {
    change(*sys, frames);
    FrameStats st;
    const auto t0 = std::chrono::steady_clock::now();
    sys->render(&st);
    frame += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    base += st.times.camera_fragments_ms + st.times.camera_ms + st.times.fragments_ms + st.times.dsm_build_ms;
    rebuilt += st.maps_rebuilt;
    compiles += st.update.full_compiles + st.update.objects_compiled + st.update.volumes_compiled;
    ++frames;
  }
  state.counters["frame_ms"] = frame / frames;
  state.counters["base_ms"] = base / frames;
  state.counters["ratio"] = frame / base;
  state.counters["overhead_ms"] = (frame - base) / frames;
  state.counters["rebuilt"] = rebuilt / frames;
  state.counters["compiles"] = compiles / frames;
}

void orbit(ShadowSystem& sys, const Camera& c0, int frame) {
  Camera c = c0;
  const float a = 0.0174533f * float(frame + 1);
  const Vec3 d = c.position - c.target;
  c.position = c.target + Vec3{d.x * std::cos(a) - d.z * std::sin(a), d.y, d.x * std::sin(a) + d.z * std::cos(a)};
  sys.set_camera(c);
}

void BM_Unchanged(benchmark::State& state) {
  run_frames(state, shipped("default"), [](ShadowSystem&, int) {});
}
void BM_CameraOrbit(benchmark::State& state) {
  const Scene s = shipped("default");
  run_frames(state, s, [&](ShadowSystem& sys, int f) { orbit(sys, s.camera, f); });
}
void BM_ObjectMoved(benchmark::State& state) {
  const Scene s = shipped("sparse");
  size_t oi = 0;
  for (size_t i = 0; i < s.objects.size(); ++i)
    if (s.objects[i].name == "teapot3") oi = i;
  run_frames(state, s, [&, oi](ShadowSystem& sys, int f) {
    Mat4 t = s.objects[oi].transform;
    t.m[0][3] += (f % 2 ? -0.02f : 0.02f) * float(f % 5 + 1);
    sys.set_transform(sys.objects()[oi], t);
  });
}
void BM_LightMoved(benchmark::State& state) {
  const Scene s = shipped("teapot_omni");
  run_frames(state, s, [&](ShadowSystem& sys, int f) {
    Light l = s.lights[1];
    l.position = l.position + Vec3{0.01f * float(f % 7 + 1), 0, 0};
    sys.set_light(sys.lights()[1], l);
  });
}
void BM_EpsilonChanged(benchmark::State& state) {
  const Scene s = shipped("default");
  run_frames(state, s, [&](ShadowSystem& sys, int f) {
    ShadowSettings x = s.shadows;
    x.epsilon = f % 2 ? 0.01f : 0.02f;
    sys.set_settings(x);
  });
}
void BM_DenseUnchanged(benchmark::State& state) {
  run_frames(state, dense_ct(int(state.range(1))), [](ShadowSystem&, int) {});
}
void BM_DenseOrbit(benchmark::State& state) {
  const Scene s = dense_ct(int(state.range(1)));
  run_frames(state, s, [&](ShadowSystem& sys, int f) { orbit(sys, s.camera, f); });
}

// After one object of sparse.json moved by `arg` centimetres: refitting
// the BVH against rebuilding it (time; cost = the tree's surface-area cost
// relative to a fresh build's, which a refit lets grow).
void BM_BvhAfterMove(benchmark::State& state) {
  Scene s = shipped("sparse");
  size_t oi = 0;
  for (size_t i = 0; i < s.objects.size(); ++i)
    if (s.objects[i].name == "teapot3") oi = i;
  SceneBuffers sb = cdsm_test::compiled_scene(s);
  const double built = bvh_cost(sb);
  s.objects[oi].transform.m[0][3] += 0.01f * float(state.range(1));
  const SceneBuffers moved = cdsm_test::compiled_scene(s);
  const ObjectData& od = sb.objects[oi];
  std::copy(moved.tri_vertices.begin() + ptrdiff_t(od.first_tri) * 3,
            moved.tri_vertices.begin() + ptrdiff_t(od.first_tri + od.tri_count) * 3,
            sb.tri_vertices.begin() + ptrdiff_t(od.first_tri) * 3);
  double cost = 0;
  for (auto _ : state) {
    if (state.range(0) == 0) {
      cost = refit_bvh(sb);
    } else {
      build_bvh(sb);
      cost = bvh_cost(sb);
    }
  }
  state.counters["cost_vs_fresh"] = cost / bvh_cost(moved);
  state.counters["cost_vs_built"] = cost / built;
  state.counters["triangles"] = double(sb.tri_object.size());
}
BENCHMARK(BM_BvhAfterMove)->Args({0, 5})->Args({1, 5})->Args({0, 200})->Args({1, 200})->Unit(benchmark::kMillisecond);

#define FRAMES(b) BENCHMARK(b)->Arg(0)->Arg(1)->Iterations(6)->Unit(benchmark::kMillisecond)
FRAMES(BM_Unchanged);
FRAMES(BM_CameraOrbit);
FRAMES(BM_ObjectMoved);
FRAMES(BM_LightMoved);
FRAMES(BM_EpsilonChanged);
BENCHMARK(BM_DenseUnchanged)->Args({0, 64})->Args({0, 512})->Iterations(6)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_DenseOrbit)->Args({0, 64})->Args({0, 512})->Iterations(6)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
