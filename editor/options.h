// The cdsm program's command line over CLI11: what the verbs' options are
// built from. An option that overrides a field of the scene is declared
// from that field's row of its table (cdsm/fields.h): its type, its range
// or names, and its help come from the row, so a range is written once, in
// the table, and the check and --help follow it (tests/cli/test_options.cpp).
// Every bad value is a CLI::ParseError naming the option, thrown while the
// command line is parsed: before any work.
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "cdsm/cdsm.h"
#include "cdsm/fields.h"

namespace cdsm::cli {

// A verb of the program: its subcommand, and what runs it once the whole
// command line is parsed and checked.
struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;  // returns the process exit code
};

// ---- values -------------------------------------------------------------------

// "[4, 8192]"; integers as integers (2^30, not 1.07374e+09).
std::string range_text(double lo, double hi, bool integer);

// "" when `s` is a number (a whole one where `integer`) within [lo, hi],
// else what is wrong with it ("must be within [4, 8192], got 2").
std::string number_problem(const std::string& s, double lo, double hi, bool integer);

// The number `s`, or cdsm::Error(opt, the problem): for values inside lists
// ("--sweep res=256,512", "--methods osm32").
double parse_number(const std::string& opt, const std::string& s, double lo, double hi, bool integer);

// Checks an option's value against [lo, hi]; --help shows the range.
CLI::Validator within(double lo, double hi, bool integer);

// `text; clause` for --help, on a new line where the last one would grow too long.
std::string add_clause(const std::string& text, const std::string& clause);

// The names an enumeration is given by on the command line, each with its value.
template <class E>
using Choices = std::vector<std::pair<std::string, E>>;

// A tag's names (cdsm/tags.h), in value order.
template <class E>
Choices<E> tag_choices_of() {
  Choices<E> c;
  for (uint32_t i = 0; i < tag_count<E>(); ++i) c.emplace_back(TagNames<E>::names[i], E(i));
  return c;
}

// Option `name` on `app` setting `value` to one of `choices` by name; --help
// shows them ("cuda|cpu|reference"), a wrong one is "unknown WHAT 'x' (cuda,
// cpu or reference)".
template <class E>
CLI::Option* add_choice_option(CLI::App& app, const std::string& name, E& value, const Choices<E>& choices,
                               const std::string& what, const std::string& help) {
  std::string shown, listed;
  for (size_t i = 0; i < choices.size(); ++i) {
    shown += (i ? "|" : "") + choices[i].first;
    listed += (i == 0 ? "" : i + 1 == choices.size() ? " or " : ", ") + choices[i].first;
  }
  // The name becomes the value's number, which CLI11 converts to E.
  CLI::Validator by_name(
      [choices, what, listed](std::string& s) -> std::string {
        for (const auto& [n, v] : choices)
          if (s == n) {
            s = std::to_string(static_cast<long long>(v));
            return "";
          }
        return "unknown " + what + " '" + s + "' (" + listed + ")";
      },
      "");
  return app.add_option(name, value, help)->transform(by_name)->type_name(shown);
}

// ---- options from field rows ----------------------------------------------------

// f(row) for the row of S's table whose key is `key`; false when none is.
template <class S, class F>
bool with_field(std::string_view key, F&& f) {
  bool found = false;
  for_each_field<S>([&](const auto& row) {
    if (!found && key == row.key) {
      found = true;
      f(row);
    }
  });
  return found;
}

// What a field holds (float, int32_t, bool, a tag, Vec3, std::string).
template <class S, class T>
T field_type(const Field<S, T>&);
template <class Row>
using field_value_t = decltype(field_type(std::declval<Row>()));

// Numbers, integers, booleans and tags can be given on the command line.
template <class T>
inline constexpr bool kOnCommandLine = std::is_arithmetic_v<T> || std::is_enum_v<T>;

// Option `name` on `app` setting `value`, from the row `f`: a number or an
// integer within the row's [lo, hi], a boolean as on|off, a tag by one of
// its names; the help is the row's, then `note`.
template <class S, class T>
CLI::Option* add_field_option(CLI::App& app, const std::string& name, const Field<S, T>& f, T& value,
                              const std::string& note = "") {
  static_assert(kOnCommandLine<T>, "vectors and strings have no command-line form");
  const std::string help = note.empty() ? f.help : add_clause(f.help, note);
  if constexpr (std::is_enum_v<T>) {
    return add_choice_option(app, name, value, tag_choices_of<T>(), f.key, help);
  } else if constexpr (std::is_same_v<T, bool>) {
    return add_choice_option(app, name, value, Choices<bool>{{"on", true}, {"off", false}}, "value", help);
  } else if constexpr (std::is_integral_v<T>) {
    if (zero_is_auto(f))  // "auto" is 0 (the library chooses); a 0 typed is out of range
      return app.add_option(name, value, help)
          ->transform(CLI::Validator(
              [lo = f.lo, hi = f.hi](std::string& s) {
                if (s != "auto") return within(lo, hi, true)(s);
                s = "0";
                return std::string();
              },
              "[" + std::to_string(int64_t(f.lo)) + ", " + std::to_string(int64_t(f.hi)) + "] or auto"));
    return app.add_option(name, value, help)->check(within(f.lo, f.hi, true));
  } else {
    return app.add_option(name, value, help)->check(within(f.lo, f.hi, false));
  }
}

// Options that override fields of a `Root` (the scene), each declared from
// its row; apply() sets the fields the command line gave, once the root is loaded.
template <class Root>
class FieldOverrides {
 public:
  // Option `name` for field `key` of the root's `part` (&Scene::shadows, &Scene::camera).
  template <class S>
  CLI::Option* add(CLI::App& app, const std::string& name, S Root::*part, const char* key,
                   const std::string& note = "") {
    CLI::Option* option = nullptr;
    with_field<S>(key, [&](const auto& f) {
      using T = field_value_t<decltype(f)>;
      if constexpr (kOnCommandLine<T>) {
        auto value = std::make_shared<T>();
        const std::string over = std::string("overrides the scene's ") + key;
        option = add_field_option(app, name, f, *value, note.empty() ? over : add_clause(note, over));
        set_.push_back([option, value, part, member = f.member](Root& r) {
          if (option->count() > 0) (r.*part).*member = *value;
        });
      }
    });
    CDSM_CHECK(option, std::string("no field '") + key + "' the command line can set");
    return option;
  }

  void apply(Root& root) const {
    for (const auto& set : set_) set(root);
  }

 private:
  std::vector<std::function<void(Root&)>> set_;
};
using SceneOverrides = FieldOverrides<Scene>;

// ---- what render and bench share -----------------------------------------------

// The frame every render of theirs makes: the image size (the camera's
// width and height), where fragments come from, the error's sample count,
// and the memory limit (0: the scene's, else half the physical memory).
struct FrameOptions {
  SceneOverrides overrides;
  RenderOptions render;
  int64_t max_memory_mib = 0;
  // Every spot and point light's radius, every directional light's angular
  // diameter (degrees); negative: the scene's.
  float light_radius = -1.0f, sun_diameter = -1.0f;

  // Before a scene is read: the reader's generated grids count too.
  void limit_memory() const {
    if (max_memory_mib > 0) set_memory_limit_mib(max_memory_mib);
  }
  // The command line over a loaded scene: its fields, and its memory limit over the scene's.
  void apply(Scene& scene) const {
    overrides.apply(scene);
    if (max_memory_mib > 0) scene.shadows.max_memory_mib = 0;
    for (Light& l : scene.lights) {
      if (light_radius >= 0.0f && l.type != LightType::Directional) l.radius = light_radius;
      if (sun_diameter >= 0.0f && l.type == LightType::Directional) l.angular_diameter_deg = sun_diameter;
    }
  }
};
void add_frame_options(CLI::App& app, FrameOptions& o);

// Throws cdsm::Error naming `path` unless a file can be written there: its
// folder exists and is writable, and it is not a directory or a read-only
// file. Called before any work, so a bad path costs nothing.
void check_writable(const std::string& path);

}  // namespace cdsm::cli
