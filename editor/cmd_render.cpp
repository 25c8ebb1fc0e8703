// cdsm render: one frame, its cost, and (on request) its error.
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <unistd.h>

#include "cdsm/cdsm.h"
#include "commands.h"

namespace cdsm::cli {
namespace {

const char* kRenderHelp =
    "usage: cdsm render SCENE.json -o OUT.png [options]\n"
    "\n"
    "Renders the scene's camera view with deep shadow maps and prints per-stage times\n"
    "(fragments, DSM build, camera pass), DSM memory and nodes per texel.\n"
    "\n"
    "options:\n"
    "  -o, --output PATH        PNG to write (required; never the scene file itself)\n"
    "  --backend cuda|cpu|reference  deep shadow maps on a CUDA device or on the CPU, or the exact\n"
    "                           reference (shadow rays, no maps). Default: cuda when a CUDA device\n"
    "                           exists, else cpu (stderr says which and why)\n"
    "  --fragments auto|gl|cpu|cuda  fragment producer: OpenGL rasterizer, CPU ray caster, or the ray\n"
    "                           caster on the CUDA device (with --backend cuda) (default auto:\n"
    "                           gl when an OpenGL 4.5 context can be created)\n"
    "  --eps E                  compression error bound epsilon (>= 0), overrides the scene\n"
    "  --dsm-res N              DSM resolution per side (4..8192), overrides the scene\n"
    "  --width W --height H     image size, overrides the scene camera\n"
    "  --filtering on|off       bilinear DSM lookups (default: the scene's setting)\n"
    "  --clusters M             at most M clustered DSMs per light (1 = unclustered), overrides the scene\n"
    "  --d0 D                   clustering distance threshold in normalized light-map units\n"
    "  --splits N               baseline: N parallel-split (cascaded) maps per spot light instead of clusters\n"
    "  --layout packed|fixed|chunked  DSM memory layout (packed: exact allocation; fixed: res x res x L,\n"
    "                           --fixed-layers L; chunked: 64-node chunks linked per texel)\n"
    "  --fixed-layers L         node layers of the fixed layout (default 32)\n"
    "  --receiver plane|slope_bias  how surfaces look themselves up: per-tap receiver planes (default),\n"
    "                           or the previous constant + slope-scaled bias (a baseline)\n"
    "  --compare-reference      also render the exact reference of the same view; report the\n"
    "                           transmittance error at sampled shaded points (mean, p99, max, RMSE)\n"
    "                           and the image RMSE/PSNR; write OUT.error.png (heat map) and\n"
    "                           OUT.reference.png beside the output\n"
    "  --error-samples N        shaded points for the transmittance error (default 20000)\n"
    "  --max-memory N[M|G]      refuse scenes and settings estimated to need more than N MiB (or GiB);\n"
    "                           default: the scene's shadows.max_memory, else half the physical memory\n"
    "  --stats PATH             write every figure as JSON\n"
    "  --help                   this text\n";

std::string sibling(const std::string& out, const std::string& suffix) {
  std::string base = out;
  if (base.size() > 4 && base.substr(base.size() - 4) == ".png") base.resize(base.size() - 4);
  return base + suffix;
}

nlohmann::json stats_json(const FrameStats& s, const Scene& scene, const std::string& backend) {
  nlohmann::json j;
  j["scene"] = scene.source;
  j["backend"] = backend;
  j["fragment_source"] = s.fragment_source;
  j["fragment_source_reason"] = s.fragment_source_reason;
  j["image_width"] = scene.camera.width;
  j["image_height"] = scene.camera.height;
  j["epsilon"] = scene.shadows.epsilon;
  j["dsm_resolution"] = scene.shadows.resolution;
  j["filtering"] = scene.shadows.filtering;
  j["lights"] = s.lights;
  j["clusters_max"] = scene.shadows.max_clusters;
  j["d0"] = scene.shadows.d0;
  j["maps_rebuilt"] = s.maps_rebuilt;
  j["maps_reused"] = s.maps_reused;
  auto& cl = j["light_clusters"];
  cl = nlohmann::json::array();
  for (const LightClusterStats& c : s.clusters) {
    nlohmann::json e;
    e["clustered"] = c.clustered;
    e["fallback_reason"] = c.fallback_reason;
    e["reclustered"] = c.reclustered;
    e["maps"] = c.maps;
    e["objects_per_cluster"] = c.members;
    cl.push_back(e);
  }
  j["popping"] = {{"measured", s.popping.measured}, {"points", s.popping.points},
                  {"mean_abs_dT", s.popping.mean}, {"max_abs_dT", s.popping.max}};
  {
    const UpdateStats& u = s.update;
    auto& up = j["update"];
    up["full_compiles"] = u.full_compiles;
    up["objects_compiled"] = u.objects_compiled;
    up["volumes_compiled"] = u.volumes_compiled;
    up["bvh_refits"] = u.bvh_refits;
    up["bvh_rebuilds"] = u.bvh_rebuilds;
    up["gl_upload_bytes"] = u.gl_upload_bytes;
    up["maps_freed"] = u.maps_freed;
    auto& why = up["maps_rebuilt_by_reason"];
    for (int r = 0; r < kRebuildReasons; ++r) why[to_string(RebuildReason(r))] = u.rebuilt_by_reason[r];
    auto& list = up["rebuilt_maps"];
    list = nlohmann::json::array();
    for (const MapRebuild& m : u.rebuilds)
      list.push_back({{"light", m.light}, {"map", m.map}, {"reason", to_string(m.reason)}});
    up["map_store_bytes"] = u.map_store_bytes;
    up["map_live_bytes"] = u.map_live_bytes;
    up["scene_bytes"] = u.scene_bytes;
    up["gl_scene_bytes"] = u.gl_scene_bytes;
    up["host_to_backend_bytes"] = u.host_to_backend_bytes;
    up["backend_to_host_bytes"] = u.backend_to_host_bytes;
  }
  auto& t = j["times_ms"];
  t["compile_scene"] = s.times.compile_ms;
  t["clustering"] = s.cluster_ms;
  t["light_fragments"] = s.times.fragments_ms;
  t["dsm_build"] = s.times.dsm_build_ms;
  t["camera_fragments"] = s.times.camera_fragments_ms;
  t["camera_pass"] = s.times.camera_ms;
  t["reference"] = s.times.reference_ms;
  t["total_frame"] = s.times.total_ms;
  // The backend's launches (the wall clock of each parallel_for on CPU
  // threads, CUDA events on a GPU), by name.
  auto& kt = t["kernels"];
  kt = nlohmann::json::object();
  for (const KernelTime& k : s.times.kernels) kt[k.name] = {{"ms", k.ms}, {"launches", k.launches}};
  auto& m = j["dsm_memory"];
  m["layout"] = tag_name(scene.shadows.layout);
  j["receiver_lookup"] = tag_name(scene.shadows.receiver);
  m["maps"] = s.memory.maps;
  m["texels"] = s.memory.texels;
  m["nodes"] = s.memory.nodes;
  m["index_bytes"] = s.memory.index_bytes;
  m["tag_bytes"] = s.memory.tag_bytes;
  m["rewalked_texels"] = s.memory.rewalked_texels;
  m["node_bytes"] = s.memory.node_bytes;
  m["slack_bytes"] = s.memory.slack_bytes;
  m["avg_nodes_per_texel"] = s.memory.avg_nodes_per_texel;
  m["max_nodes_per_texel"] = s.memory.max_nodes_per_texel;
  m["overflow_texels"] = s.memory.overflow_texels;
  m["overflow_extra_error"] = s.memory.max_extra_error;
  m["rgb_maps"] = s.memory.rgb_maps;
  m["grey_map_bytes"] = s.memory.grey_bytes;
  m["rgb_map_bytes"] = s.memory.rgb_bytes;
  m["rgb_nodes"] = s.memory.rgb_nodes;
  j["light_fragments"] = s.light_fragments;
  j["camera_fragments"] = s.camera_fragments;
  j["unmatched_fragments"] = s.unmatched_fragments;
  j["enclosing_overflow"] = s.enclosing_overflow;
  j["ray_object_overflow"] = s.match_overflow;
  j["march_steps_lengthened"] = s.march_lengthened;
  if (s.has_reference) {
    auto& e = j["transmittance_error"];
    e["points"] = s.transmittance.points;
    e["mean"] = s.transmittance.mean;
    e["p99"] = s.transmittance.p99;
    e["max"] = s.transmittance.max;
    e["rmse"] = s.transmittance.rmse;
    e["channel_mean"] = {s.transmittance.channel_mean[0], s.transmittance.channel_mean[1],
                         s.transmittance.channel_mean[2]};
    auto summary = [](const ErrorSummary& x) {
      return nlohmann::json{{"mean", x.mean}, {"p99", x.p99}, {"max", x.max}, {"rmse", x.rmse}};
    };
    e["map_error_dsm_vs_filtered_exact"] = summary(s.transmittance.map);
    e["resolution_error_filtered_exact_vs_exact"] = summary(s.transmittance.resolution);
    e["total_error_dsm_vs_exact"] = summary(s.transmittance.total);
    for (const auto& [key, c] : {std::pair<const char*, const ErrorClass&>{"edge_points", s.transmittance.edge},
                                 std::pair<const char*, const ErrorClass&>{"interior_points", s.transmittance.interior}}) {
      e[key]["share_of_points"] = c.share;
      e[key]["map_error"] = summary(c.map);
      e[key]["resolution_error"] = summary(c.resolution);
      e[key]["total_error"] = summary(c.total);
    }
    j["image_error"]["rmse"] = s.image.rmse;
    j["image_error"]["psnr_db"] = std::isfinite(s.image.psnr) ? s.image.psnr : 999.0;
  }
  return j;
}

void print_summary(const FrameStats& s, const Scene& scene, bool reference_backend) {
  std::printf("scene        %s  (%zu objects, %zu volumes, %u lights, %dx%d)\n", scene.source.c_str(),
              scene.objects.size(), scene.volumes.size(), s.lights, scene.camera.width, scene.camera.height);
  if (reference_backend) {
    std::printf("reference    %.1f ms\n", s.times.reference_ms);
    return;
  }
  std::printf("fragments    %s (%s)\n", s.fragment_source.c_str(), s.fragment_source_reason.c_str());
  std::printf("settings     eps %.4g, DSM %d^2, filtering %s\n", scene.shadows.epsilon, scene.shadows.resolution,
              scene.shadows.filtering ? "on" : "off");
  std::printf("times [ms]   light fragments %.1f | DSM build %.1f | camera fragments %.1f | camera pass %.1f | frame %.1f\n",
              s.times.fragments_ms, s.times.dsm_build_ms, s.times.camera_fragments_ms, s.times.camera_ms,
              s.times.total_ms);
  for (size_t li = 0; li < s.clusters.size(); ++li) {
    const LightClusterStats& c = s.clusters[li];
    std::printf("light %zu      %u maps", li, c.maps);
    if (c.clustered) {
      std::printf(", %zu clusters (objects:", c.members.size());
      for (const auto& m : c.members) {
        std::printf(" {");
        for (size_t k = 0; k < m.size(); ++k) std::printf("%s%d", k ? "," : "", m[k]);
        std::printf("}");
      }
      std::printf(")");
    } else if (!c.fallback_reason.empty()) {
      std::printf(", unclustered: %s", c.fallback_reason.c_str());
    }
    std::printf("\n");
  }
  std::printf("rebuilds     %u maps built, %u reused\n", s.maps_rebuilt, s.maps_reused);
  std::printf("transfers    host -> backend %.2f MiB, backend -> host %.2f MiB\n",
              double(s.update.host_to_backend_bytes) / 1048576.0, double(s.update.backend_to_host_bytes) / 1048576.0);
  std::printf("DSM memory   %s layout, %llu maps, index %.2f MiB, nodes %.2f MiB, tags %.2f MiB, slack %.2f MiB\n",
              tag_name(scene.shadows.layout), (unsigned long long)s.memory.maps, s.memory.index_bytes / 1048576.0,
              s.memory.node_bytes / 1048576.0, s.memory.tag_bytes / 1048576.0, s.memory.slack_bytes / 1048576.0);
  std::printf("nodes/texel  avg %.2f, max %u (texels walked twice %llu, re-compressed %llu)\n",
              s.memory.avg_nodes_per_texel, s.memory.max_nodes_per_texel, (unsigned long long)s.memory.rewalked_texels,
              (unsigned long long)s.memory.overflow_texels);
  if (s.memory.rgb_maps > 0)
    std::printf("map kinds    %llu RGB maps %.2f MiB, %llu grey maps %.2f MiB\n", (unsigned long long)s.memory.rgb_maps,
                s.memory.rgb_bytes / 1048576.0, (unsigned long long)(s.memory.maps - s.memory.rgb_maps),
                s.memory.grey_bytes / 1048576.0);
  std::printf("segments     unmatched fragments %llu, enclosing overflow %llu, rays with > %d objects %llu, "
              "march steps lengthened %llu\n",
              (unsigned long long)s.unmatched_fragments, (unsigned long long)s.enclosing_overflow, kMaxRayObjects,
              (unsigned long long)s.match_overflow, (unsigned long long)s.march_lengthened);
  if (s.has_reference) {
    const TransmittanceError& t = s.transmittance;
    std::printf("error        transmittance over %llu points: mean %.5f, p99 %.4f, max %.4f, RMSE %.5f\n",
                (unsigned long long)t.points, t.mean, t.p99, t.max, t.rmse);
    std::printf("  map        |T_dsm - T_filtered_exact| (eps, offsets): mean %.5f, p99 %.4f, max %.4f\n", t.map.mean,
                t.map.p99, t.map.max);
    std::printf("  resolution |T_filtered_exact - T_exact| (texels, clusters): mean %.5f, p99 %.4f, max %.4f\n",
                t.resolution.mean, t.resolution.p99, t.resolution.max);
    for (const auto& [name, c] : {std::pair<const char*, const ErrorClass&>{"interior", t.interior},
                                  std::pair<const char*, const ErrorClass&>{"edge    ", t.edge}})
      std::printf("  %s   %.1f%% of points: total mean %.5f, p99 %.4f, max %.4f; map p99 %.4f, max %.4f; "
                  "resolution p99 %.4f\n",
                  name, 100.0 * c.share, c.total.mean, c.total.p99, c.total.max, c.map.p99, c.map.max, c.resolution.p99);
    std::printf("image        RMSE %.5f, PSNR %.2f dB against the reference (%.1f ms)\n", s.image.rmse, s.image.psnr,
                s.times.reference_ms);
  }
}

}  // namespace

float parse_float(const std::string& opt, const std::string& v) {
  try {
    size_t n = 0;
    float f = std::stof(v, &n);
    if (n != v.size() || !std::isfinite(f)) throw 0;
    return f;
  } catch (...) {
    throw Error(opt, "expected a finite number, got '" + v + "'");
  }
}

int64_t parse_memory_mib(const std::string& opt, const std::string& v) {
  std::string digits = v;
  int64_t unit = 1;
  if (!digits.empty() && (digits.back() == 'G' || digits.back() == 'g')) {
    unit = 1024;
    digits.pop_back();
  } else if (!digits.empty() && (digits.back() == 'M' || digits.back() == 'm')) {
    digits.pop_back();
  }
  int n = 0;
  try {
    n = parse_int(opt, digits);
  } catch (const Error&) {
    throw Error(opt, "expected a size in MiB (or with M or G), got '" + v + "'");
  }
  if (n < 1 || int64_t(n) * unit > (int64_t(1) << 30)) throw Error(opt, "must be within [1 MiB, 1 PiB], got '" + v + "'");
  return int64_t(n) * unit;
}

int parse_int(const std::string& opt, const std::string& v) {
  try {
    size_t n = 0;
    long x = std::stol(v, &n);
    if (n != v.size() || x < -2147483647L || x > 2147483647L) throw 0;
    return int(x);
  } catch (...) {
    throw Error(opt, "expected an integer, got '" + v + "'");
  }
}

void check_writable(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path p(path);
  if (fs::is_directory(p, ec)) throw Error(path, "is a directory, not a file that can be written");
  fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  if (!fs::is_directory(dir, ec)) throw Error(path, "cannot be written: the directory '" + dir.string() + "' does not exist");
  if (fs::exists(p, ec) ? ::access(path.c_str(), W_OK) != 0 : ::access(dir.c_str(), W_OK) != 0)
    throw Error(path, "cannot be written: permission denied");
}

int cmd_render(const std::vector<std::string>& args) {
  std::string scene_path, out, stats_path;
  RenderOptions opt;
  opt.backend = Backend::Auto;  // cuda when a CUDA device exists, else cpu
  float eps = -1.0f;
  int res = 0, width = 0, height = 0;
  int filtering = -1;
  int clusters = 0;
  float d0 = -1.0f;
  std::optional<DsmLayout> layout;
  std::optional<ReceiverLookup> receiver;
  int fixed_layers = 0;
  int splits = -1;
  int64_t max_memory = 0;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= args.size()) throw Error(a, "needs a value");
      return args[++i];
    };
    if (a == "--help" || a == "-h") {
      std::fputs(kRenderHelp, stdout);
      return 0;
    } else if (a == "-o" || a == "--output") {
      out = value();
    } else if (a == "--backend") {
      std::string v = value();
      if (v == "cpu") opt.backend = Backend::Cpu;
      else if (v == "reference") opt.backend = Backend::Reference;
      else if (v == "cuda") opt.backend = Backend::Cuda;
      else throw Error("--backend", "unknown backend '" + v + "' (cuda, cpu or reference)");
    } else if (a == "--fragments") {
      std::string v = value();
      if (v == "auto") opt.fragments = FragmentSource::Auto;
      else if (v == "gl") opt.fragments = FragmentSource::Gl;
      else if (v == "cpu") opt.fragments = FragmentSource::Cpu;
      else if (v == "cuda") opt.fragments = FragmentSource::Cuda;
      else throw Error("--fragments", "unknown producer '" + v + "' (auto, gl, cpu or cuda)");
    } else if (a == "--eps") {
      eps = parse_float(a, value());
      if (eps < 0) throw Error("--eps", "must be >= 0");
    } else if (a == "--dsm-res") {
      res = parse_int(a, value());
      if (res < 4 || res > 8192) throw Error("--dsm-res", "must be within [4, 8192]");
    } else if (a == "--width") {
      width = parse_int(a, value());
      if (width < 1 || width > 16384) throw Error("--width", "must be within [1, 16384]");
    } else if (a == "--height") {
      height = parse_int(a, value());
      if (height < 1 || height > 16384) throw Error("--height", "must be within [1, 16384]");
    } else if (a == "--filtering") {
      std::string v = value();
      if (v == "on") filtering = 1;
      else if (v == "off") filtering = 0;
      else throw Error("--filtering", "expected on or off, got '" + v + "'");
    } else if (a == "--clusters") {
      clusters = parse_int(a, value());
      if (clusters < 1 || clusters > 8) throw Error("--clusters", "must be within [1, 8]");
    } else if (a == "--d0") {
      d0 = parse_float(a, value());
      if (d0 < 0) throw Error("--d0", "must be >= 0");
    } else if (a == "--splits") {
      splits = parse_int(a, value());
      if (splits != 0 && (splits < 2 || splits > 7)) throw Error("--splits", "must be 0 (off) or within [2, 7]");
    } else if (a == "--layout") {
      const std::string v = value();
      layout = DsmLayout::Packed;
      if (!parse_tag(v, *layout)) throw Error("--layout", "unknown layout '" + v + "' (" + tag_choices<DsmLayout>() + ")");
    } else if (a == "--receiver") {
      const std::string v = value();
      receiver = ReceiverLookup::Plane;
      if (!parse_tag(v, *receiver))
        throw Error("--receiver", "unknown receiver lookup '" + v + "' (" + tag_choices<ReceiverLookup>() + ")");
    } else if (a == "--fixed-layers") {
      fixed_layers = parse_int(a, value());
      if (fixed_layers < 2 || fixed_layers > 4096) throw Error("--fixed-layers", "must be within [2, 4096]");
    } else if (a == "--compare-reference") {
      opt.compare_reference = true;
    } else if (a == "--error-samples") {
      opt.error_samples = parse_int(a, value());
      if (opt.error_samples < 1 || opt.error_samples > 10000000) throw Error("--error-samples", "must be within [1, 1e7]");
    } else if (a == "--stats") {
      stats_path = value();
    } else if (a == "--max-memory") {
      max_memory = parse_memory_mib(a, value());
    } else if (!a.empty() && a[0] == '-') {
      throw Error(a, "unknown option (try cdsm render --help)");
    } else if (scene_path.empty()) {
      scene_path = a;
    } else {
      throw Error(a, "unexpected argument: only one scene per render");
    }
  }
  if (scene_path.empty()) throw Error("cdsm render", "needs a scene file (try cdsm render --help)");
  if (out.empty()) throw Error("cdsm render", "needs -o OUT.png");
  // Which backend, and why: no CUDA device means the cpu backend, unless
  // cuda was asked for by name (then the same reason is an error).
  const BackendResolution backend = resolve_backend(opt.backend, opt.fragments);  // (no GL with the ray caster)
  if (!backend.available) throw Error("--backend cuda", backend.reason);
  opt.backend = backend.backend;
  if (opt.fragments == FragmentSource::Cuda && opt.backend != Backend::Cuda)
    throw Error("--fragments cuda", "the CUDA fragment producer needs the cuda backend (" + backend.reason + ")");
  if (out.size() < 4 || out.substr(out.size() - 4) != ".png") throw Error(out, "output must be a .png file");
  namespace fs = std::filesystem;
  std::error_code ec;
  std::vector<std::string> outputs{out};
  if (!stats_path.empty()) outputs.push_back(stats_path);
  if (opt.compare_reference && opt.backend != Backend::Reference) {
    outputs.push_back(sibling(out, ".reference.png"));
    outputs.push_back(sibling(out, ".error.png"));
  }
  for (const std::string& p : outputs) {
    if (fs::exists(p, ec) && fs::equivalent(p, scene_path, ec)) throw Error(p, "refusing to overwrite the scene file");
    check_writable(p);
  }

  if (max_memory > 0) set_memory_limit_mib(max_memory);  // also for what the scene reader generates
  Scene scene = load_scene(scene_path);
  if (max_memory > 0) scene.shadows.max_memory_mib = 0;  // the command line over the scene: its limit applies
  if (eps >= 0) scene.shadows.epsilon = eps;
  if (res > 0) scene.shadows.resolution = res;
  if (width > 0) scene.camera.width = width;
  if (height > 0) scene.camera.height = height;
  if (filtering >= 0) scene.shadows.filtering = filtering == 1;
  if (clusters > 0) scene.shadows.max_clusters = clusters;
  if (d0 >= 0) scene.shadows.d0 = d0;
  if (layout) scene.shadows.layout = *layout;
  if (receiver) scene.shadows.receiver = *receiver;
  if (fixed_layers > 0) scene.shadows.fixed_layers = fixed_layers;
  if (splits >= 0) scene.shadows.parallel_splits = splits;

  std::fprintf(stderr, "cdsm: backend %s: %s\n", backend.name.c_str(), backend.reason.c_str());
  Renderer renderer;
  FrameStats stats;
  Image img = renderer.render(scene, opt, &stats);
  if (!stats.fragment_source.empty())
    std::fprintf(stderr, "cdsm: fragments from %s: %s\n", stats.fragment_source.c_str(),
                 stats.fragment_source_reason.c_str());
  for (const std::string& w : stats.warnings) std::fprintf(stderr, "cdsm: warning: %s\n", w.c_str());
  write_png(img, out);
  print_summary(stats, scene, opt.backend == Backend::Reference);
  std::printf("wrote        %s\n", out.c_str());
  if (opt.compare_reference && opt.backend != Backend::Reference) {
    write_png(renderer.last_reference(), sibling(out, ".reference.png"));
    write_png(error_heatmap(img, renderer.last_reference()), sibling(out, ".error.png"));
    std::printf("wrote        %s, %s\n", sibling(out, ".reference.png").c_str(), sibling(out, ".error.png").c_str());
  }
  if (!stats_path.empty()) {
    std::ofstream f(stats_path);
    if (!f) throw Error(stats_path, "cannot write stats file");
    f << stats_json(stats, scene, backend.name).dump(2) << "\n";
    std::printf("wrote        %s\n", stats_path.c_str());
  }
  return 0;
}

int cmd_info(const std::vector<std::string>& args) {
  if (args.size() != 1 || args[0] == "--help") {
    std::puts("usage: cdsm info SCENE.json");
    return args.size() == 1 ? 0 : 2;
  }
  Scene s = load_scene(args[0]);
  size_t tris = 0;
  for (const Object& o : s.objects) tris += o.mesh ? o.mesh->triangle_count() : 0;
  std::printf("%s: %zu objects (%zu triangles), %zu volumes, %zu lights, camera %dx%d\n", s.source.c_str(),
              s.objects.size(), tris, s.volumes.size(), s.lights.size(), s.camera.width, s.camera.height);
  for (size_t i = 0; i < s.objects.size(); ++i) {
    const Object& o = s.objects[i];
    std::printf("  object %zu %-12s %6zu tris  opacity %.2f  interior %s%s%s\n", i, o.name.c_str(),
                o.mesh->triangle_count(), o.surface.opacity, tag_name(o.interior),
                is_closed(*o.mesh) ? "" : "  (open mesh)", o.casts_shadows ? "" : "  (receives only)");
  }
  for (size_t i = 0; i < s.volumes.size(); ++i) {
    const Volume& v = s.volumes[i];
    if (v.grid)
      std::printf("  volume %zu %-12s dense %dx%dx%d\n", i, v.name.c_str(), v.grid->nx, v.grid->ny, v.grid->nz);
    else if (v.sparse)
      std::printf("  volume %zu %-12s sparse (NanoVDB), active box %dx%dx%d, %llu active voxels\n", i,
                  v.name.c_str(), v.sparse->active_max[0] - v.sparse->active_min[0] + 1,
                  v.sparse->active_max[1] - v.sparse->active_min[1] + 1,
                  v.sparse->active_max[2] - v.sparse->active_min[2] + 1,
                  (unsigned long long)v.sparse->active_voxels);
  }
  return 0;
}

}  // namespace cdsm::cli
