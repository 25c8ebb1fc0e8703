// Warm frames as an engine runs them (issue 45 item 7), the same scenario
// code for the CPU threads and the CUDA device (--backend):
//   build/tests/gl/bench_warm [--backend cpu|cuda|auto] [--frames N]
//                                [--width W --height H] [--scene NAME]...
// ($CDSM_CONTENT_DIR: where scenes/NAME.json is, default this tree's content/)
//   build/tests/gl/bench_warm_gl_host --backend gl-host ...  (below: Options)
// One ShadowSystem on the program's own GL context (GlContextUse::Application,
// GL fragments), warmed up, then per scenario N frames of: the change,
// update(), bind_gl(program), closed by glFinish (the CUDA stream is
// synchronized inside update() where it reads back). Scenarios on
// default.json (4 clusters, 512²) and sun_clouds.json: nothing changed, a
// camera orbit of 0.05° a frame (clusters kept), one of 2° a frame
// (clusters move), one object moved, one light moved, epsilon changed.
// Prints one row per scenario: wall time of update()+bind_gl() (median,
// 10th and 90th percentile), of update() alone and the kernel time
// (medians), maps rebuilt, and the
// FrameStats counters per frame (host synchronizations, backend and GL
// allocations, launches, GL read-backs, bytes each way).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

#include "cdsm/gl.h"
#include "cdsm/scene_io.h"
#include "cdsm/shadow_system.h"
#include "gl/context.h"
#include "gl/gl_api.h"
#include "forward_internal.h"
#include "scene_sync.h"
#ifndef CDSM_BENCH_GL_HOST
#define CDSM_BENCH_GL_HOST 0
#endif
#if CDSM_BENCH_GL_HOST
#include "backend/exec_backend.h"
#include "frame_snapshot.h"
#include "gl_host_exec.h"
#endif

using namespace cdsm;

namespace {

struct Options {
  Backend backend = Backend::Auto;
  // --backend gl-host (bench_warm_gl_host): the exec backend over CPU
  // threads with the cuda backend's GL hand-over (tests/gl/gl_host_exec.h):
  // the device path's structure (what waits, what is read back or
  // allocated) counted here; its times are the CPU's, with each GL mapping
  // a copy.
  bool gl_host = false;
  int frames = 100;
  int width = 1920, height = 1080;
  std::vector<std::string> scenes;
};

struct Scenario {
  const char* name;
  std::function<void(ShadowSystem&, const Scene&, int)> change;  // before frame `f`
};

void orbit(ShadowSystem& sys, const Camera& c0, float degrees_per_frame, int f) {
  Camera c = c0;
  const float a = degrees_per_frame * 0.0174533f * float(f + 1);
  const Vec3 d = c.position - c.target;
  c.position = c.target + Vec3{d.x * std::cos(a) - d.z * std::sin(a), d.y, d.x * std::sin(a) + d.z * std::cos(a)};
  sys.set_camera(c);
}

std::vector<Scenario> scenarios() {
  return {
      {"unchanged", [](ShadowSystem&, const Scene&, int) {}},
      {"orbit_kept", [](ShadowSystem& sys, const Scene& s, int f) { orbit(sys, s.camera, 0.05f, f); }},
      {"orbit_moving", [](ShadowSystem& sys, const Scene& s, int f) { orbit(sys, s.camera, 2.0f, f); }},
      {"object_moved",
       [](ShadowSystem& sys, const Scene& s, int f) {
         for (size_t i = 0; i < s.objects.size(); ++i)
           if (s.objects[i].casts_shadows) {
             Mat4 t = s.objects[i].transform;
             t.m[0][3] += 0.01f * float(f % 2 ? -1 : 1);
             sys.set_transform(sys.objects()[i], t);
             return;
           }
       }},
      {"light_moved",
       [](ShadowSystem& sys, const Scene& s, int f) {
         Light l = s.lights[0];
         if (l.type == LightType::Directional)
           l.direction = normalize(l.direction + Vec3{0.002f * float(f % 2 ? -1 : 1), 0, 0});
         else
           l.position = l.position + Vec3{0.01f * float(f % 2 ? -1 : 1), 0, 0};
         sys.set_light(sys.lights()[0], l);
       }},
      {"epsilon",
       [](ShadowSystem& sys, const Scene& s, int f) {
         ShadowSettings x = s.shadows;
         x.epsilon = s.shadows.epsilon * (f % 2 ? 1.0f : 0.5f);
         sys.set_settings(x);
       }},
  };
}

Scene bench_scene(const std::string& name, const Options& o) {
  const char* dir = std::getenv("CDSM_CONTENT_DIR");  // the GPU kit runs it away from this tree
  Scene s = load_scene(std::string(dir ? dir : CDSM_CONTENT_DIR_BENCH) + "/scenes/" + name + ".json");
  s.camera.width = o.width;
  s.camera.height = o.height;
  if (name == "default") {
    s.shadows.max_clusters = 4;
    s.shadows.resolution = 512;
  }
  return s;
}

// A compute program that reads the maps through cdsm.glsl (compiled for
// the maps' node layout), so bind_gl() binds what a shader of the
// application's would.
GLuint lookup_program(int layout) {
  return forward::link({forward::compile(GL_COMPUTE_SHADER,
                                         "layout(local_size_x = 1) in;\n"
                                         "layout(std430, binding = 15) buffer Out { vec4 result; };\n"
                                         "void main() { result = vec4(cdsm_surface_transmittance(vec3(0.0),\n"
                                         "    vec3(0.0, 1.0, 0.0), CDSM_NO_OBJECT, 0), 1.0); }\n",
                                         layout)});
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[size_t(std::lround(q * double(v.size() - 1)))];
}

void run_scene(const std::string& name, const Options& o, GLuint& program, bool& header) {
  const Scene scene = bench_scene(name, o);
  for (const Scenario& sc : scenarios()) {
    SystemOptions so;
    so.gl_context = GlContextUse::Application;
    so.fragments = FragmentSource::Gl;
    so.backend = o.backend;
    so.source = name;
    ShadowSystem sys(so);
#if CDSM_BENCH_GL_HOST
    if (o.gl_host)
      SystemHooks::wrap_backend(sys, [](std::unique_ptr<ShadowBackend>) {
        return std::unique_ptr<ShadowBackend>(std::make_unique<exec::ExecBackend<test::GlHostExec>>("gl-host"));
      });
#endif
    sync_scene(sys, scene);
    FrameStats st;
    for (int f = -3; f < 0; ++f) {  // warm-up: the first build, then the change twice
      if (f > -3) sc.change(sys, scene, f + 1000);
      sys.update(&st);
      if (!program) program = lookup_program(int(sys.gl_buffers().layout));
      sys.bind_gl(program);
      glFinish();
    }
    std::vector<double> wall, update, kernels;
    double rebuilt = 0;
    FrameCounters sum;
    uint64_t up = 0, down = 0;
    for (int f = 0; f < o.frames; ++f) {
      sc.change(sys, scene, f);
      const auto t0 = std::chrono::steady_clock::now();
      sys.update(&st);
      update.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      sys.bind_gl(program);
      glFinish();
      wall.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      kernels.push_back(st.times.kernel_fragments_ms + st.times.kernel_dsm_build_ms);
      rebuilt += st.maps_rebuilt;
      sum.host_syncs += st.counters.host_syncs;
      sum.backend_allocations += st.counters.backend_allocations;
      sum.launches += st.counters.launches;
      sum.gl_readbacks += st.counters.gl_readbacks;
      sum.gl_allocations += st.counters.gl_allocations;
      up += st.update.host_to_backend_bytes;
      down += st.update.backend_to_host_bytes;
    }
    if (!header) {
      std::printf("%-11s %-13s %-5s %6s %9s %9s %9s %9s %9s %7s %7s %7s %8s %7s %7s %11s %11s\n", "scene", "scenario",
                  "backend", "frames", "median_ms", "p10_ms", "p90_ms", "update_ms", "kernel_ms", "rebuilt", "syncs",
                  "allocs", "launches", "gl_rb", "gl_alloc", "up_bytes", "down_bytes");
      header = true;
    }
    const double n = double(o.frames);
    std::printf(
        "%-11s %-13s %-5s %6d %9.3f %9.3f %9.3f %9.3f %9.3f %7.2f %7.2f %7.2f %8.2f %7.2f %7.2f %11.0f %11.0f\n",
        name.c_str(), sc.name, st.backend.c_str(), o.frames, percentile(wall, 0.5), percentile(wall, 0.1),
        percentile(wall, 0.9), percentile(update, 0.5), percentile(kernels, 0.5), rebuilt / n,
        double(sum.host_syncs) / n, double(sum.backend_allocations) / n, double(sum.launches) / n,
        double(sum.gl_readbacks) / n, double(sum.gl_allocations) / n, double(up) / n, double(down) / n);
    std::fflush(stdout);
  }
}

[[noreturn]] void usage(const std::string& why) {
  std::fprintf(stderr,
               "bench_warm: %s\nusage: bench_warm [--backend cpu|cuda|auto] [--frames N] [--width W] [--height H] "
               "[--scene NAME]...\n",
               why.c_str());
  std::exit(2);
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) usage("'" + a + "' needs a value");
    const std::string v = argv[++i];
    if (a == "--backend") {
      if (v == "cpu")
        o.backend = Backend::Cpu;
      else if (v == "cuda")
        o.backend = Backend::Cuda;
      else if (v == "auto")
        o.backend = Backend::Auto;
      else if (v == "gl-host" && CDSM_BENCH_GL_HOST)
        o.backend = Backend::Cpu, o.gl_host = true;
      else if (v == "gl-host")
        usage("--backend gl-host is build/tests/gl/bench_warm_gl_host's");
      else
        usage("--backend takes cpu, cuda, auto or gl-host, got '" + v + "'");
    } else if (a == "--frames" || a == "--width" || a == "--height") {
      char* end = nullptr;
      const long n = std::strtol(v.c_str(), &end, 10);
      if (*end != '\0' || n < 1 || n > 100000) usage(a + " takes a positive integer, got '" + v + "'");
      (a == "--frames" ? o.frames : a == "--width" ? o.width : o.height) = int(n);
    } else if (a == "--scene") {
      o.scenes.push_back(v);
    } else {
      usage("unknown option '" + a + "'");
    }
  }
  if (o.scenes.empty()) o.scenes = {"default", "sun_clouds"};
  std::string reason;
  std::unique_ptr<gl::Context> ctx = gl::create_headless_context({}, &reason);
  if (!ctx) {
    std::fprintf(stderr, "bench_warm: no GL 4.5 context: %s\n", reason.c_str());
    return 1;
  }
  try {
    GLuint program = 0;  // made after the first update(), for the maps' layout
    bool header = false;
    for (const std::string& s : o.scenes) run_scene(s, o, program, header);
    glDeleteProgram(program);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_warm: %s\n", e.what());
    return 1;
  }
  return 0;
}
