// cdsm bench: sweep axes, methods, and what this build can run.
#include <cmath>
#include <cstdio>
#include <sstream>

#include "bench.h"
#include "options.h"
#include "cdsm/method_params.h"

namespace cdsm::cli::bench {
namespace {

// What this build can sweep. When a backend or a cluster count lands,
// flipping its entry here is the whole change. Every layout (cdsm/tags.h)
// is available: packed, fixed (thesis §4.2.1 "3D texture", L =
// ShadowSettings::fixed_layers), chunked (§4.2.2 linked chunks of
// ShadowSettings::chunk_nodes).
struct BackendChoice {
  const char* name;
  Backend backend;
  bool available;
};
constexpr BackendChoice kBackends[] = {
    {"cpu", Backend::Cpu, true}, {"cuda", Backend::Cuda, true},  // at run time: needs a CUDA device (resolve_backend)
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

int count_param(const std::string& label, size_t prefix, double lo, double hi) {
  return int(parse_number("--methods " + label, label.substr(prefix), lo, hi, true));
}

// The count N of a method written "nameN", within the method's parameter range (cdsm/tags.h).
int method_count(const std::string& label, size_t prefix, ShadowMethod m) {
  return count_param(label, prefix, method_param(m).lo, method_param(m).hi);
}

// The range of field `key` of the shadow settings (cdsm/fields.h).
std::pair<double, double> settings_range(const char* key) {
  std::pair<double, double> r;
  const bool found = with_field<ShadowSettings>(key, [&](const auto& f) { r = {f.lo, f.hi}; });
  CDSM_CHECK(found, std::string("no shadow setting '") + key + "'");
  return r;
}

}  // namespace

const char* const kMethodsList = "dsm, dsmgrey, sm, sm:T, osmN, avsmN, pssmN, domN, domN:T, fomN, mom4, mom8";

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
      const MethodParam& mp = method_param(ShadowMethod::ShadowMap);
      s.param = m == "sm" ? mp.fallback : float(parse_number("--methods " + m, m.substr(3), mp.lo, mp.hi, false));
      if (!(s.param > 0.0f))
        throw Error("--methods " + m, std::string(mp.what) + " must be within (0, " + fmt(mp.hi) + "]");
    } else if (m.rfind("osm", 0) == 0 && m.size() > 3) {
      s.method = ShadowMethod::OpacitySlices;
      s.param = float(method_count(m, 3, s.method));
    } else if (m.rfind("pssm", 0) == 0 && m.size() > 4) {
      s.method = ShadowMethod::Dsm;  // deep shadow maps in parallel-split cascades
      s.splits = count_param(m, 4, 2, settings_range("parallel_splits").second);  // up to the scene's limit
    } else if (m.rfind("avsm", 0) == 0 && m.size() > 4) {
      s.method = ShadowMethod::FixedNodes;
      s.param = float(method_count(m, 4, s.method));
    } else if (m.rfind("dom", 0) == 0 && m.size() > 3) {
      s.method = ShadowMethod::DeepOpacity;
      const size_t colon = m.find(':');
      s.param = float(method_count(m.substr(0, colon), 3, s.method));
      if (colon != std::string::npos)
        with_field<ShadowSettings>("layer_thickness", [&](const auto& f) {
          s.layer_thickness = float(parse_number("--methods " + m, m.substr(colon + 1), f.lo, f.hi, false));
        });
    } else if (m.rfind("fom", 0) == 0 && m.size() > 3) {
      s.method = ShadowMethod::FourierOpacity;
      s.param = float(method_count(m, 3, s.method));
    } else if (m.rfind("mom", 0) == 0 && m.size() > 3) {
      s.method = ShadowMethod::Moments;
      s.param = float(method_count(m, 3, s.method));
      if (!moment_count_allowed(s.param)) throw Error("--methods " + m, "moments: 4 or 8 power moments (mom4, mom8)");
    } else {
      throw Error("--methods " + m, std::string("unknown method (") + kMethodsList + ")");
    }
    out.push_back(s);
  }
  return out;
}

std::vector<MethodSpec> default_methods() { return parse_methods("dsm,sm,osm16,osm32,osm64,avsm4,avsm8,avsm16"); }

std::vector<std::string> parse_layouts(const std::string& list) {
  std::vector<std::string> out;
  for (const std::string& v : split(list, "--layouts")) {
    DsmLayout layout;
    if (!parse_tag(v, layout)) throw Error("--layouts " + v, "unknown layout (" + tag_choices<DsmLayout>() + ")");
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
  // The three number axes take the ranges of the settings they set.
  if (name == "eps") {
    const auto [lo, hi] = settings_range("epsilon");
    sweep.eps.clear();
    for (const std::string& v : split(values, opt)) sweep.eps.push_back(float(parse_number(opt, v, lo, hi, false)));
  } else if (name == "res") {
    const auto [lo, hi] = settings_range("resolution");
    sweep.res.clear();
    for (const std::string& v : split(values, opt))
      sweep.res.push_back(v == "auto" ? kAutoResolution : int(parse_number(opt, v, lo, hi, true)));
  } else if (name == "tpp") {
    with_field<ShadowSettings>("texels_per_pixel", [&](const auto& f) {
      sweep.tpp.clear();
      for (const std::string& v : split(values, opt))
        sweep.tpp.push_back(float(parse_number(opt, v, f.lo, f.hi, false)));
    });
  } else if (name == "clusters") {
    const auto [lo, hi] = settings_range("clusters");
    sweep.clusters.clear();
    for (const std::string& v : split(values, opt)) {
      const int m = v == "auto" ? kAutoClusters : int(parse_number(opt, v, lo, hi, true));
      if (m > kMaxClustersAvailable)
        throw Error(opt,
                    "clusters=" + v + " is not available yet (at most " + std::to_string(kMaxClustersAvailable) + ")");
      sweep.clusters.push_back(m);
    }
  } else if (name == "radius" || name == "angular_diameter") {
    with_field<Light>(name.c_str(), [&](const auto& f) {
      std::vector<float>& axis = name == "radius" ? sweep.radius : sweep.angular_diameter;
      axis.clear();
      for (const std::string& v : split(values, opt)) axis.push_back(float(parse_number(opt, v, f.lo, f.hi, false)));
    });
  } else if (name == "penumbra") {
    sweep.penumbrae.clear();
    for (const std::string& v : split(values, opt)) {
      Penumbra p;
      if (!parse_tag(v, p)) throw Error(opt + "=" + v, "unknown penumbra (" + tag_choices<Penumbra>() + ")");
      sweep.penumbrae.push_back(p);
    }
  } else if (name == "layout" || name == "layouts") {
    sweep.layouts = parse_layouts(values);
  } else if (name == "backend" || name == "backends") {
    sweep.backends = parse_backends(values);
  } else if (name == "method" || name == "methods") {
    sweep.methods = parse_methods(values);
  } else {
    throw Error(opt,
                "unknown sweep axis (eps, res, clusters, radius, angular_diameter, penumbra; also layouts, backends, "
                "methods)");
  }
}

std::string sweep_help() {
  auto range = [](const char* key, bool integer) {
    const auto [lo, hi] = settings_range(key);
    return range_text(lo, hi, integer);
  };
  return "an axis and its comma-separated values; every combination is measured:\n"
         "  eps=0,0.001,0.01,0.1  DSM error bound, each within " +
         range("epsilon", false) +
         " (default: the\n"
         "                        scene's); baselines are measured once per resolution, not per eps\n"
         "  res=256,512,1024,auto shadow-map texels per side, each within " +
         range("resolution", true) +
         "\n"
         "                        or auto: each map's from the screen (default: the scene's)\n"
         "  tpp=1,2               auto resolution: texels per image pixel (default: the scene's)\n"
         "  clusters=1,2,4,auto   at most m clustered maps per light, each within " +
         range("clusters", true) +
         "\n"
         "                        or auto: per light from the screen (default: the scene's)\n"
         "  radius=0,0.05,0.15    every spot and point light's radius, world units (a variant of the\n"
         "                        scene with its own area-sampled reference per value)\n"
         "  angular_diameter=0.53 every directional light's apparent size, degrees (variants as radius)\n"
         "  penumbra=estimated,fixed_kernel,hard  how lights with a size soften (default: the scene's)\n"
         "  layouts=, backends=, methods=  as --layouts, --backends, --methods";
}

std::string capabilities_text() {
  std::string s = "  layouts in this build:  ";
  for (uint32_t i = 0; i < tag_count<DsmLayout>(); ++i) s += std::string(TagNames<DsmLayout>::names[i]) + "  ";
  s += "\n  backends in this build: ";
  for (const BackendChoice& b : kBackends)
    s += std::string(b.name) + (b.available ? "" : " (not available yet)") + "  ";
  s += "\n  clusters in this build: 1.." + std::to_string(kMaxClustersAvailable) + "\n";
  return s;
}

std::string Config::label() const {
  std::string s = method.label;
  if (method.method == ShadowMethod::Dsm) s += " eps=" + fmt(eps);
  s += " res=" + res_text();
  if (clusters != 1) s += " m=" + clusters_text();
  if (layout != "packed") s += " " + layout;
  if (backend != "cpu") s += " " + backend;
  if (penumbra != Penumbra::Estimated) s += std::string(" ") + tag_name(penumbra);
  return s;
}

std::string Config::clusters_text() const { return clusters == kAutoClusters ? "auto" : std::to_string(clusters); }

std::string Config::res_text() const {
  if (res != kAutoResolution) return std::to_string(res);
  return tpp > 0.0f ? "auto x" + fmt(tpp) : "auto";
}

std::vector<SizeVariant> size_variants(const Sweep& sw) {
  std::vector<SizeVariant> out;
  const std::vector<float> none{-1.0f};
  for (float r : sw.radius.empty() ? none : sw.radius)
    for (float a : sw.angular_diameter.empty() ? none : sw.angular_diameter) {
      SizeVariant v;
      v.radius = r;
      v.angular_diameter = a;
      if (r >= 0.0f) v.suffix += "@r" + fmt(r);
      if (a >= 0.0f) v.suffix += "@sun" + fmt(a);
      out.push_back(v);
    }
  return out;
}

void apply(const SizeVariant& v, Scene& scene) {
  for (Light& l : scene.lights) {
    if (v.radius >= 0.0f && l.type != LightType::Directional) l.radius = v.radius;
    if (v.angular_diameter >= 0.0f && l.type == LightType::Directional) l.angular_diameter_deg = v.angular_diameter;
  }
}

std::vector<Config> expand(const Sweep& sw, const Scene& scene) {
  std::vector<float> eps = sw.eps.empty() ? std::vector<float>{scene.shadows.epsilon} : sw.eps;
  std::vector<int> res = sw.res.empty() ? std::vector<int>{scene.shadows.resolution} : sw.res;
  std::vector<int> clusters = sw.clusters.empty() ? std::vector<int>{scene.shadows.max_clusters} : sw.clusters;
  std::vector<float> tpps = sw.tpp.empty() ? std::vector<float>{-1.0f} : sw.tpp;
  std::vector<MethodSpec> methods = sw.methods.empty() ? default_methods() : sw.methods;
  std::vector<std::string> layouts = sw.layouts.empty() ? std::vector<std::string>{"packed"} : sw.layouts;
  std::vector<std::string> backends = sw.backends.empty() ? std::vector<std::string>{"cpu"} : sw.backends;
  std::vector<Penumbra> penumbrae = sw.penumbrae.empty() ? std::vector<Penumbra>{scene.shadows.penumbra} : sw.penumbrae;
  std::vector<Config> out;
  for (Penumbra pen : penumbrae)
    for (const std::string& backend : backends)
      for (const std::string& layout : layouts)
        for (int m : clusters)
          for (int r : res)
            for (size_t t = 0; t < (r == kAutoResolution ? tpps.size() : 1); ++t)
              for (const MethodSpec& method : methods) {
                bool dsm = method.method == ShadowMethod::Dsm && method.splits == 0;
                for (size_t e = 0; e < (dsm ? eps.size() : 1); ++e) {
                  Config c;
                  c.method = method;
                  c.eps = dsm ? eps[e] : scene.shadows.epsilon;
                  c.res = r;
                  c.tpp = r == kAutoResolution ? tpps[t] : -1.0f;
                  c.clusters = m;
                  c.layout = layout;
                  c.backend = backend;
                  c.penumbra = pen;
                  out.push_back(c);
                }
              }
  return out;
}

void apply(const Config& c, Scene& scene, RenderOptions& opt) {
  ShadowSettings& s = scene.shadows;
  s.method = c.method.method;
  s.method_param = c.method.param;
  s.layer_thickness = c.method.layer_thickness;
  s.epsilon = c.eps;
  s.resolution = c.res;
  if (c.tpp > 0.0f) s.texels_per_pixel = c.tpp;
  s.max_clusters = c.method.splits > 0 ? 1 : c.clusters;
  s.parallel_splits = c.method.splits;
  s.rgb_maps = !c.method.grey_maps;
  s.penumbra = c.penumbra;
  parse_tag(c.layout, s.layout);
  for (const BackendChoice& b : kBackends)
    if (c.backend == b.name) opt.backend = b.backend;
}

}  // namespace cdsm::cli::bench
