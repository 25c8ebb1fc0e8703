// The scene file's field reference (cdsm/scene_io.h scene_field_reference),
// written from the field tables so that the README's tables cannot drift.
#include <cmath>
#include <cstdio>
#include <string>
#include <type_traits>

#include "cdsm/fields.h"
#include "cdsm/scene_io.h"

namespace cdsm {
namespace {

std::string number(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

template <class T>
std::string value_text(const T& v) {
  if constexpr (std::is_enum_v<T>)
    return std::string("`") + tag_name(v) + "`";
  else if constexpr (std::is_same_v<T, bool>)
    return v ? "`true`" : "`false`";
  else if constexpr (std::is_same_v<T, Vec3>)
    return "[" + number(v.x) + ", " + number(v.y) + ", " + number(v.z) + "]";
  else if constexpr (std::is_same_v<T, std::string>)
    return v.empty() ? "\"\"" : "\"" + v + "\"";
  else
    return number(double(v));
}

// What a value may be: a tag's names, a boolean, free text, or [lo, hi]
// (each component of a vector; 1e30 is "any finite").
template <class T>
std::string range_text(double lo, double hi) {
  if constexpr (std::is_enum_v<T>) {
    std::string names;
    for (uint32_t i = 0; i < tag_count<T>(); ++i) names += (i ? ", `" : "`") + std::string(tag_name(T(i))) + "`";
    return names;
  } else if constexpr (std::is_same_v<T, bool>) {
    return "`true`, `false`";
  } else if constexpr (std::is_same_v<T, std::string>) {
    return "text";
  } else {
    const std::string r = hi >= 1e29 && lo <= -1e29 ? "any finite number"
                          : hi >= 1e29              ? "≥ " + number(lo)
                                                    : "[" + number(lo) + ", " + number(hi) + "]";
    return std::is_same_v<T, Vec3> ? r + " each" : r;
  }
}

template <class S>
void table(std::string& out, const char* json, const char* cpp) {
  out += "\n| `" + std::string(json) + "` key | C++ (`" + cpp + "`) | default | values | meaning |\n";
  out += "|---|---|---|---|---|\n";
  const S defaults{};
  for_each_field<S>([&](const auto& f) {
    using T = std::remove_cv_t<std::remove_reference_t<decltype(defaults.*f.member)>>;
    out += "| `" + std::string(f.key) + "` | `" + (f.cpp ? f.cpp : "?") + "` | " + value_text(defaults.*f.member) +
           " | " + range_text<T>(f.lo, f.hi) + (zero_is_auto(f) ? " or `auto`" : "") + " | " + f.help + " |\n";
  });
}

}  // namespace

std::string scene_field_reference() {
  std::string out =
      "A scene must have `camera` (with `position` and `target`), `objects` (each with a `mesh`) and `lights` "
      "(each with a `type`; a `position` unless directional; a `direction` or a `target` unless a point light). "
      "`shadows`, `background`, `volumes` and `comment` are optional; every field below has the default shown.\n";
  table<Camera>(out, "camera", "cdsm::Camera");
  table<ShadowSettings>(out, "shadows", "cdsm::ShadowSettings");
  table<Light>(out, "lights[]", "cdsm::Light");
  table<Object>(out, "objects[]", "cdsm::Object");
  table<SurfaceMaterial>(out, "objects[].material", "cdsm::Object::surface, a cdsm::SurfaceMaterial");
  table<Volume>(out, "volumes[]", "cdsm::Volume");
  return out;
}

}  // namespace cdsm
