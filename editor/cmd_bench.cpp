// cdsm bench: speed against error (docs/bench/README.md). Sweeps epsilon,
// resolution, cluster count, layout, backend and the baseline methods over
// scenes; measures build and camera-pass times over repeated runs, memory,
// nodes per texel, and the error against the exact reference (rendered once
// per view and cached); writes results.csv, results.md and plots.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <map>

#include "bench.h"
#include "commands.h"

namespace cdsm::cli {
namespace {

namespace fs = std::filesystem;
using namespace bench;

// The paragraphs of cdsm bench --help around its options.
std::string bench_footer() {
  return "Speed against error. For every scene and every configuration of the sweep, renders the\n"
         "scene's camera view N times (each with a fresh renderer, so every map is built) and reports\n"
         "median and spread (min, max, quartiles) of the DSM build and camera-pass times, DSM memory\n"
         "(index, nodes, slack), nodes per texel (average, max), and the error against the exact\n"
         "reference of the same view: transmittance |T - T_ref| at sampled shaded\n"
         "points (mean, p99, max, RMSE) and the image RMSE / PSNR. The reference image of a view is\n"
         "rendered once (progress bar on stderr) and cached on disk under a hash of the scene content\n"
         "and the view. The baselines are built from the same light rays and read by the same lookup.\n"
         "Colour: every error figure is the largest over the R, G, B channels of that figure per\n"
         "channel (results.csv also has t_mean_r/g/b); the baselines are grey (one alpha per node, a\n"
         "coloured caster by its channel mean), deep shadow maps store RGB nodes where a map holds\n"
         "colour (rgb_maps, rgb_map_bytes, grey_map_bytes in results.csv).\n"
         "\n" +
         capabilities_text() +
         "\n"
         "Runs are interleaved: each round renders every configuration of a scene once, so a changing\n"
         "machine load affects all configurations alike. The reference is rendered at the image size\n"
         "(--width, --height), so keep it small (e.g. 240x160). The reference row of each scene is the\n"
         "reference renderer's own time (exact shadow rays).\n"
         "Example (the checked-in report, docs/bench/, is made by scripts/bench_report.sh):\n"
         "  cdsm bench content/scenes/default.json --sweep eps=0.01,0.1 --sweep res=256,512 \\\n"
         "             --methods dsm,sm,osm32,avsm8 --repeat 3 --width 240 --height 160 --out bench-out";
}

const char* kMethodsHelp =
    "shadow representations (default: all of these):\n"
    "  dsm     deep shadow maps, epsilon-bounded (the product)\n"
    "  dsmgrey the same with every map scalar (rgb_maps off): what RGB\n"
    "          maps cost on a coloured scene (grey scenes: identical)\n"
    "  sm      conventional shadow map: opaque where the opacity reaches\n"
    "          0.5 (a surface's own, or the media's accumulated); sm:T for\n"
    "          another threshold T in (0, 1]\n"
    "  osmN    opacity shadow maps, N uniform slices over each ray's extent\n"
    "          through the casters (osm16, osm32, osm64)\n"
    "  avsmN   AVSM-style fixed-node maps, at most N nodes, greedy\n"
    "          smallest-area node removal (avsm4, avsm8, avsm16)\n"
    "  domN    deep opacity maps: N layers from each texel's first caster\n"
    "          depth, each the casters' depth extent / N thick; domN:T\n"
    "          for layers T world units thick (dom4, dom8, dom16)\n"
    "  fomN    Fourier opacity maps: N real coefficients (a0, a1, b1, ...)\n"
    "          of the absorption over each texel's depth range (fom8)\n"
    "  momN    moment-based transmittance: b0 and N = 4 or 8 power moments\n"
    "          of the absorbance, their biased lower bound (mom4, mom8)\n"
    "          dom, fom and mom are grey; their memory is what an engine\n"
    "          stores, N + 1, N + 2 and N + 3 floats per texel\n"
    "  pssmN   parallel-split (cascaded) deep shadow maps: N maps along the\n"
    "          camera's view, epsilon-bounded (pssm4: what clustering with\n"
    "          m = 4 competes with); ignores --sweep clusters";

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

std::string utc_now() {
  std::time_t t = std::time(nullptr);
  char b[64];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return b;
}

// Measures the configurations of one scene. Timed runs are interleaved —
// round r renders every configuration once — so a load that changes while
// the bench runs (a shared machine) spreads over all of them alike instead
// of favouring whichever ran in a quiet minute. Then the error of each
// against `ref`.
std::vector<Result> measure(const Scene& base, const RenderOptions& base_opt, const std::vector<Config>& configs,
                            const Reference& ref, int warmup, int repeat, const std::string& name) {
  struct Run {
    Scene scene;
    RenderOptions opt;
    std::vector<double> frag, build, camera, frame;
    Result r;
  };
  std::vector<Run> runs(configs.size());
  for (size_t k = 0; k < configs.size(); ++k) {
    runs[k].scene = base;
    runs[k].opt = base_opt;
    apply(configs[k], runs[k].scene, runs[k].opt);
    runs[k].r.scene = base.source;
    runs[k].r.scene_name = name;
    runs[k].r.config = configs[k];
    runs[k].r.runs = repeat;
  }
  const int rounds = warmup + repeat;
  for (int round = 0; round < rounds; ++round) {
    auto t0 = std::chrono::steady_clock::now();
    for (Run& run : runs) {
      Renderer renderer;  // fresh: every map is built, none reused from a previous frame
      FrameStats st;
      Image img = renderer.render(run.scene, run.opt, &st);
      if (st.maps_reused != 0) throw Error("cdsm bench", "internal: a map was reused in a timed run");
      if (round == 0) run.r.image = compare_images(img, ref.image);  // deterministic: once is enough
      if (round < warmup) continue;
      run.frag.push_back(st.times.fragments_ms);
      run.build.push_back(st.times.dsm_build_ms);
      run.camera.push_back(st.times.camera_ms);
      run.frame.push_back(st.times.total_ms);
      run.r.stats = st;
    }
    std::fprintf(stderr, "%s: round %d/%d (%s) of %zu configurations: %.1f s\n", name.c_str(), round + 1, rounds,
                 round < warmup ? "warm-up" : "timed", runs.size(), ms_since(t0) / 1000.0);
  }
  std::vector<Result> out;
  for (size_t k = 0; k < runs.size(); ++k) {
    auto t0 = std::chrono::steady_clock::now();
    Run& run = runs[k];
    Result& r = run.r;
    r.fragments_ms = spread_of(run.frag);
    r.build_ms = spread_of(run.build);
    r.camera_ms = spread_of(run.camera);
    r.frame_ms = spread_of(run.frame);
    Renderer renderer;
    r.transmittance = renderer.transmittance_error(run.scene, run.opt);
    r.reference_ms = ref.ms;
    r.reference_cached = ref.cached;
    std::fprintf(stderr,
                 "[%zu/%zu] %s %-26s build %7.1f ms  camera %6.1f ms  %7.0f KiB  nodes %.2f/%u  T-RMSE %.5f  "
                 "PSNR %.2f dB  (error %.1f s)\n",
                 k + 1, runs.size(), name.c_str(), configs[k].label().c_str(), r.build_ms.median, r.camera_ms.median,
                 r.memory_bytes() / 1024.0, r.stats.memory.avg_nodes_per_texel, r.stats.memory.max_nodes_per_texel,
                 r.transmittance.rmse, r.image.psnr, ms_since(t0) / 1000.0);
    out.push_back(std::move(r));
  }
  return out;
}

std::string unique_name(const std::string& path, const std::string& suffix, std::map<std::string, int>& used) {
  std::string stem = fs::path(path).stem().string();
  if (stem.empty()) stem = "scene";
  stem += suffix;
  int n = ++used[stem];
  return n == 1 ? stem : stem + "-" + std::to_string(n);
}

void print_fronts(const std::vector<Result>& results) {
  std::map<std::string, bool> seen;
  for (const Result& first : results) {
    if (first.is_reference || seen[first.scene_name]) continue;
    seen[first.scene_name] = true;
    std::printf("%s: Pareto front, time (build + camera pass) against transmittance RMSE:\n", first.scene_name.c_str());
    std::vector<const Result*> front;
    for (const Result& r : results)
      if (r.scene_name == first.scene_name && r.pareto_time) front.push_back(&r);
    std::sort(front.begin(), front.end(), [](const Result* a, const Result* b) { return a->time_ms() < b->time_ms(); });
    for (const Result* r : front)
      std::printf("  %-28s %8.1f ms  RMSE %.5f  %8.0f KiB\n", r->config.label().c_str(), r->time_ms(),
                  r->transmittance.rmse, r->memory_bytes() / 1024.0);
  }
}

// What `cdsm bench` was given.
struct BenchArgs {
  std::vector<std::string> scenes;
  std::vector<std::string> sweeps;  // as given; parsed into `sweep`
  Sweep sweep;
  FrameOptions frame;
  int repeat = 5, warmup = 1;
  std::string out_dir = "bench-out", cache_dir = default_cache_dir(), python = "/usr/bin/python3";
  std::string plot_script = default_plot_script();
  bool no_cache = false, refresh = false, no_plot = false;
  std::string command;
};

int run_bench(const BenchArgs& a) {
  const RenderOptions& opt = a.frame.render;
  const std::string& out_dir = a.out_dir;
  const std::string cache_dir = a.no_cache ? "" : a.cache_dir;
  for (const std::string& s : a.scenes) {
    std::error_code ec;
    if (fs::exists(out_dir, ec) && fs::equivalent(out_dir, s, ec))
      throw Error(out_dir, "the output directory is a scene file");
  }
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) throw Error(out_dir, "cannot create the output directory: " + ec.message());
  check_writable((fs::path(out_dir) / "results.csv").string());
  a.frame.limit_memory();

  RunInfo info;
  info.command = a.command;
  info.date = utc_now();
  info.repeat = a.repeat;
  info.warmup = a.warmup;
  info.error_samples = opt.error_samples;

  std::vector<Result> results;
  std::map<std::string, int> used_names;
  auto t_all = std::chrono::steady_clock::now();
  for (const std::string& path : a.scenes)
    for (const SizeVariant& variant : size_variants(a.sweep)) {
      Scene scene = load_scene(path);
      a.frame.apply(scene);
      apply(variant, scene);
      info.width = scene.camera.width;
      info.height = scene.camera.height;
      std::string name = unique_name(path, variant.suffix, used_names);
      std::vector<Config> configs = expand(a.sweep, scene);

      Reference ref = reference_for(scene, opt, cache_dir, a.refresh);

      Result rr;
      rr.scene = path;
      rr.scene_name = name;
      rr.is_reference = true;
      rr.reference_ms = ref.ms;
      rr.reference_cached = ref.cached;
      results.push_back(rr);

      for (Result& r : measure(scene, opt, configs, ref, a.warmup, a.repeat, name)) {
        r.scene = path;
        results.push_back(std::move(r));
      }
      mark_pareto(results);
      std::vector<Result> mine;
      for (const Result& r : results)
        if (r.scene_name == name) mine.push_back(r);
      write_csv(mine, (fs::path(out_dir) / (name + ".csv")).string());
    }
  mark_pareto(results);
  std::string csv = (fs::path(out_dir) / "results.csv").string();
  std::string md = (fs::path(out_dir) / "results.md").string();
  write_csv(results, csv);
  write_markdown(results, info, md);
  std::printf("wrote %s, %s and per-scene CSVs (%.1f s)\n", csv.c_str(), md.c_str(), ms_since(t_all) / 1000.0);
  if (!a.no_plot && plot(a.python, a.plot_script, csv, out_dir))
    std::printf("wrote the plots in %s\n", out_dir.c_str());
  print_fronts(results);
  return 0;
}

}  // namespace

Command add_bench(CLI::App& cdsm, const std::string& command_line) {
  auto a = std::make_shared<BenchArgs>();
  a->command = command_line;
  CLI::App* app = cdsm.add_subcommand("bench",
                                      "speed against error: sweep epsilon, resolution, clusters and the\n"
                                      "baselines (shadow map, opacity slices, AVSM); CSV, Markdown, plot");
  app->footer(bench_footer());
  app->add_option("SCENE", a->scenes, "JSON scenes (or glTF / GLB files)")->required();
  // One axis a --sweep, each given as often as there are axes.
  app->add_option("--sweep", a->sweeps, sweep_help())
      ->type_name("NAME=V1,V2,...")
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
      ->each([a](const std::string& spec) { parse_sweep(spec, a->sweep); });
  app->add_option_function<std::string>(
         "--methods", [a](const std::string& v) { a->sweep.methods = parse_methods(v); }, kMethodsHelp)
      ->type_name("LIST");
  app->add_option_function<std::string>(
         "--layouts", [a](const std::string& v) { a->sweep.layouts = parse_layouts(v); },
         "DSM storage layouts (default: packed)")
      ->type_name("LIST");
  app->add_option_function<std::string>(
         "--backends", [a](const std::string& v) { a->sweep.backends = parse_backends(v); }, "backends (default: cpu)")
      ->type_name("LIST");
  app->add_option("--repeat", a->repeat, "timed runs per configuration")
      ->check(within(1, 1000, true))
      ->capture_default_str();
  app->add_option("--warmup", a->warmup, "untimed rounds before them")
      ->check(within(0, 100, true))
      ->capture_default_str();
  add_frame_options(*app, a->frame);
  app->add_option("--out", a->out_dir,
                  "where to write: results.csv (every row), results.md (a table per scene), and per\n"
                  "scene NAME.csv and NAME.png (time and memory against transmittance RMSE, Pareto front\n"
                  "marked)")
      ->type_name("DIR")
      ->capture_default_str();
  app->add_option("--cache", a->cache_dir,
                  "reference cache (default $CDSM_CACHE_DIR, else $XDG_CACHE_HOME/cdsm, else\n~/.cache/cdsm)")
      ->type_name("DIR");
  app->add_flag("--no-cache", a->no_cache, "render the reference every time, store nothing (over --cache)");
  app->add_flag("--refresh-reference", a->refresh, "render the reference again and replace the cached one");
  app->add_flag("--no-plot", a->no_plot, "skip the PNG plots");
  app->add_option("--python", a->python, "interpreter for the plots (needs matplotlib)")
      ->type_name("PATH")
      ->capture_default_str();
  app->add_option("--plot-script", a->plot_script,
                  "the plot script (default scripts/plot_bench.py of this source tree, or\n$CDSM_PLOT_SCRIPT)")
      ->type_name("PATH");
  return {app, [a] { return run_bench(*a); }};
}

}  // namespace cdsm::cli
