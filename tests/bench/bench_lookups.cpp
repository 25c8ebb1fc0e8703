// What one shadow lookup costs (not a ctest test):
//   build/tests/bench/bench_lookups [--benchmark_filter=...]
// The default scene's map (512^2, eps 0.01), its key spot light hard
// (radius 0), as a sphere of radius 0.15 with the estimated penumbra
// (hd/lights.h "lights with a size"), and with the fixed-kernel PCF of the
// same taps. Surfaces: ground points under the light, looked up at their
// plane; volume samples: points in the smoke's box at their own depth. One
// thread; counter per_lookup (seconds, with an SI prefix).
//
// BM_LookupByReach: the same points split by whether a blocker lies within a
// penumbra's reach (the pyramid dismisses the search, or the search and the
// filter run).
//
// BM_CameraPass: the camera pass of `cdsm render content/scenes/default.json
// --backend cpu --fragments cpu` (its hard spot light, the smoke marched per
// pixel) at 360 x 240 on one thread, in one process: ShadowSystem::render()
// over maps built once, with its camera fragments and camera pass times
// (FrameStats::times) as counters. Whole renders on a shared 2-core VM vary
// by 15-25% run to run; this is the figure to A/B the per-pixel path with.
//
// BM_SeriesReconstruction: what the Fourier opacity maps' and the moments'
// own lookup would cost in an engine that keeps their numbers per texel
// (the maps here tabulate it into nodes, hd/baselines.h): one texel's
// reconstruction at one depth (hd/series.h), six layers of random depth
// and absorbance, 4096 depths. A bilinear lookup reconstructs four texels.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <memory>
#include <string>
#include <vector>

#include "cdsm/scene_io.h"
#include "frame.h"
#include "hd/camera_pass.h"
#include "hd/series.h"
#include "scene_compile.h"
#include "common/system_frame.h"

using namespace cdsm;

namespace {

struct Maps : cdsm_test::SystemFrame {
  Scene scene;
  std::vector<Receiver> surfaces, samples;
  explicit Maps(float radius) : scene(load()) {
    scene.lights[0].radius = radius;
    build(scene);
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

// Light 0's lookups at `pts` in its first map (mode 3: the blocker search
// alone, penumbra_filter_radius), timed, as counter per_lookup.
void time_lookups(benchmark::State& state, const ShadowView& sv, const std::vector<Receiver>& pts, int mode) {
  const DsmVisibility vis{sv};
  const LightData& L = sv.lights[0];
  const DsmMap& map = sv.maps[L.first_map];
  double sink = 0.0;
  for (auto _ : state)
    for (const Receiver& r : pts)
      sink += mode == 3 ? double(penumbra_filter_radius(sv, L, map, project(map.view, r.p), r)) : double(vis(0, r).x);
  benchmark::DoNotOptimize(sink);
  state.counters["per_lookup"] = benchmark::Counter(double(state.iterations()) * double(pts.size()),
                                                    benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// arg 0: 0 hard (radius 0), 1 estimated (radius 0.15), 2 fixed kernel (radius 0.15), 3 the estimate's
// blocker search alone (penumbra_filter_radius), 4 estimated with penumbra_taps 5; arg 1: 0 surfaces, 1 samples.
void BM_Lookup(benchmark::State& state) {
  static Maps hard(0.0f), sized(0.15f);
  const int mode = int(state.range(0));
  Maps& m = mode == 0 ? hard : sized;
  ShadowView sv = m.frame.view(m.scene.shadows);
  if (mode == 2) sv.penumbra = Penumbra::FixedKernel;
  if (mode == 4) sv.penumbra_taps = 5;
  const std::vector<Receiver>& pts = state.range(1) == 0 ? m.surfaces : m.samples;
  time_lookups(state, sv, pts, mode);
  const char* names[] = {"hard", "estimated r=0.15", "fixed kernel r=0.15", "blocker search alone r=0.15",
                         "estimated r=0.15, 5 taps across"};
  state.SetLabel(std::string(names[mode]) + (state.range(1) == 0 ? ", surfaces" : ", volume samples"));
}

// BM_Lookup's points split by whether a blocker lies within a penumbra's
// reach of them (blockers_within_reach, radius 0.15): what a lookup costs
// where the pyramid dismisses the search, and where the search and the
// filter run. arg 0: 0 hard, 1 estimated, 3 the blocker search alone (as
// BM_Lookup); arg 1: 0 nothing within reach, 1 blockers within reach; arg
// 2: 0 surfaces, 1 samples. Counter n: the points.
void BM_LookupByReach(benchmark::State& state) {
  static Maps hard(0.0f), sized(0.15f);
  const int mode = int(state.range(0));
  const bool within = state.range(1) != 0;
  const ShadowView soft = sized.frame.view(sized.scene.shadows);
  const LightData& Ls = soft.lights[0];
  const DsmMap& ms = soft.maps[Ls.first_map];
  std::vector<Receiver> pts;
  for (const Receiver& r : state.range(2) == 0 ? sized.surfaces : sized.samples) {
    const ViewProjection pr = project(ms.view, r.p);
    const PenumbraFrame f = penumbra_frame(ms, pr);
    const float search =
        std::min(penumbra_radius(Ls, ms, pr.depth, std::max(ms.view.near, 1e-6f)), kPenumbraSearchTexels * f.texel);
    const bool maybe = ms.rgb ? blockers_within_reach<3>(soft, Ls, ms, pr, r, f, search)
                              : blockers_within_reach<1>(soft, Ls, ms, pr, r, f, search);
    if (maybe == within) pts.push_back(r);
  }
  Maps& m = mode == 0 ? hard : sized;
  const ShadowView sv = m.frame.view(m.scene.shadows);
  time_lookups(state, sv, pts, mode);
  state.counters["n"] = double(pts.size());
  const char* names[] = {"hard", "estimated r=0.15", "", "blocker search alone r=0.15"};
  state.SetLabel(std::string(names[mode]) + (within ? ", blockers within reach" : ", nothing within reach") +
                 (state.range(2) == 0 ? ", surfaces" : ", volume samples"));
}

// arg: 0 fom4, 1 fom8, 2 fom16, 3 mom4, 4 mom8.
void BM_SeriesReconstruction(benchmark::State& state) {
  const int mode = int(state.range(0));
  const int n = mode == 0 ? 4 : mode == 1 ? 8 : mode == 2 ? 16 : mode == 3 ? 4 : 8;
  const bool fourier = mode < 3;
  FourierSeries f(fourier ? n : 3);
  PowerMoments m(fourier ? 4 : n);
  uint32_t seed = 12345u;
  auto next = [&] { return double((seed = seed * 1664525u + 1013904223u) >> 8) / double(1u << 24); };
  for (int i = 0; i < 6; ++i) {
    const double u = next(), A = 0.05 + next();
    f.add_surface(u, A);
    m.add_surface(2.0 * u - 1.0, A);
  }
  f.store();
  m.store();
  const MomentBias bias = moment_bias(m.n);
  double sink = 0.0;
  const int depths = 4096;
  for (auto _ : state)
    for (int i = 0; i < depths; ++i) {
      const double u = (i + 0.5) / depths;
      if (fourier) {
        sink += f.optical_depth(u);
      } else {
        double lower, at;
        m.bound(2.0 * u - 1.0, bias, lower, at);
        sink += lower + at;
      }
    }
  benchmark::DoNotOptimize(sink);
  state.counters["per_lookup"] = benchmark::Counter(double(state.iterations()) * depths,
                                                    benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  const char* names[] = {"fom4", "fom8", "fom16", "mom4", "mom8"};
  state.SetLabel(std::string(names[mode]) + ": one texel, one depth");
}

void BM_CameraPass(benchmark::State& state) {
  const tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  Scene scene = Maps::load();
  scene.camera.width = 360;
  scene.camera.height = 240;
  const std::unique_ptr<ShadowSystem> system = cdsm_test::updated_system(scene);
  double fragments_ms = 0.0, pass_ms = 0.0;
  for (auto _ : state) {
    FrameStats st;
    benchmark::DoNotOptimize(system->render(&st));
    fragments_ms += st.times.camera_fragments_ms;
    pass_ms += st.times.camera_ms;
  }
  const double n = double(state.iterations());
  state.counters["camera_fragments_ms"] = fragments_ms / n;
  state.counters["camera_pass_ms"] = pass_ms / n;
  state.counters["per_pixel"] =
      benchmark::Counter(n * 360.0 * 240.0, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

}  // namespace

BENCHMARK(BM_CameraPass)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_SeriesReconstruction)->DenseRange(0, 4)->Unit(benchmark::kMillisecond)->MinTime(0.5);
BENCHMARK(BM_Lookup)->ArgsProduct({{0, 1, 2, 3, 4}, {0, 1}})->Unit(benchmark::kMillisecond)->MinTime(0.5);
BENCHMARK(BM_LookupByReach)->ArgsProduct({{0, 1, 3}, {0, 1}, {0, 1}})->Unit(benchmark::kMillisecond)->MinTime(0.3);
BENCHMARK_MAIN();
