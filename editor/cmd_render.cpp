// cdsm render: one frame, its cost, and (on request) its error; cdsm info.
#include <nlohmann/json.hpp>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "cdsm/cdsm.h"
#include "cdsm/loaders.h"
#include "commands.h"
#include "options.h"

namespace cdsm::cli {
namespace {

const char* kRenderFooter =
    "Renders the scene's camera view with deep shadow maps and prints per-stage times\n"
    "(fragments, DSM build, camera pass), DSM memory and nodes per texel.";

// What `cdsm render` was given.
struct RenderArgs {
  std::string scene_path, out, stats_path;
  FrameOptions frame;
};

std::string sibling(const std::string& out, const std::string& suffix) {
  std::string base = out;
  if (base.size() > 4 && base.substr(base.size() - 4) == ".png") base.resize(base.size() - 4);
  return base + suffix;
}

// One part of FrameStats as a JSON object, by its names (for_each_stat).
template <class S>
nlohmann::json stat_object(const S& part) {
  nlohmann::json o = nlohmann::json::object();
  for_each_stat(part, [&](const char* name, auto value) { o[name] = value; });
  return o;
}

nlohmann::json stats_json(const FrameStats& s, const Scene& scene, const std::string& backend) {
  nlohmann::json j;
  j["scene"] = scene.source;
  j["backend"] = backend;
  j["backend_reason"] = s.backend_reason;
  j["fragment_source"] = s.fragment_source;
  j["fragment_source_reason"] = s.fragment_source_reason;
  j["image_width"] = scene.camera.width;
  j["image_height"] = scene.camera.height;
  j["epsilon"] = scene.shadows.epsilon;
  if (scene.shadows.auto_resolution())
    j["dsm_resolution"] = "auto";
  else
    j["dsm_resolution"] = scene.shadows.resolution;
  j["filtering"] = scene.shadows.filtering;
  j["lights"] = s.lights;
  if (scene.shadows.auto_clusters())
    j["clusters_max"] = "auto";
  else
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
    if (c.chosen_clusters > 0) {
      e["auto_clusters"] = c.chosen_clusters;
      e["auto_clusters_reason"] = c.count_reason;
      auto& tried = e["auto_clusters_tried"];
      tried = nlohmann::json::array();
      for (const LightClusterStats::CountTrial& t : c.count_trials)
        tried.push_back({{"clusters", t.clusters},
                         {"maps", t.maps},
                         {"wanted_texels", t.wanted_texels},
                         {"texels", t.texels},
                         {"reaches", t.reaches}});
    }
    cl.push_back(e);
  }
  auto& mr = j["map_resolutions"];
  mr = nlohmann::json::array();
  for (const MapResolutionStats& m : s.map_resolutions)
    mr.push_back({{"light", m.light},
                  {"resolution", m.resolution},
                  {"limit", m.limit},
                  {"receivers", m.receivers},
                  {"texels_per_pixel_median", m.texels_per_pixel_median},
                  {"texels_per_pixel_p5", m.texels_per_pixel_p5}});
  j["popping"] = {{"measured", s.popping.measured},
                  {"points", s.popping.points},
                  {"mean_abs_dT", s.popping.mean},
                  {"p99_abs_dT", s.popping.p99},
                  {"max_abs_dT", s.popping.max}};
  {
    auto& up = j["update"];
    up = stat_object(s.update);
    auto& why = up["maps_rebuilt_by_reason"];
    for (int r = 0; r < kRebuildReasons; ++r) why[to_string(RebuildReason(r))] = s.update.rebuilt_by_reason[r];
    auto& list = up["rebuilt_maps"];
    list = nlohmann::json::array();
    for (const MapRebuild& m : s.update.rebuilds)
      list.push_back({{"light", m.light}, {"map", m.map}, {"reason", to_string(m.reason)}});
  }
  j["counters"] = stat_object(s.counters);
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
  m = stat_object(s.memory);
  m["layout"] = tag_name(scene.shadows.layout);
  j["receiver_lookup"] = tag_name(scene.shadows.receiver);
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
    for (const auto& [key, c] :
         {std::pair<const char*, const ErrorClass&>{"edge_points", s.transmittance.edge},
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
  const std::string dsm = scene.shadows.auto_resolution()
                              ? std::string("auto (about ") + format_number(scene.shadows.texels_per_pixel) +
                                    " texels per pixel, at most " + std::to_string(scene.shadows.max_resolution) + "^2)"
                              : std::to_string(scene.shadows.resolution) + "^2";
  std::printf("settings     eps %.4g, DSM %s, filtering %s\n", scene.shadows.epsilon, dsm.c_str(),
              scene.shadows.filtering ? "on" : "off");
  std::printf(
      "times [ms]   light fragments %.1f | DSM build %.1f | camera fragments %.1f | camera pass %.1f | frame %.1f\n",
      s.times.fragments_ms, s.times.dsm_build_ms, s.times.camera_fragments_ms, s.times.camera_ms, s.times.total_ms);
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
    if (c.chosen_clusters > 0) std::printf("; %s", cluster_count_text(c).c_str());
    std::printf("\n");
  }
  if (scene.shadows.auto_resolution())
    for (size_t k = 0; k < s.map_resolutions.size(); ++k) {
      const MapResolutionStats& m = s.map_resolutions[k];
      std::printf("map %-2zu       light %u: %d^2, %s", k, m.light, m.resolution, m.limit.c_str());
      if (m.receivers > 0)
        std::printf(", %.2f texels per pixel (5th percentile %.2f) over %u receivers", m.texels_per_pixel_median,
                    m.texels_per_pixel_p5, m.receivers);
      std::printf("\n");
    }
  std::printf("rebuilds     %u maps built, %u reused\n", s.maps_rebuilt, s.maps_reused);
  std::printf("transfers    host -> backend %.2f MiB, backend -> host %.2f MiB\n",
              double(s.update.host_to_backend_bytes) / 1048576.0, double(s.update.backend_to_host_bytes) / 1048576.0);
  std::printf(
      "DSM memory   %s layout, %llu maps, index %.2f MiB, nodes %.2f MiB, tags %.2f MiB, slack %.2f MiB, blocker "
      "pyramids %.2f MiB\n",
      tag_name(scene.shadows.layout), (unsigned long long)s.memory.maps, s.memory.index_bytes / 1048576.0,
      s.memory.node_bytes / 1048576.0, s.memory.tag_bytes / 1048576.0, s.memory.slack_bytes / 1048576.0,
      s.memory.pyramid_bytes / 1048576.0);
  std::printf("nodes/texel  avg %.2f, max %u (texels walked twice %llu, re-compressed %llu)\n",
              s.memory.avg_nodes_per_texel, s.memory.max_nodes_per_texel, (unsigned long long)s.memory.rewalked_texels,
              (unsigned long long)s.memory.overflow_texels);
  if (s.memory.rgb_maps > 0)
    std::printf("map kinds    %llu RGB maps %.2f MiB, %llu grey maps %.2f MiB\n", (unsigned long long)s.memory.rgb_maps,
                s.memory.rgb_bytes / 1048576.0, (unsigned long long)(s.memory.maps - s.memory.rgb_maps),
                s.memory.grey_bytes / 1048576.0);
  std::printf(
      "segments     unmatched fragments %llu, enclosing overflow %llu, rays with > %d objects %llu, "
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
      std::printf(
          "  %s   %.1f%% of points: total mean %.5f, p99 %.4f, max %.4f; map p99 %.4f, max %.4f; "
          "resolution p99 %.4f\n",
          name, 100.0 * c.share, c.total.mean, c.total.p99, c.total.max, c.map.p99, c.map.max, c.resolution.p99);
    std::printf("image        RMSE %.5f, PSNR %.2f dB against the reference (%.1f ms)\n", s.image.rmse, s.image.psnr,
                s.times.reference_ms);
  }
}

int run_render(const RenderArgs& a) {
  const std::string& out = a.out;
  RenderOptions opt = a.frame.render;
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
  if (!a.stats_path.empty()) outputs.push_back(a.stats_path);
  if (opt.compare_reference && opt.backend != Backend::Reference) {
    outputs.push_back(sibling(out, ".reference.png"));
    outputs.push_back(sibling(out, ".error.png"));
  }
  for (const std::string& p : outputs) {
    if (fs::exists(p, ec) && fs::equivalent(p, a.scene_path, ec))
      throw Error(p, "refusing to overwrite the scene file");
    check_writable(p);
  }

  a.frame.limit_memory();
  Scene scene = load_scene(a.scene_path);
  a.frame.apply(scene);

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
  if (!a.stats_path.empty()) {
    std::ofstream f(a.stats_path);
    if (!f) throw Error(a.stats_path, "cannot write stats file");
    f << stats_json(stats, scene, backend.name).dump(2) << "\n";
    std::printf("wrote        %s\n", a.stats_path.c_str());
  }
  return 0;
}

// A volume file given where a scene is expected: what it is and how a
// scene names it. Returns false for anything else.
bool info_of_volume_file(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".vdb") {
    std::printf("%s: an OpenVDB volume, not a scene.\n", path.c_str());
    if (vdb_supported()) {
      try {
        const VdbVolume v = load_vdb(path);
        std::printf("  grid 'density': active box %dx%dx%d, %llu active voxels\n",
                    v.grid->active_max[0] - v.grid->active_min[0] + 1,
                    v.grid->active_max[1] - v.grid->active_min[1] + 1,
                    v.grid->active_max[2] - v.grid->active_min[2] + 1, (unsigned long long)v.grid->active_voxels);
      } catch (const std::exception& e) {
        std::printf("  %s\n", e.what());  // e.g. no grid 'density': the message lists the grids
      }
    }
    std::printf(
        "  A scene uses it as a volume's grid: \"volumes\": [{\"name\": \"smoke\", \"grid\": {\"type\": \"vdb\", "
        "\"file\": \"%s\", \"grid\": \"density\"}, ...}] (README, \"Supported formats\").\n",
        path.c_str());
    return true;
  }
  if (ext == ".raw") {
    std::error_code ec;
    const auto bytes = std::filesystem::file_size(path, ec);
    if (ec) throw Error(path, "cannot read the file: " + ec.message());
    std::printf("%s: a raw volume (%llu bytes), not a scene; its dimensions and format are not in the file.\n",
                path.c_str(), (unsigned long long)bytes);
    std::printf(
        "  A scene uses it as a volume's grid: \"grid\": {\"type\": \"raw\", \"file\": \"%s\", \"dims\": [x, y, z], "
        "\"format\": \"uint8\" or \"uint16\"} (README, \"Supported formats\").\n",
        path.c_str());
    return true;
  }
  return false;
}

int run_info(const std::string& path) {
  if (info_of_volume_file(path)) return 0;
  Scene s = load_scene(path);
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
      std::printf("  volume %zu %-12s sparse (NanoVDB), active box %dx%dx%d, %llu active voxels\n", i, v.name.c_str(),
                  v.sparse->active_max[0] - v.sparse->active_min[0] + 1,
                  v.sparse->active_max[1] - v.sparse->active_min[1] + 1,
                  v.sparse->active_max[2] - v.sparse->active_min[2] + 1, (unsigned long long)v.sparse->active_voxels);
  }
  return 0;
}

}  // namespace

Command add_render(CLI::App& cdsm) {
  auto a = std::make_shared<RenderArgs>();
  a->frame.render.backend = Backend::Auto;  // cuda when a CUDA device exists, else cpu
  CLI::App* app = cdsm.add_subcommand("render",
                                      "render a scene with deep shadow maps, print times and memory; with\n"
                                      "--compare-reference also the error against the exact reference");
  app->footer(kRenderFooter);
  app->add_option("SCENE", a->scene_path, "a JSON scene (content/scenes/*.json), or a glTF / GLB file")->required();
  app->add_option("-o,--output", a->out, "PNG to write (never the scene file itself)")->required();
  add_choice_option(*app, "--backend", a->frame.render.backend,
                    Choices<Backend>{{"cuda", Backend::Cuda}, {"cpu", Backend::Cpu}, {"reference", Backend::Reference}},
                    "backend",
                    "deep shadow maps on a CUDA device or on the CPU, or the exact reference (shadow rays, no\n"
                    "maps); default: cuda when a CUDA device exists, else cpu (stderr says which and why)");
  add_frame_options(*app, a->frame);
  SceneOverrides& scene = a->frame.overrides;
  scene.add(*app, "--eps", &Scene::shadows, "epsilon");
  scene.add(*app, "--dsm-res", &Scene::shadows, "resolution");
  scene.add(*app, "--texels-per-pixel", &Scene::shadows, "texels_per_pixel");
  scene.add(*app, "--max-dsm-res", &Scene::shadows, "max_resolution");
  scene.add(*app, "--filtering", &Scene::shadows, "filtering");
  scene.add(*app, "--clusters", &Scene::shadows, "clusters", "1: unclustered");
  scene.add(*app, "--max-clusters", &Scene::shadows, "max_clusters");
  scene.add(*app, "--d0", &Scene::shadows, "d0");
  scene.add(*app, "--splits", &Scene::shadows, "parallel_splits", "instead of clusters")
      ->check(CLI::Validator(  // what the range cannot say (as the scene's validator)
          [](std::string& s) { return std::stoll(s) == 1 ? "must be 0 (off) or at least 2, got " + s : ""; }, ""));
  scene.add(*app, "--layout", &Scene::shadows, "layout",
            "packed: exact allocation; fixed: res x res x L, --fixed-layers L;\n"
            "chunked: 64-node chunks linked per texel");
  scene.add(*app, "--fixed-layers", &Scene::shadows, "fixed_layers");
  scene.add(*app, "--receiver", &Scene::shadows, "receiver",
            "plane: per-tap receiver planes; slope_bias: the previous\nconstant + slope-scaled bias (a baseline)");
  scene.add(*app, "--penumbra", &Scene::shadows, "penumbra");  // the field table's text says it all
  app->add_flag("--compare-reference", a->frame.render.compare_reference,
                "also render the exact reference of the same view; report the transmittance error at\n"
                "sampled shaded points (mean, p99, max, RMSE) and the image RMSE/PSNR; write OUT.error.png\n"
                "(heat map) and OUT.reference.png beside the output");
  app->add_option("--stats", a->stats_path, "write every figure as JSON")->type_name("PATH");
  return {app, [a] { return run_render(*a); }};
}

Command add_info(CLI::App& cdsm) {
  auto path = std::make_shared<std::string>();
  auto fields = std::make_shared<bool>(false);
  CLI::App* app = cdsm.add_subcommand("info", "print what a scene holds (objects, triangles, volumes, lights)");
  app->add_option("SCENE", *path, "a JSON scene, or a glTF / GLB file");
  app->add_flag("--fields", *fields,
                "print every scene-file field instead (Markdown: JSON key, the C++ member it sets, default, values)");
  return {app, [path, fields] {
            if (*fields) {
              std::fputs(scene_field_reference().c_str(), stdout);
              return 0;
            }
            if (path->empty()) throw Error("cdsm info", "SCENE is required (or --fields)");
            return run_info(*path);
          }};
}

}  // namespace cdsm::cli
