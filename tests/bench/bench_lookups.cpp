// What one shadow lookup costs (not a ctest test):
//   build/tests/bench/bench_lookups [--benchmark_filter=...]
// The default scene's map (512^2, eps 0.01), its key spot light hard
// (radius 0), as a sphere of radius 0.15 with the estimated penumbra
// (hd/lights.h "lights with a size"), and with the fixed-kernel PCF of the
// same taps. Surfaces: ground points under the light, looked up at their
// plane; volume samples: points in the smoke's box at their own depth. One
// thread; counter per_lookup (seconds, with an SI prefix).
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "cdsm/scene_io.h"
#include "frame.h"
#include "hd/camera_pass.h"
#include "scene_compile.h"

using namespace cdsm;

namespace {

struct Maps {
  Scene scene;
  SceneBuffers sb;
  ShadowCache cache;
  ShadowFrame frame;
  std::vector<Receiver> surfaces, samples;
  explicit Maps(float radius) : scene(load()), sb((scene.lights[0].radius = radius, compile_scene(scene))) {
    build_shadow_frame(scene, sb, cpu_fragment_producer(sb.view()), cache, frame);
    for (int j = 0; j < 64; ++j)
      for (int i = 0; i < 64; ++i)
        surfaces.push_back(
            Receiver{{-1.5f + 3.0f * float(i) / 63.0f, 0.0f, -1.5f + 3.0f * float(j) / 63.0f}, {0, 1, 0}, kNoObject});
    for (const Object& o : scene.objects)
      if (o.name == "smoke") {
        const Box3 b = world_bounds(*o.mesh, o.transform);
        for (int k = 0; k < 16; ++k)
          for (int j = 0; j < 16; ++j)
            for (int i = 0; i < 16; ++i) {
              const Vec3 t{(float(i) + 0.5f) / 16.0f, (float(j) + 0.5f) / 16.0f, (float(k) + 0.5f) / 16.0f};
              samples.push_back(Receiver{b.lo + (b.hi - b.lo) * t, {0, 0, 0}, kNoObject});
            }
      }
  }
  static Scene load() { return load_scene(std::string(CDSM_CONTENT_DIR_BENCH) + "/scenes/default.json"); }
};

// arg 0: 0 hard (radius 0), 1 estimated (radius 0.15), 2 fixed kernel (radius 0.15), 3 the estimate's
// blocker search alone (penumbra_filter_radius); arg 1: 0 surfaces, 1 samples.
void BM_Lookup(benchmark::State& state) {
  static Maps hard(0.0f), sized(0.15f);
  const int mode = int(state.range(0));
  Maps& m = mode == 0 ? hard : sized;
  ShadowView sv = m.frame.view(m.scene.shadows);
  if (mode == 2) sv.penumbra = Penumbra::FixedKernel;
  const std::vector<Receiver>& pts = state.range(1) == 0 ? m.surfaces : m.samples;
  const DsmVisibility vis{sv};
  double sink = 0.0;
  const LightData& L = sv.lights[0];
  const DsmMap& map = sv.maps[L.first_map];
  for (auto _ : state)
    for (const Receiver& r : pts)
      sink += mode == 3 ? double(penumbra_filter_radius(sv, L, map, project(map.view, r.p), r)) : double(vis(0, r).x);
  benchmark::DoNotOptimize(sink);
  state.counters["per_lookup"] = benchmark::Counter(double(state.iterations()) * double(pts.size()),
                                                    benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  const char* names[] = {"hard", "estimated r=0.15", "fixed kernel r=0.15", "blocker search alone r=0.15"};
  state.SetLabel(std::string(names[mode]) + (state.range(1) == 0 ? ", surfaces" : ", volume samples"));
}

}  // namespace

BENCHMARK(BM_Lookup)->ArgsProduct({{0, 1, 2, 3}, {0, 1}})->Unit(benchmark::kMillisecond)->MinTime(0.5);
BENCHMARK_MAIN();
