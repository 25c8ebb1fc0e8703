// cdsm bench: sweep axes, methods, and what this build can run.
#include <cmath>
#include <cstdio>
#include <sstream>

#include "bench.h"
#include "commands.h"

namespace cdsm::cli::bench {
namespace {

// What this build can sweep. When a layout, a backend or a cluster count
// lands, flipping its entry here is the whole change.
struct LayoutChoice {
  const char* name;
  DsmLayout layout;
  bool available;
};
constexpr LayoutChoice kLayouts[] = {
    {"packed", DsmLayout::Packed, true},
    {"fixed", DsmLayout::Fixed, true},      // thesis §4.2.1 "3D texture", L = ShadowSettings::fixed_layers
    {"chunked", DsmLayout::Chunked, true},  // thesis §4.2.2 linked chunks of ShadowSettings::chunk_nodes
};

struct BackendChoice {
  const char* name;
  Backend backend;
  bool available;
};
constexpr BackendChoice kBackends[] = {
    {"cpu", Backend::Cpu, true},
    {"cuda", Backend::Cuda, true},  // at run time: needs a CUDA device (resolve_backend)
};

constexpr int kMaxClustersAvailable = kMaxMapsPerLight;  // clustering (thesis Alg. 4.2) is wired

std::vector<std::string> split(const std::string& list, const std::string& opt) {
  std::vector<std::string> out;
  std::stringstream ss(list);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  if (out.empty()) throw Error(opt, "needs a comma-separated list of values");
  return out;
}

std::string fmt(float v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", double(v));
  return b;
}

int count_param(const std::string& label, size_t prefix, int lo, int hi) {
  std::string digits = label.substr(prefix);
  int n = parse_int("--methods " + label, digits);
  if (n < lo || n > hi)
    throw Error("--methods " + label, "the count must be within [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return n;
}

}  // namespace

std::vector<MethodSpec> parse_methods(const std::string& list) {
  std::vector<MethodSpec> out;
  for (const std::string& m : split(list, "--methods")) {
    MethodSpec s;
    s.label = m;
    if (m == "dsm") {
      s.method = ShadowMethod::Dsm;
    } else if (m == "dsmgrey") {
      s.method = ShadowMethod::Dsm;
      s.grey_maps = true;
    } else if (m == "sm" || m.rfind("sm:", 0) == 0) {
      s.method = ShadowMethod::ShadowMap;
      s.param = m == "sm" ? 0.5f : parse_float("--methods " + m, m.substr(3));
      if (!(s.param > 0.0f && s.param <= 1.0f)) throw Error("--methods " + m, "the opacity threshold must be within (0, 1]");
    } else if (m.rfind("osm", 0) == 0 && m.size() > 3) {
      s.method = ShadowMethod::OpacitySlices;
      s.param = float(count_param(m, 3, 1, 512));
    } else if (m.rfind("pssm", 0) == 0 && m.size() > 4) {
      s.method = ShadowMethod::Dsm;  // deep shadow maps in parallel-split cascades
      s.splits = count_param(m, 4, 2, 8);
    } else if (m.rfind("avsm", 0) == 0 && m.size() > 4) {
      s.method = ShadowMethod::FixedNodes;
      s.param = float(count_param(m, 4, 2, 512));
    } else {
      throw Error("--methods " + m, "unknown method (dsm, dsmgrey, sm, sm:T, osmN, avsmN, pssmN)");
    }
    out.push_back(s);
  }
  return out;
}

std::vector<MethodSpec> default_methods() {
  return parse_methods("dsm,sm,osm16,osm32,osm64,avsm4,avsm8,avsm16");
}

std::vector<std::string> parse_layouts(const std::string& list) {
  std::vector<std::string> out;
  for (const std::string& v : split(list, "--layouts")) {
    const LayoutChoice* c = nullptr;
    for (const LayoutChoice& l : kLayouts)
      if (v == l.name) c = &l;
    if (!c) throw Error("--layouts " + v, "unknown layout (packed, fixed, chunked)");
    if (!c->available) throw Error("--layouts " + v, "the " + v + " layout is not available yet");
    out.push_back(v);
  }
  return out;
}

std::vector<std::string> parse_backends(const std::string& list) {
  std::vector<std::string> out;
  for (const std::string& v : split(list, "--backends")) {
    const BackendChoice* c = nullptr;
    for (const BackendChoice& b : kBackends)
      if (v == b.name) c = &b;
    if (!c) throw Error("--backends " + v, "unknown backend (cpu, cuda)");
    if (!c->available) throw Error("--backends " + v, "the " + v + " backend is not available yet (only cpu)");
    const BackendResolution r = resolve_backend(c->backend);
    if (!r.available) throw Error("--backends " + v, r.reason);
    out.push_back(v);
  }
  return out;
}

void parse_sweep(const std::string& spec, Sweep& sweep) {
  size_t eq = spec.find('=');
  if (eq == std::string::npos) throw Error("--sweep " + spec, "expected NAME=V1,V2,... (eps, res, clusters)");
  std::string name = spec.substr(0, eq), values = spec.substr(eq + 1);
  std::string opt = "--sweep " + name;
  if (name == "eps") {
    sweep.eps.clear();
    for (const std::string& v : split(values, opt)) {
      float e = parse_float(opt, v);
      if (e < 0.0f) throw Error(opt, "epsilon must be >= 0, got " + v);
      sweep.eps.push_back(e);
    }
  } else if (name == "res") {
    sweep.res.clear();
    for (const std::string& v : split(values, opt)) {
      int r = parse_int(opt, v);
      if (r < 4 || r > 8192) throw Error(opt, "resolution must be within [4, 8192], got " + v);
      sweep.res.push_back(r);
    }
  } else if (name == "clusters") {
    sweep.clusters.clear();
    for (const std::string& v : split(values, opt)) {
      int m = parse_int(opt, v);
      if (m < 1 || m > kMaxMapsPerLight)
        throw Error(opt, "cluster count must be within [1, " + std::to_string(kMaxMapsPerLight) + "], got " + v);
      if (m > kMaxClustersAvailable)
        throw Error(opt, "clusters=" + v + " is not available yet (at most " + std::to_string(kMaxClustersAvailable) + ")");
      sweep.clusters.push_back(m);
    }
  } else if (name == "layout" || name == "layouts") {
    sweep.layouts = parse_layouts(values);
  } else if (name == "backend" || name == "backends") {
    sweep.backends = parse_backends(values);
  } else if (name == "method" || name == "methods") {
    sweep.methods = parse_methods(values);
  } else {
    throw Error(opt, "unknown sweep axis (eps, res, clusters; also layouts, backends, methods)");
  }
}

std::string capabilities_text() {
  std::string s = "  layouts in this build:  ";
  for (const LayoutChoice& l : kLayouts) s += std::string(l.name) + (l.available ? "" : " (not available yet)") + "  ";
  s += "\n  backends in this build: ";
  for (const BackendChoice& b : kBackends) s += std::string(b.name) + (b.available ? "" : " (not available yet)") + "  ";
  s += "\n  clusters in this build: 1.." + std::to_string(kMaxClustersAvailable) + "\n";
  return s;
}

std::string Config::label() const {
  std::string s = method.label;
  if (method.method == ShadowMethod::Dsm) s += " eps=" + fmt(eps);
  s += " res=" + std::to_string(res);
  if (clusters > 1) s += " m=" + std::to_string(clusters);
  if (layout != "packed") s += " " + layout;
  if (backend != "cpu") s += " " + backend;
  return s;
}

std::vector<Config> expand(const Sweep& sw, const Scene& scene) {
  std::vector<float> eps = sw.eps.empty() ? std::vector<float>{scene.shadows.epsilon} : sw.eps;
  std::vector<int> res = sw.res.empty() ? std::vector<int>{scene.shadows.resolution} : sw.res;
  std::vector<int> clusters = sw.clusters.empty() ? std::vector<int>{scene.shadows.max_clusters} : sw.clusters;
  std::vector<MethodSpec> methods = sw.methods.empty() ? default_methods() : sw.methods;
  std::vector<std::string> layouts = sw.layouts.empty() ? std::vector<std::string>{"packed"} : sw.layouts;
  std::vector<std::string> backends = sw.backends.empty() ? std::vector<std::string>{"cpu"} : sw.backends;
  std::vector<Config> out;
  for (const std::string& backend : backends)
    for (const std::string& layout : layouts)
      for (int m : clusters)
        for (int r : res)
          for (const MethodSpec& method : methods) {
            bool dsm = method.method == ShadowMethod::Dsm && method.splits == 0;
            for (size_t e = 0; e < (dsm ? eps.size() : 1); ++e) {
              Config c;
              c.method = method;
              c.eps = dsm ? eps[e] : scene.shadows.epsilon;
              c.res = r;
              c.clusters = m;
              c.layout = layout;
              c.backend = backend;
              out.push_back(c);
            }
          }
  return out;
}

void apply(const Config& c, Scene& scene, RenderOptions& opt) {
  ShadowSettings& s = scene.shadows;
  s.method = c.method.method;
  s.method_param = c.method.param;
  s.epsilon = c.eps;
  s.resolution = c.res;
  s.max_clusters = c.method.splits > 0 ? 1 : c.clusters;
  s.parallel_splits = c.method.splits;
  s.rgb_maps = !c.method.grey_maps;
  for (const LayoutChoice& l : kLayouts)
    if (c.layout == l.name) s.layout = l.layout;
  for (const BackendChoice& b : kBackends)
    if (c.backend == b.name) opt.backend = b.backend;
}

}  // namespace cdsm::cli::bench
