// Fragment-list build time: the OpenGL rasterizer (llvmpipe here, a GPU
// where there is one) against the exact CPU ray caster, at 512^2 and
// 1024^2, on a small scene (~6k triangles) and on ~1M triangles (110
// spheres), and on a scene file's camera view when one is given. Scene
// upload and BVH build are outside the timed loop; the GL time includes
// read-back into FragmentBuffers.
//   bench_fragments [--scene=content/scenes/default.json] [--benchmark_filter=Gl]
#include <benchmark/benchmark.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "cdsm/scene_io.h"
#include "gl_test_util.h"
#include "common/system_frame.h"

namespace {

using cdsm::test::TestScene;

std::string g_scene_file;     // --scene=PATH
cdsm::Camera g_scene_camera;  // its camera

// 0: small test scene, 1: ~1M triangles, 2: the --scene file.
TestScene& scene(int which) {
  static std::unique_ptr<TestScene> scenes[3];
  std::unique_ptr<TestScene>& s = scenes[which];
  if (!s) {
    if (which == 0) {
      s = std::make_unique<TestScene>(cdsm::test::closed_meshes_scene());
    } else if (which == 1) {
      s = std::make_unique<TestScene>(cdsm::test::many_spheres_scene(110, 96, 48));
    } else {
      cdsm::Scene sc = cdsm::load_scene(g_scene_file);
      g_scene_camera = sc.camera;
      s = std::make_unique<TestScene>();
      s->sb = cdsm_test::compiled_scene(sc);
    }
  }
  return *s;
}

cdsm::PinholeView view_for(int which, int res) {
  if (which == 0) return cdsm::test::look_at({0.5f, 2.5f, 6.5f}, {0, 0.6f, 0}, {0, 1, 0}, 50.0f, res, res, 0.1f, 50.0f);
  if (which == 1) return cdsm::test::look_at({0.0f, 9.0f, 11.0f}, {0, 0, 0}, {0, 1, 0}, 50.0f, res, res, 0.1f, 60.0f);
  const cdsm::Camera& c = g_scene_camera;  // square view with the camera's vertical field of view
  return cdsm::test::look_at(c.position, c.target, c.up, c.fov_y_deg, res, res, c.near, c.far);
}

struct GlState {
  std::unique_ptr<cdsm::gl::Context> context;
  std::string reason;
  std::unique_ptr<cdsm::gl::FragmentRasterizer> raster;
  int uploaded = -1;
};

GlState& gl_state() {
  static GlState s;
  if (!s.context && s.reason.empty()) {
    s.context = cdsm::gl::create_headless_context({}, &s.reason);
    if (s.context) {
      std::fprintf(stderr, "GL: %s\n", s.context->description().c_str());
      s.raster = std::make_unique<cdsm::gl::FragmentRasterizer>(*s.context);
    }
  }
  return s;
}

void set_counters(benchmark::State& st, const TestScene& s, const cdsm::FragmentBuffers& out) {
  st.counters["triangles"] = double(s.sb.tri_object.size());
  st.counters["fragments"] = double(out.total());
  st.counters["frag/px"] = double(out.total()) / double(uint64_t(out.width) * uint64_t(out.height));
  st.counters["Mfrag/s"] =
      benchmark::Counter(double(out.total()) * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
}

// Args: scene (0 small, 1 ~1M triangles), resolution.
void BM_Gl(benchmark::State& st) {
  GlState& g = gl_state();
  if (!g.context) {
    st.SkipWithError(g.reason.c_str());
    return;
  }
  const int which = int(st.range(0)), res = int(st.range(1));
  TestScene& s = scene(which);
  g.context->make_current();
  if (g.uploaded != which) {
    s.upload(*g.raster);
    g.uploaded = which;
  }
  cdsm::PinholeView v = view_for(which, res);
  cdsm::FragmentBuffers out;
  g.raster->rasterize(v, {}, out);  // warm-up: pool growth, shader compile
  for (auto _ : st) {
    g.raster->rasterize(v, {}, out);
    benchmark::DoNotOptimize(out.fragments.data());
  }
  set_counters(st, s, out);
  st.counters["tiles"] = g.raster->stats().tiles;
}

void BM_Cpu(benchmark::State& st) {
  const int which = int(st.range(0)), res = int(st.range(1));
  TestScene& s = scene(which);
  cdsm::PinholeView v = view_for(which, res);
  cdsm::FragmentBuffers out;
  for (auto _ : st) {
    s.cast(v, {}, out);
    benchmark::DoNotOptimize(out.fragments.data());
  }
  set_counters(st, s, out);
}

void args(benchmark::internal::Benchmark* b) {
  const int scenes = g_scene_file.empty() ? 2 : 3;
  for (int which = 0; which < scenes; ++which)
    for (int res : {512, 1024}) b->Args({which, res});
  b->ArgNames({"scene", "res"})->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(1.0);
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    std::string a = argv[i];
    if (a.rfind("--scene=", 0) == 0)
      g_scene_file = a.substr(8);
    else
      rest.push_back(argv[i]);
  }
  int n = int(rest.size());
  benchmark::Initialize(&n, rest.data());
  benchmark::RegisterBenchmark("BM_Gl", BM_Gl)->Apply(args);
  benchmark::RegisterBenchmark("BM_Cpu", BM_Cpu)->Apply(args);
  std::fprintf(stderr, "scenes: 0 = test scene (%zu triangles), 1 = 110 spheres (~1M triangles)%s\n",
               scene(0).sb.tri_object.size(), g_scene_file.empty() ? "" : (", 2 = " + g_scene_file).c_str());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
