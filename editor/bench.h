// cdsm bench: the parts of the speed-against-error harness (DESIGN.md §7).
// bench_config: what to sweep; bench_reference: the cached exact reference;
// bench_output: statistics, Pareto fronts, CSV / Markdown / plot.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "cdsm/cdsm.h"
#include "cdsm/method_params.h"

namespace cdsm::cli::bench {

// ---- what to sweep (bench_config.cpp) ---------------------------------------

// One shadow representation: deep shadow maps or a baseline (hd/baselines.h).
struct MethodSpec {
  std::string label;  // as on the command line: dsm, sm, osm32, avsm8
  ShadowMethod method = ShadowMethod::Dsm;
  float param = 0.0f;            // ShadowSettings::method_param
  float layer_thickness = 0.0f;  // domN:T: ShadowSettings::layer_thickness
  int splits = 0;                // pssmN: N parallel-split deep shadow maps (ShadowSettings::parallel_splits)
  bool grey_maps = false;        // dsmgrey: every map scalar (ShadowSettings::rgb_maps off): RGB maps' cost
};

// The sweep axes; every combination is one configuration (baselines ignore eps).
struct Sweep {
  std::vector<float> eps;     // empty: the scene's epsilon
  std::vector<int> res;       // empty: the scene's resolution; kAutoResolution: auto
  std::vector<float> tpp;     // auto resolution's texels per pixel; empty: the scene's
  std::vector<int> clusters;  // empty: the scene's max_clusters
  std::vector<MethodSpec> methods;
  std::vector<std::string> layouts;
  std::vector<std::string> backends;
  std::vector<Penumbra> penumbrae;  // empty: the scene's
  // Light sizes: each value a variant of the scene with its own reference
  // (the area-sampled one) and its own Pareto fronts: every spot and point
  // light's radius (world units), every directional light's angular
  // diameter (degrees). Empty: the scene's own.
  std::vector<float> radius, angular_diameter;
};

// One light-size variant of a scene: its name suffix ("" for the scene as
// it is, else "@r0.15" or "@sun0.53") and what it sets (negative: unset).
struct SizeVariant {
  std::string suffix;
  float radius = -1.0f, angular_diameter = -1.0f;
};
std::vector<SizeVariant> size_variants(const Sweep& sweep);
void apply(const SizeVariant& v, Scene& scene);

// "--sweep NAME=V1,V2,..." into `sweep`; unknown names, bad values and
// values this build cannot run yet throw cdsm::Error naming the option.
void parse_sweep(const std::string& spec, Sweep& sweep);
std::vector<MethodSpec> parse_methods(const std::string& list);
std::vector<std::string> parse_layouts(const std::string& list);
std::vector<std::string> parse_backends(const std::string& list);
std::vector<MethodSpec> default_methods();
// Lines for --help: what --sweep takes (the ranges of the settings it
// sets), and what each sweep axis accepts in this build.
std::string sweep_help();
std::string capabilities_text();

// One configuration to measure.
struct Config {
  MethodSpec method;
  float eps = 0.0f;   // DSM only
  int res = 0;        // kAutoResolution: auto
  float tpp = -1.0f;  // auto resolution's texels per pixel (negative: the scene's)
  int clusters = 1;   // kAutoClusters: auto
  std::string layout;
  std::string backend;
  Penumbra penumbra = Penumbra::Estimated;
  std::string label() const;          // e.g. "dsm eps=0.01 res=512", "osm32 res=512", "dsm eps=0.01 res=auto tpp=2"
  std::string res_text() const;       // "512", "auto" or "auto x2"
  std::string clusters_text() const;  // "4" or "auto"
};

// Every configuration of `sweep` on a scene (its own settings fill empty axes).
std::vector<Config> expand(const Sweep& sweep, const Scene& scene);
// The scene (and options) a configuration renders.
void apply(const Config& c, Scene& scene, RenderOptions& opt);

// ---- the reference (bench_reference.cpp) -------------------------------------

struct Reference {
  Image image;
  double ms = 0.0;      // how long rendering it took (when it was rendered)
  bool cached = false;  // read from the cache
  std::string key;      // hex hash of the scene content and view
  std::string path;     // cache file ("" when caching is off)
};

// Hash of everything the reference image depends on: geometry, materials,
// volumes, lights, camera and image size, ambient, background, the march step.
std::string reference_key(const Scene& scene, float reference_step_voxels);

// The reference image of the scene's view: read from `cache_dir` when there,
// else rendered (with a progress bar on stderr) and stored. Empty
// `cache_dir`: no caching. `refresh`: render even if cached.
Reference reference_for(const Scene& scene, const RenderOptions& opt, const std::string& cache_dir, bool refresh);

// The default cache directory: $CDSM_CACHE_DIR, $XDG_CACHE_HOME/cdsm, ~/.cache/cdsm.
std::string default_cache_dir();

// ---- results (bench_output.cpp) -------------------------------------------

struct Spread {
  double median = 0.0, min = 0.0, max = 0.0, q1 = 0.0, q3 = 0.0;
};
Spread spread_of(std::vector<double> v);

struct Result {
  std::string scene;       // path as given
  std::string scene_name;  // file stem (unique within a run)
  Config config;
  bool is_reference = false;
  int runs = 0;
  Spread fragments_ms, build_ms, camera_ms, frame_ms;
  FrameStats stats;  // of the last run (memory, nodes, counters)
  TransmittanceError transmittance;
  ImageError image;
  double reference_ms = 0.0;
  bool reference_cached = false;
  bool pareto_time = false;    // no other configuration is both faster and more accurate
  bool pareto_memory = false;  // ... both smaller and more accurate
  double time_ms() const { return build_ms.median + camera_ms.median; }
  // The maps' memory: their nodes, or for the methods that keep a fixed set
  // of numbers per texel (cdsm/method_params.h stored_components), those.
  double memory_bytes() const {
    const int components = stored_components(config.method.method, config.method.param);
    if (components > 0) return double(stats.memory.texels) * components * kBytesPerComponent;
    return double(stats.memory.index_bytes + stats.memory.node_bytes + stats.memory.slack_bytes +
                  stats.memory.tag_bytes + stats.memory.pyramid_bytes);
  }
};

// Marks the Pareto fronts among the results of each scene (reference rows excluded).
void mark_pareto(std::vector<Result>& results);

struct RunInfo {
  std::string command;  // the command line
  std::string date;     // UTC, ISO 8601
  int repeat = 0, warmup = 0, width = 0, height = 0, error_samples = 0;
};

void write_csv(const std::vector<Result>& results, const std::string& path);
void write_markdown(const std::vector<Result>& results, const RunInfo& info, const std::string& path);

// Runs the plot script (python3 + matplotlib) on results.csv; returns false
// (with a message on stderr) when it cannot, so the caller can go on.
bool plot(const std::string& python, const std::string& script, const std::string& csv, const std::string& out_dir);
std::string default_plot_script();

}  // namespace cdsm::cli::bench
