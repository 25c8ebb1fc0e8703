// The GPU kit's benchmark (issue 16 items 3, 5, 7, 10; scripts/gpu/run_kit.sh):
// on the default scene with 4 clusters at 512^2, at 1280x720 and 1920x1080,
//   - per-stage times of one frame on the cpu and the cuda backend (FrameStats,
//     wall clock) and the cuda backend's per-launch times (CUDA events);
//   - the GL fragment pass against the CUDA fragment producer (camera view);
//   - the light pass: two-pass (count -> reserve -> write) against one pass
//     into per-thread buffers of 64 nodes with re-compression (staged);
//   - the CUDA/CPU ratio of the same frame.
// Writes Markdown and JSON to --out DIR. Not a test: figures only.
//
//   bench_gpu [--out DIR] [--scene FILE] [--repeat N]
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cdsm/renderer.h"
#include "cdsm/scene_io.h"
#include "backend/backend.h"
#include "cuda_backend.h"
#include "device.h"
#include "common/system_frame.h"
#include "frame.h"

using namespace cdsm;
using Clock = std::chrono::steady_clock;

namespace {

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// One cold frame (a new Renderer: every map built) on `backend`; its stage times.
nlohmann::json frame_times(const Scene& s, Backend backend, FragmentSource frags, int repeat) {
  std::vector<double> fr, build, camf, cam, total;
  FrameStats st;
  for (int i = 0; i < repeat; ++i) {
    Renderer r;
    RenderOptions o;
    o.backend = backend;
    o.fragments = frags;
    r.render(s, o, &st);
    fr.push_back(st.times.fragments_ms);
    build.push_back(st.times.dsm_build_ms);
    camf.push_back(st.times.camera_fragments_ms);
    cam.push_back(st.times.camera_ms);
    total.push_back(st.times.total_ms);
  }
  nlohmann::json j;
  j["fragment_source"] = st.fragment_source;
  j["light_fragments_ms"] = median(fr);
  j["dsm_build_ms"] = median(build);
  j["camera_fragments_ms"] = median(camf);
  j["camera_pass_ms"] = median(cam);
  j["total_ms"] = median(total);
  j["maps"] = st.maps_rebuilt;
  j["nodes"] = st.memory.nodes;
  return j;
}

// The frame's maps on the cuda backend with a first walk into buffers of
// k nodes, with CUDA event times per launch (a ShadowSystem on that backend).
nlohmann::json light_pass_walk(const Scene& s, int k) {
  ShadowSystem sys(cdsm_test::cpu_system_options());
  SystemHooks::wrap_backend(sys, [k](std::unique_ptr<ShadowBackend>) {
    std::unique_ptr<exec::ExecShadowBackend> gpu = cuda::make_cuda_backend();
    gpu->light_pass().walk_nodes = k;
    return std::unique_ptr<ShadowBackend>(std::move(gpu));
  });
  sync_scene(sys, s);
  sys.update();  // the first build includes allocations: measure a second one
  sys.reset_maps();
  FrameStats st;
  const auto t0 = Clock::now();
  sys.update(&st);
  const double wall = ms_since(t0);
  nlohmann::json j;
  double kernels = 0.0;
  uint64_t recompressed = 0, rewalked = 0;
  for (const KernelTime& t : st.times.kernels) {
    if (t.name.rfind("light pass", 0) == 0) {
      j["launches"][t.name] = t.ms;
      kernels += t.ms;
    }
  }
  for (const DsmBuildStats& m : FrameSnapshot(sys).frame().map_stats) {
    recompressed += m.overflow_texels;
    rewalked += m.rewalked_texels;
  }
  j["light_pass_kernels_ms"] = kernels;
  j["build_wall_ms_with_fragments"] = wall;
  j["recompressed_texels"] = recompressed;
  j["rewalked_texels"] = rewalked;
  return j;
}

// Camera-view fragment lists: the CUDA producer (events) against the GL rasterizer (wall clock).
nlohmann::json fragment_producers(const Scene& s, const SceneBuffers& sb, int repeat) {
  nlohmann::json j;
  std::unique_ptr<exec::ExecShadowBackend> gpu = cuda::make_cuda_backend();
  gpu->update_scene(sb, SceneChange::all());
  const PinholeView cam = camera_view(s.camera);
  const ListsId first = gpu->cast_lists(cam, ObjectMask{});  // warm-up
  const uint64_t fragments = gpu->lists_fragments(first);
  gpu->free_lists(first);
  gpu->take_stage_times();
  const auto t0 = Clock::now();
  for (int i = 0; i < repeat; ++i) gpu->free_lists(gpu->cast_lists(cam, ObjectMask{}));  // the lists stay on the device
  double kernels = 0.0;
  for (const exec::StageTime& t : gpu->take_stage_times())  // (synchronizes)
    if (t.name.rfind("fragments", 0) == 0 || t.name.rfind("scan", 0) == 0) kernels += t.ms;
  j["cuda_wall_ms"] = ms_since(t0) / repeat;
  j["cuda_kernels_ms"] = kernels / repeat;
  j["fragments"] = fragments;
  // GL: the Renderer's camera fragments with the GL producer (read back to the host as the frame does).
  // A GL failure is a figure of the report (and the exit status), not the end of it.
  try {
    nlohmann::json gl = frame_times(s, Backend::Cpu, FragmentSource::Gl, repeat);
    j["gl_source"] = gl["fragment_source"];
    j["gl_camera_fragments_ms"] = gl["camera_fragments_ms"];
    j["gl_light_fragments_ms"] = gl["light_fragments_ms"];
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_gpu: GL fragments failed: %s\n", e.what());
    j["gl_error"] = e.what();
    j["gl_source"] = "failed";
    j["gl_camera_fragments_ms"] = -1.0;
    j["gl_light_fragments_ms"] = -1.0;
  }
  return j;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out = "bench-gpu", scene_path = std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/default.json";
  int repeat = 3;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--out" && i + 1 < argc)
      out = argv[++i];
    else if (a == "--scene" && i + 1 < argc)
      scene_path = argv[++i];
    else if (a == "--repeat" && i + 1 < argc)
      repeat = std::max(1, std::atoi(argv[++i]));
    else {
      std::fprintf(stderr, "usage: bench_gpu [--out DIR] [--scene FILE] [--repeat N]\n");
      return 2;
    }
  }
  const cuda::DeviceInfo dev = cuda::probe_device();
  if (!dev.available) {
    std::fprintf(stderr, "bench_gpu: %s\n", dev.description.c_str());
    return 1;
  }
  std::filesystem::create_directories(out);
  nlohmann::json all;
  all["device"] = dev.description;
  all["scene"] = scene_path;
  std::string md = "# GPU benchmark\n\nDevice: " + dev.description + "; scene " + scene_path +
                   ", 4 clusters at 512², median of " + std::to_string(repeat) + " cold frames.\n\n";
  md +=
      "| resolution | backend | fragments (light) ms | DSM build ms | camera fragments ms | camera pass ms | total ms "
      "|\n"
      "|---|---|---|---|---|---|---|\n";
  std::string md2, md3;
  bool gl_failed = false;
  for (const auto& wh : {std::pair<int, int>{1280, 720}, std::pair<int, int>{1920, 1080}}) {
    Scene s = load_scene(scene_path);
    s.shadows.max_clusters = 4;
    s.shadows.resolution = 512;
    s.camera.width = wh.first;
    s.camera.height = wh.second;
    const std::string res = std::to_string(wh.first) + "x" + std::to_string(wh.second);
    nlohmann::json r;
    r["cpu"] = frame_times(s, Backend::Cpu, FragmentSource::Cpu, repeat);
    r["cuda"] = frame_times(s, Backend::Cuda, FragmentSource::Cpu, repeat);
    // The whole frame on the device: fragment lists from the CUDA ray caster too.
    r["cuda+cuda fragments"] = frame_times(s, Backend::Cuda, FragmentSource::Cuda, repeat);
    for (const char* b : {"cpu", "cuda", "cuda+cuda fragments"}) {
      const nlohmann::json& t = r[b];
      char line[256];
      std::snprintf(line, sizeof line, "| %s | %s | %.1f | %.1f | %.1f | %.1f | %.1f |\n", res.c_str(), b,
                    t["light_fragments_ms"].get<double>(), t["dsm_build_ms"].get<double>(),
                    t["camera_fragments_ms"].get<double>(), t["camera_pass_ms"].get<double>(),
                    t["total_ms"].get<double>());
      md += line;
    }
    const double build_ratio =
        r["cpu"]["dsm_build_ms"].get<double>() / std::max(1e-6, r["cuda"]["dsm_build_ms"].get<double>());
    const double cam_ratio =
        r["cpu"]["camera_pass_ms"].get<double>() / std::max(1e-6, r["cuda"]["camera_pass_ms"].get<double>());
    r["cpu_over_cuda"] = {{"dsm_build", build_ratio}, {"camera_pass", cam_ratio}};
    SceneBuffers sb = cdsm_test::compiled_scene(s);
    r["fragments"] = fragment_producers(s, sb, repeat);
    r["light_pass"]["k32"] = light_pass_walk(s, 32);
    r["light_pass"]["k64"] = light_pass_walk(s, 64);
    char line[512];
    std::snprintf(line, sizeof line, "| %s | %.2fx | %.2fx | %.2f | %.2f | %s %.2f / %.2f |\n", res.c_str(),
                  build_ratio, cam_ratio, r["fragments"]["cuda_kernels_ms"].get<double>(),
                  r["fragments"]["cuda_wall_ms"].get<double>(), r["fragments"]["gl_source"].get<std::string>().c_str(),
                  r["fragments"]["gl_camera_fragments_ms"].get<double>(),
                  r["fragments"]["gl_light_fragments_ms"].get<double>());
    md2 += line;
    std::snprintf(line, sizeof line, "| %s | %.2f | %llu | %.2f | %llu |\n", res.c_str(),
                  r["light_pass"]["k32"]["light_pass_kernels_ms"].get<double>(),
                  (unsigned long long)r["light_pass"]["k32"]["rewalked_texels"].get<uint64_t>(),
                  r["light_pass"]["k64"]["light_pass_kernels_ms"].get<double>(),
                  (unsigned long long)r["light_pass"]["k64"]["rewalked_texels"].get<uint64_t>());
    md3 += line;
    gl_failed = gl_failed || r["fragments"].contains("gl_error");
    all[res] = r;
    std::fprintf(stderr, "bench_gpu: %s done\n", res.c_str());
  }
  md +=
      "\n| resolution | CPU/CUDA DSM build | CPU/CUDA camera pass | CUDA fragments kernels ms | CUDA fragments wall ms "
      "(lists kept on the device) | GL (producer) camera / light-view fragments ms |\n"
      "|---|---|---|---|---|---|\n" +
      md2;
  md +=
      "\nLight pass (all maps of the frame, CUDA events):\n\n"
      "| resolution | first walk into 32 nodes: ms | texels walked twice | into 64 nodes: ms | texels walked twice |\n"
      "|---|---|---|---|---|\n" +
      md3;
  std::ofstream(out + "/bench_gpu.md") << md;
  std::ofstream(out + "/bench_gpu.json") << all.dump(2) << "\n";
  std::fputs(md.c_str(), stdout);
  return gl_failed ? 1 : 0;
}
