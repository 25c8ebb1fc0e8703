// cdsm_forward: an application's forward renderer that gets translucent and
// volumetric shadows from cdsm through the public API and cdsm.glsl only
// (forward_renderer.h). Headless by default (EGL: llvmpipe without a GPU).
//
//   cdsm_forward SCENE.json -o out.png [--width W --height H] [--frames N]
//                [--raw out.pfm] [--mask mask.pgm] [--no-shadows] [--window]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "cdsm/cdsm.h"
#include "cdsm/gl.h"
#include "cdsm/gl_window.h"
#include "forward_renderer.h"

namespace {

const char* const kUsage =
    "usage: cdsm_forward SCENE -o OUT.png [options]\n"
    "  --width W --height H  image size (default: the scene camera's)\n"
    "  --frames N            render N frames of the unchanged scene and report the mean time of frames 2..N\n"
    "  --raw FILE.pfm        the linear float image (Portable Float Map)\n"
    "  --mask FILE.pgm       255 where only opaque surfaces were drawn\n"
    "  --no-shadows          every light unshadowed (to see what the maps change)\n"
    "  --lookup-every N      volume samples per shadow lookup (default 1: every sample)\n"
    "  --light-grid N        volumes take the lights' transmittance from a grid per volume (a texel per\n"
    "                        N voxels per axis), computed when the maps change, not a lookup per sample\n"
    "  --step-scale S        volume march steps S times the scene's (default 1)\n"
    "  --window              a GLFW window instead of a headless context\n";

void write_pfm(const cdsm::Image& img, const std::string& path) {
  std::ofstream f(path, std::ios::binary);
  f << "PF\n" << img.width << " " << img.height << "\n-1.0\n";
  for (int y = img.height - 1; y >= 0; --y)  // PFM rows go bottom to top
    f.write(reinterpret_cast<const char*>(img.rgb.data() + size_t(y) * img.width * 3), std::streamsize(img.width) * 12);
  if (!f) throw cdsm::Error(path, "cannot write");
}

void write_pgm(const std::vector<unsigned char>& mask, int w, int h, const std::string& path) {
  std::ofstream f(path, std::ios::binary);
  f << "P5\n" << w << " " << h << "\n255\n";
  for (unsigned char m : mask) f.put(char(m ? 255 : 0));
  if (!f) throw cdsm::Error(path, "cannot write");
}

int parse_int(const std::string& opt, const std::string& v) {
  char* end = nullptr;
  const long n = std::strtol(v.c_str(), &end, 10);
  if (v.empty() || *end != '\0' || n < 1 || n > 16384)
    throw cdsm::Error(opt, "needs a whole number in 1..16384, got '" + v + "'");
  return int(n);
}

float parse_float(const std::string& opt, const std::string& v) {
  char* end = nullptr;
  const float x = std::strtof(v.c_str(), &end);
  if (v.empty() || *end != '\0' || !(x >= 1.0f && x <= 16.0f))
    throw cdsm::Error(opt, "needs a number in 1..16, got '" + v + "'");
  return x;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  std::string scene_path, out, raw, mask_path;
  int width = 0, height = 0, frames = 1, lookup_every = 1, light_grid = 0;
  float step_scale = 1.0f;
  bool shadows_on = true, window = false;
  try {
    for (size_t i = 0; i < args.size(); ++i) {
      const std::string& a = args[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= args.size()) throw cdsm::Error(a, "needs a value");
        return args[++i];
      };
      if (a == "-o")
        out = value();
      else if (a == "--width")
        width = parse_int(a, value());
      else if (a == "--height")
        height = parse_int(a, value());
      else if (a == "--frames")
        frames = parse_int(a, value());
      else if (a == "--raw")
        raw = value();
      else if (a == "--mask")
        mask_path = value();
      else if (a == "--no-shadows")
        shadows_on = false;
      else if (a == "--lookup-every")
        lookup_every = parse_int(a, value());
      else if (a == "--step-scale")
        step_scale = parse_float(a, value());
      else if (a == "--light-grid")
        light_grid = parse_int(a, value());
      else if (a == "--window")
        window = true;
      else if (a == "--help" || a == "-h") {
        std::fputs(kUsage, stdout);
        return 0;
      } else if (!a.empty() && a[0] == '-')
        throw cdsm::Error(a, "unknown option (cdsm_forward --help)");
      else
        scene_path = a;
    }
    if (scene_path.empty() || out.empty()) {
      std::fputs(kUsage, stderr);
      return 2;
    }

    // The application's context: the renderer and the shadow system share it.
    std::string why;
    std::unique_ptr<cdsm::GlWindow> win =
        window ? cdsm::GlWindow::create(width ? width : 720, height ? height : 480, "cdsm_forward", true, &why)
               : nullptr;
    std::unique_ptr<cdsm::GlContext> headless = window ? nullptr : cdsm::GlContext::create_headless(&why);
    cdsm::GlContext* context = win ? win.get() : headless.get();
    if (!context) throw cdsm::Error("OpenGL", "no 4.5 context: " + why);
    std::fprintf(stderr, "cdsm_forward: %s\n", context->description().c_str());

    cdsm::Scene scene = cdsm::load_scene(scene_path);
    if (width) scene.camera.width = width;
    if (height) scene.camera.height = height;

    // The shadow system on this context; the renderer's own buffers hold
    // the meshes, and the system reads them back once from there.
    cdsm::SystemOptions options;
    options.gl_context = cdsm::GlContextUse::Application;
    options.source = scene.source;
    cdsm::ShadowSystem shadows(options);
    forward::ForwardRenderer renderer;
    std::vector<std::string> notes;
    renderer.upload(scene, &notes);
    for (const std::string& n : notes) std::fprintf(stderr, "cdsm_forward: note: %s\n", n.c_str());
    std::vector<cdsm::VolumeHandle> volumes;
    for (const cdsm::Volume& v : scene.volumes) volumes.push_back(shadows.add_volume(v));
    for (size_t i = 0; i < scene.objects.size(); ++i) {
      cdsm::Object o = scene.objects[i];
      o.mesh = shadows.read_gl_mesh(renderer.mesh_source(scene, i));
      shadows.add_object(o,
                         o.interior == cdsm::InteriorKind::Volume ? volumes[size_t(o.volume)] : cdsm::VolumeHandle{});
    }
    for (const cdsm::Light& l : scene.lights) shadows.add_light(l);
    shadows.set_camera(scene.camera);
    shadows.set_settings(scene.shadows);
    shadows.set_background(scene.background);

    forward::DrawOptions draw;
    draw.shadows = shadows_on;
    draw.volume_lookup_every = lookup_every;
    draw.volume_shadows = light_grid > 0 ? forward::VolumeShadows::LightGrid : forward::VolumeShadows::PerSample;
    draw.light_grid_voxels = std::max(light_grid, 1);
    draw.volume_step_scale = step_scale;
    using Clock = std::chrono::steady_clock;
    double sum_total = 0.0, sum_draw = 0.0, sum_update = 0.0;
    int later_grids = 0;  // light grids recomputed after frame 1 (none: nothing changed)
    for (int f = 0; f < frames; ++f) {
      cdsm::FrameStats st;
      const auto t0 = Clock::now();
      shadows.update(&st);  // maps reused unless something changed
      if (st.maps_rebuilt > 0 || st.update.gl_map_upload_bytes > 0) ++draw.maps_version;  // (the light grids)
      const double update_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      const forward::FrameTimes t = renderer.draw(shadows, scene, scene.camera, draw);
      const double total_ms = update_ms + t.draw_ms;
      if (f == 0) {
        std::printf(
            "frame 1: %.1f ms (shadow update %.1f ms: %u maps built, %.1f KiB uploaded to GL, %.1f KiB read back "
            "from the application's buffers; draw %.1f ms, of it %d light grids %.1f ms)\n",
            total_ms, update_ms, st.maps_rebuilt, double(st.update.gl_map_upload_bytes) / 1024.0,
            double(st.update.gl_readback_bytes) / 1024.0, t.draw_ms, t.light_grids, t.light_grid_ms);
      } else {
        sum_total += total_ms;
        sum_draw += t.draw_ms;
        sum_update += update_ms;
        later_grids += t.light_grids;
        if (st.update.gl_map_upload_bytes != 0)
          std::printf("frame %d: %llu bytes uploaded although nothing changed\n", f + 1,
                      (unsigned long long)st.update.gl_map_upload_bytes);
      }
      for (const std::string& w : st.warnings) std::fprintf(stderr, "cdsm_forward: warning: %s\n", w.c_str());
    }
    if (frames > 1)
      std::printf(
          "frames 2..%d: mean %.2f ms (shadow update %.3f ms, draw %.2f ms) at %dx%d; light grids recomputed %d\n",
          frames, sum_total / (frames - 1), sum_update / (frames - 1), sum_draw / (frames - 1), scene.camera.width,
          scene.camera.height, later_grids);

    const cdsm::Image img = renderer.read_color();
    cdsm::write_png(img, out);
    if (!raw.empty()) write_pfm(img, raw);
    if (!mask_path.empty()) write_pgm(renderer.read_opaque_mask(), img.width, img.height, mask_path);
    if (window) {
      while (!win->should_close()) {
        cdsm::FrameStats st;
        shadows.update(&st);
        if (st.maps_rebuilt > 0 || st.update.gl_map_upload_bytes > 0) ++draw.maps_version;
        renderer.draw(shadows, scene, scene.camera, draw);
        renderer.present(0, 0, scene.camera.width, scene.camera.height);
        win->swap_buffers();
      }
    }
    return 0;
  } catch (const cdsm::Error& e) {
    std::fprintf(stderr, "cdsm_forward: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "cdsm_forward: error: %s\n", e.what());
    return 1;
  }
}
