// cdsm bench: statistics over runs, Pareto fronts, and the written results.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <type_traits>
#include <vector>

#include "bench.h"

namespace cdsm::cli::bench {
namespace {

std::string num(double v, const char* f = "%.6g") {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  if (std::isnan(v)) return "nan";
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

double quantile(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return 0.0;
  double pos = q * double(sorted.size() - 1);
  size_t i = size_t(pos);
  double f = pos - double(i);
  return i + 1 < sorted.size() ? sorted[i] * (1.0 - f) + sorted[i + 1] * f : sorted[i];
}

}  // namespace

Spread spread_of(std::vector<double> v) {
  Spread s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  s.min = v.front();
  s.max = v.back();
  s.median = quantile(v, 0.5);
  s.q1 = quantile(v, 0.25);
  s.q3 = quantile(v, 0.75);
  return s;
}

void mark_pareto(std::vector<Result>& results) {
  for (Result& a : results) {
    if (a.is_reference) continue;
    a.pareto_time = a.pareto_memory = true;
    for (const Result& b : results) {
      if (&a == &b || b.is_reference || b.scene_name != a.scene_name) continue;
      double ea = a.transmittance.rmse, eb = b.transmittance.rmse;
      auto dominates = [&](double cb, double ca) { return cb <= ca && eb <= ea && (cb < ca || eb < ea); };
      if (dominates(b.time_ms(), a.time_ms())) a.pareto_time = false;
      if (dominates(b.memory_bytes(), a.memory_bytes())) a.pareto_memory = false;
    }
  }
}

void write_csv(const std::vector<Result>& results, const std::string& path) {
  static const char* const kColumns[] = {"scene",
                                         "scene_name",
                                         "label",
                                         "method",
                                         "method_param",
                                         "epsilon",
                                         "resolution",
                                         "clusters",
                                         "layout",
                                         "backend",
                                         "penumbra",
                                         "fragment_source",
                                         "runs",
                                         "fragments_ms_median",
                                         "build_ms_median",
                                         "build_ms_min",
                                         "build_ms_max",
                                         "build_ms_q1",
                                         "build_ms_q3",
                                         "camera_ms_median",
                                         "camera_ms_min",
                                         "camera_ms_max",
                                         "camera_ms_q1",
                                         "camera_ms_q3",
                                         "frame_ms_median",
                                         "time_ms",
                                         "memory_bytes",
                                         "t_points",
                                         "t_mean",
                                         "t_p99",
                                         "t_max",
                                         "t_rmse",
                                         "t_mean_r",
                                         "t_mean_g",
                                         "t_mean_b",
                                         "map_err_mean",
                                         "map_err_p99",
                                         "map_err_max",
                                         "res_err_mean",
                                         "res_err_p99",
                                         "res_err_max",
                                         "interior_share",
                                         "interior_total_mean",
                                         "interior_total_p99",
                                         "interior_total_max",
                                         "interior_map_p99",
                                         "interior_map_max",
                                         "edge_share",
                                         "edge_total_mean",
                                         "edge_total_p99",
                                         "edge_total_max",
                                         "edge_map_p99",
                                         "image_rmse",
                                         "image_psnr_db",
                                         "pareto_time",
                                         "pareto_memory",
                                         "reference_ms",
                                         "reference_cached"};
  // The maps' memory figures by their names in cdsm/frame_stats.h
  // (for_each_stat), before memory_bytes, their sum.
  std::vector<std::string> columns;
  for (const char* k : kColumns) {
    if (std::string(k) == "memory_bytes")
      for_each_stat(DsmMemory{}, [&](const char* name, auto) { columns.push_back(name); });
    columns.push_back(k);
  }
  std::ofstream f(path);
  if (!f) throw Error(path, "cannot write the results CSV");
  for (size_t i = 0; i < columns.size(); ++i) f << (i ? "," : "") << columns[i];
  f << "\n";
  for (const Result& r : results) {
    std::map<std::string, std::string> v;
    const Config& c = r.config;
    v["scene"] = csv_field(r.scene);
    v["scene_name"] = csv_field(r.scene_name);
    v["reference_ms"] = num(r.reference_ms);
    v["reference_cached"] = r.reference_cached ? "1" : "0";
    if (r.is_reference) {
      // The reference renderer's own time; exact by definition.
      v["label"] = v["method"] = "reference";
      v["time_ms"] = num(r.reference_ms);
      // Every error figure is 0 (the transmittance's own, its map and
      // resolution parts, per class, the image's RMSE).
      for (const std::string& c : columns) {
        const bool error = c == "image_rmse" || c.rfind("map_err_", 0) == 0 || c.rfind("res_err_", 0) == 0 ||
                           c.rfind("interior_total_", 0) == 0 || c.rfind("interior_map_", 0) == 0 ||
                           c.rfind("edge_total_", 0) == 0 || c.rfind("edge_map_", 0) == 0 ||
                           (c.rfind("t_", 0) == 0 && c != "t_points" && c.rfind("t_mean_", 0) != 0);
        if (error) v[c] = "0";
      }
      v["image_psnr_db"] = "inf";
    } else {
      bool dsm = c.method.method == ShadowMethod::Dsm;
      const DsmMemory& m = r.stats.memory;
      const TransmittanceError& t = r.transmittance;
      v["label"] = csv_field(c.label());
      v["method"] = c.method.label;
      v["method_param"] = dsm ? "" : num(c.method.param);
      v["epsilon"] = dsm ? num(c.eps) : "";
      v["resolution"] = c.res_text();
      v["clusters"] = c.clusters_text();
      v["layout"] = c.layout;
      v["backend"] = c.backend;
      v["penumbra"] = tag_name(c.penumbra);
      v["fragment_source"] = r.stats.fragment_source;
      v["runs"] = std::to_string(r.runs);
      v["fragments_ms_median"] = num(r.fragments_ms.median);
      for (auto [name, s] :
           {std::pair<const char*, const Spread*>{"build_ms", &r.build_ms}, {"camera_ms", &r.camera_ms}}) {
        std::string n = name;
        v[n + "_median"] = num(s->median);
        v[n + "_min"] = num(s->min);
        v[n + "_max"] = num(s->max);
        v[n + "_q1"] = num(s->q1);
        v[n + "_q3"] = num(s->q3);
      }
      v["frame_ms_median"] = num(r.frame_ms.median);
      v["time_ms"] = num(r.time_ms());
      for_each_stat(m, [&](const char* name, auto x) {
        v[name] = std::is_floating_point_v<decltype(x)> ? num(double(x)) : std::to_string(uint64_t(x));
      });
      v["memory_bytes"] = num(r.memory_bytes(), "%.0f");
      v["t_mean_r"] = num(t.channel_mean[0]);
      v["t_mean_g"] = num(t.channel_mean[1]);
      v["t_mean_b"] = num(t.channel_mean[2]);
      v["t_points"] = std::to_string(t.points);
      v["t_mean"] = num(t.mean);
      v["t_p99"] = num(t.p99);
      v["t_max"] = num(t.max);
      v["t_rmse"] = num(t.rmse);
      v["map_err_mean"] = num(t.map.mean);
      v["map_err_p99"] = num(t.map.p99);
      v["map_err_max"] = num(t.map.max);
      v["res_err_mean"] = num(t.resolution.mean);
      v["res_err_p99"] = num(t.resolution.p99);
      v["res_err_max"] = num(t.resolution.max);
      v["interior_share"] = num(t.interior.share);
      v["interior_total_mean"] = num(t.interior.total.mean);
      v["interior_total_p99"] = num(t.interior.total.p99);
      v["interior_total_max"] = num(t.interior.total.max);
      v["interior_map_p99"] = num(t.interior.map.p99);
      v["interior_map_max"] = num(t.interior.map.max);
      v["edge_share"] = num(t.edge.share);
      v["edge_total_mean"] = num(t.edge.total.mean);
      v["edge_total_p99"] = num(t.edge.total.p99);
      v["edge_total_max"] = num(t.edge.total.max);
      v["edge_map_p99"] = num(t.edge.map.p99);
      v["image_rmse"] = num(r.image.rmse);
      v["image_psnr_db"] = num(r.image.psnr);
      v["pareto_time"] = r.pareto_time ? "1" : "0";
      v["pareto_memory"] = r.pareto_memory ? "1" : "0";
    }
    for (size_t i = 0; i < columns.size(); ++i) f << (i ? "," : "") << v[columns[i]];
    f << "\n";
  }
  if (!f) throw Error(path, "cannot write the results CSV");
}

void write_markdown(const std::vector<Result>& results, const RunInfo& info, const std::string& path) {
  std::ofstream f(path);
  if (!f) throw Error(path, "cannot write the Markdown table");
  f << "<!-- written by cdsm bench; " << info.date << " -->\n";
  f << "Command: `" << info.command << "`\n\n";
  f << "Image " << info.width << "x" << info.height << "; times are the median [min-max] of " << info.repeat
    << " runs after " << info.warmup << " warm-up run(s), each with a fresh renderer (no map reuse), "
    << "interleaved across the configurations (round-robin). "
    << "*time* = DSM build + camera pass (light-view fragment generation, the same for every method at a "
       "resolution, is in the CSV). Transmittance error: |T - T_ref| at about "
    << info.error_samples
    << " shadow lookups of shaded points, compositing-weighted, decomposed with the filtered "
       "exact reference T_f (the exact transmittance along each lookup tap's light ray, with the lookup's "
       "weights): *map* = |T - T_f| p99 (what ε controls), *res* = |T_f - T_ref| p99 (resolution, "
       "clustering), *int.* = total error p99 / max over interior points (the taps' and the point's exact "
       "transmittances agree within 0.05), "
       "*edge %* = share of edge points. Memory = index + nodes + slack + surface tags + blocker pyramids (maps of "
       "lights with a size). "
       "P: on the Pareto front of time against transmittance RMSE (t) and of memory against it (m).\n\n";
  std::map<std::string, bool> seen;
  for (const Result& first : results) {
    if (seen[first.scene_name]) continue;
    seen[first.scene_name] = true;
    f << "### " << first.scene_name << " (`" << first.scene << "`)\n\n";
    for (const Result& r : results)
      if (r.scene_name == first.scene_name && r.is_reference)
        f << "Reference renderer (exact shadow rays, no maps): " << num(r.reference_ms, "%.1f") << " ms"
          << (r.reference_cached ? " (measured when it was cached)" : "") << ".\n\n";
    bool other_backend = false;
    for (const Result& r : results)
      if (r.scene_name == first.scene_name && !r.is_reference && r.config.backend != "cpu") other_backend = true;
    f << "| method | ε | res | m | layout |" << (other_backend ? " backend |" : "")
      << " build ms | camera ms | memory KiB | nodes/texel avg / max | T mean | T p99 | T max | T RMSE | map p99 |"
         " res p99 | int. p99 / max | edge % | PSNR dB | P |\n";
    f << "|---|---|---|---|---|" << (other_backend ? "---|" : "")
      << "---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const Result& r : results) {
      if (r.scene_name != first.scene_name || r.is_reference) continue;
      const Config& c = r.config;
      bool dsm = c.method.method == ShadowMethod::Dsm;
      auto ms = [](const Spread& s) {
        return num(s.median, "%.1f") + " [" + num(s.min, "%.1f") + "–" + num(s.max, "%.1f") + "]";
      };
      std::string p = std::string(r.pareto_time ? "t" : "") + (r.pareto_memory ? "m" : "");
      f << "| " << c.method.label << (c.penumbra != Penumbra::Estimated ? std::string(" ") + tag_name(c.penumbra) : "")
        << " | " << (dsm ? num(c.eps, "%g") : "") << " | " << c.res_text() << " | " << c.clusters_text() << " | "
        << c.layout << " | " << (other_backend ? c.backend + " | " : "") << ms(r.build_ms) << " | " << ms(r.camera_ms)
        << " | " << num(r.memory_bytes() / 1024.0, "%.0f") << " | " << num(r.stats.memory.avg_nodes_per_texel, "%.2f")
        << " / " << r.stats.memory.max_nodes_per_texel << " | " << num(r.transmittance.mean, "%.4f") << " | "
        << num(r.transmittance.p99, "%.3f") << " | " << num(r.transmittance.max, "%.3f") << " | "
        << num(r.transmittance.rmse, "%.4f") << " | " << num(r.transmittance.map.p99, "%.4f") << " | "
        << num(r.transmittance.resolution.p99, "%.4f") << " | " << num(r.transmittance.interior.total.p99, "%.4f")
        << " / " << num(r.transmittance.interior.total.max, "%.3f") << " | "
        << num(100.0 * r.transmittance.edge.share, "%.1f") << " | " << num(r.image.psnr, "%.2f") << " | " << p
        << " |\n";
    }
    f << "\n";
  }
}

std::string default_plot_script() {
  if (const char* p = std::getenv("CDSM_PLOT_SCRIPT"); p && *p) return p;
#ifdef CDSM_SCRIPTS_DIR
  return std::string(CDSM_SCRIPTS_DIR) + "/plot_bench.py";
#else
  return "scripts/plot_bench.py";
#endif
}

bool plot(const std::string& python, const std::string& script, const std::string& csv, const std::string& out_dir) {
  std::string cmd =
      shell_quote(python) + " " + shell_quote(script) + " " + shell_quote(csv) + " " + shell_quote(out_dir);
  std::fflush(stdout);  // keep our lines before the script's
  int rc = std::system(cmd.c_str());
  if (rc != 0) {
    std::fprintf(stderr,
                 "cdsm bench: warning: the plot failed (%s exited with %d); results.csv and results.md are written.\n"
                 "  It needs python3 with matplotlib (Debian: apt-get install python3-matplotlib).\n",
                 cmd.c_str(), rc);
    return false;
  }
  return true;
}

}  // namespace cdsm::cli::bench
