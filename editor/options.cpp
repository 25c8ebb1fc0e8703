// The cdsm program's command line over CLI11 (options.h).
#include "options.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

namespace cdsm::cli {

std::string range_text(double lo, double hi, bool integer) {
  auto text = [&](double x) { return integer ? std::to_string(int64_t(x)) : format_number(x); };
  return "[" + text(lo) + ", " + text(hi) + "]";
}

std::string number_problem(const std::string& s, double lo, double hi, bool integer) {
  double v = 0.0;
  size_t used = 0;
  try {
    v = integer ? double(std::stoll(s, &used)) : std::stod(s, &used);
  } catch (...) {
    used = 0;
  }
  if (used == 0 || used != s.size() || !std::isfinite(v))
    return std::string(integer ? "expected an integer" : "expected a finite number") + ", got '" + s + "'";
  if (!(v >= lo && v <= hi)) return "must be within " + range_text(lo, hi, integer) + ", got " + s;
  return "";
}

double parse_number(const std::string& opt, const std::string& s, double lo, double hi, bool integer) {
  const std::string problem = number_problem(s, lo, hi, integer);
  if (!problem.empty()) throw Error(opt, problem);
  return std::stod(s);
}

CLI::Validator within(double lo, double hi, bool integer) {
  return CLI::Validator([=](std::string& s) { return number_problem(s, lo, hi, integer); },
                        range_text(lo, hi, integer));
}

std::string add_clause(const std::string& text, const std::string& clause) {
  const size_t last = text.rfind('\n'), line = last == std::string::npos ? text.size() : text.size() - last - 1;
  const size_t first = std::min(clause.find('\n'), clause.size());  // the clause's first line
  return text + (line + 2 + first > 90 ? ";\n" : "; ") + clause;
}

void add_frame_options(CLI::App& app, FrameOptions& o) {
  add_choice_option(app, "--fragments", o.render.fragments,
                    Choices<FragmentSource>{{"auto", FragmentSource::Auto},
                                            {"gl", FragmentSource::Gl},
                                            {"cpu", FragmentSource::Cpu},
                                            {"cuda", FragmentSource::Cuda}},
                    "producer",
                    "fragment producer: the OpenGL rasterizer, the CPU ray caster, or the ray caster on the CUDA\n"
                    "device (with the cuda backend); auto (the default): gl when an OpenGL 4.5 context can be made");
  o.overrides.add(app, "--width", &Scene::camera, "width");
  o.overrides.add(app, "--height", &Scene::camera, "height");
  with_field<Light>("radius", [&](const auto& f) {
    app.add_option("--light-radius", o.light_radius,
                   "every spot and point light a sphere of this radius (world units; 0: a point): soft shadows")
        ->check(within(f.lo, f.hi, false));
  });
  with_field<Light>("angular_diameter", [&](const auto& f) {
    app.add_option("--sun-diameter", o.sun_diameter,
                   "every directional light this angular diameter (degrees; the sun 0.53, 0: a point)")
        ->check(within(f.lo, f.hi, false));
  });
  app.add_option("--error-samples", o.render.error_samples, "shaded points for the transmittance error")
      ->check(within(1, 1e7, true))
      ->capture_default_str();
  // N, NM or NG, as MiB up to the largest shadows.max_memory a scene may give.
  double most = 0.0;
  with_field<ShadowSettings>("max_memory", [&](const auto& f) { most = f.hi; });
  CLI::Validator mib(
      [most](std::string& s) -> std::string {
        std::string digits = s;
        int64_t unit = 1;
        if (!digits.empty() && (digits.back() == 'G' || digits.back() == 'g')) {
          unit = 1024;
          digits.pop_back();
        } else if (!digits.empty() && (digits.back() == 'M' || digits.back() == 'm')) {
          digits.pop_back();
        }
        if (!number_problem(digits, 1, most, true).empty() || std::stoll(digits) * unit > int64_t(most))
          return "expected a size N (MiB), NM or NG within [1 MiB, " + std::to_string(int64_t(most)) + " MiB], got '" +
                 s + "'";
        s = std::to_string(std::stoll(digits) * unit);
        return "";
      },
      "");
  app.add_option("--max-memory", o.max_memory_mib,
                 "refuse scenes and settings estimated to need more than N MiB (or GiB); default: the\n"
                 "scene's shadows.max_memory, else half the physical memory")
      ->transform(mib)
      ->type_name("N[M|G]");
}

void check_writable(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path p(path);
  if (fs::is_directory(p, ec)) throw Error(path, "is a directory, not a file that can be written");
  fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  if (!fs::is_directory(dir, ec))
    throw Error(path, "cannot be written: the directory '" + dir.string() + "' does not exist");
  if (fs::exists(p, ec) ? ::access(path.c_str(), W_OK) != 0 : ::access(dir.c_str(), W_OK) != 0)
    throw Error(path, "cannot be written: permission denied");
}

}  // namespace cdsm::cli
