#include "state/edit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <type_traits>

#include "cdsm/fields.h"
#include "cdsm/config.h"

namespace cdsm::editor {
namespace {

// Bit-for-bit equality (so -0 vs 0 and NaN payloads count as edits).
template <class T>
bool same(const T& a, const T& b) {
  static_assert(std::is_trivially_copyable_v<T>);
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}
bool same(const Interior& a, const Interior& b) {
  return a.kind == b.kind && same(a.sigma, b.sigma) && a.volume == b.volume;
}
bool same(const SurfaceMaterial& a, const SurfaceMaterial& b) { return same_fields(a, b); }
bool same(const TransferPoint& a, const TransferPoint& b) {
  return same(a.density, b.density) && same(a.extinction, b.extinction) && same(a.color, b.color);
}
bool same(const std::vector<TransferPoint>& a, const std::vector<TransferPoint>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (!same(a[i], b[i])) return false;
  return true;
}

// The fields that differ, by their scene-file names, joined by '+'.
struct Diff {
  std::string fields;
  template <class T>
  void field(const char* name, const T& a, const T& b) {
    if (!same(a, b)) fields += (fields.empty() ? "" : "+") + std::string(name);
  }
};

Diff settings_diff(const ShadowSettings& a, const ShadowSettings& b) { return {changed_fields(a, b)}; }

Diff light_diff(const Light& a, const Light& b) { return {changed_fields(a, b)}; }

Diff surface_diff(const SurfaceMaterial& a, const SurfaceMaterial& b) { return {changed_fields(a, b)}; }

bool camera_same(const Camera& a, const Camera& b) { return same_fields(a, b); }

bool light_same(const Light& a, const Light& b) { return light_diff(a, b).fields.empty(); }

std::string idx(const char* what, size_t i) { return std::string(what) + "/" + std::to_string(i); }

Edit refused(Edit e, const std::string& why) {
  e.refused = why;
  return e;
}

// Index checks: "" when in range.
std::string check_object(const Document& d, size_t i) {
  return i < d.scene.objects.size() ? ""
                                    : "object " + std::to_string(i) + " does not exist (the scene has " +
                                          std::to_string(d.scene.objects.size()) + ")";
}
std::string check_light(const Document& d, size_t i) {
  return i < d.scene.lights.size() ? ""
                                   : "light " + std::to_string(i) + " does not exist (the scene has " +
                                         std::to_string(d.scene.lights.size()) + ")";
}

Interior interior_of(const Object& o) { return {o.interior, o.sigma, o.volume}; }

Edit insert_light(const Document& doc, size_t at, const Light& light) {
  Edit e;
  const size_t n = doc.scene.lights.size();
  e.what = change::AddLight{std::min(at, n), light};
  e.key = "lights+";
  if (at > n) return refused(e, "light " + std::to_string(at) + " cannot be inserted among " + std::to_string(n));
  if (n >= size_t(kMaxLights)) return refused(e, "a scene has at most " + std::to_string(kMaxLights) + " lights");
  return e;
}

std::string number(float v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", double(v));
  return b;
}

}  // namespace

// ---- the edits ----------------------------------------------------------------

Edit set_settings(const Document& doc, const ShadowSettings& next) {
  Edit e;
  e.what = change::Settings{doc.scene.shadows, next};
  e.key = "shadows/" + settings_diff(doc.scene.shadows, next).fields;
  return e;
}

Edit set_camera(const Document& doc, const Camera& next) {
  Edit e;
  const ShadowSettings& s = doc.scene.shadows;
  e.what = change::Camera{doc.scene.camera, next, s.clustering() || s.parallel_splits > 1};
  e.key = "camera";
  return e;
}

Edit set_background(const Document& doc, Vec3 next) {
  Edit e;
  e.what = change::Background{doc.scene.background, next};
  e.key = "background";
  return e;
}

Edit set_light(const Document& doc, size_t light, const Light& next) {
  Edit e;
  const std::string bad = check_light(doc, light);
  e.what = change::Light{light, bad.empty() ? doc.scene.lights[light] : next, next};
  if (!bad.empty()) return refused(e, bad);
  e.key = idx("lights", light) + "/" + light_diff(doc.scene.lights[light], next).fields;
  return e;
}

Edit add_light(const Document& doc, const Light& light) { return insert_light(doc, doc.scene.lights.size(), light); }

Edit remove_light(const Document& doc, size_t light) {
  Edit e;
  const std::string bad = check_light(doc, light);
  e.what = change::RemoveLight{light, bad.empty() ? doc.scene.lights[light] : Light{}};
  e.key = "lights-";
  return bad.empty() ? e : refused(e, bad);
}

Edit set_transform(const Document& doc, size_t object, const Mat4& next) {
  Edit e;
  const std::string bad = check_object(doc, object);
  if (!bad.empty()) return refused(Edit{change::Transform{object, next, next, false}, "", ""}, bad);
  const Object& o = doc.scene.objects[object];
  e.what = change::Transform{object, o.transform, next, o.casts_shadows};
  e.key = idx("objects", object) + "/transform";
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      if (!std::isfinite(next.m[i][j])) return refused(e, "the transform has a NaN or infinite entry");
  if (next.m[3][0] != 0 || next.m[3][1] != 0 || next.m[3][2] != 0 || next.m[3][3] != 1)
    return refused(e, "the transform's last row must be 0 0 0 1");
  return e;
}

Edit set_surface(const Document& doc, size_t object, const SurfaceMaterial& next) {
  Edit e;
  const std::string bad = check_object(doc, object);
  if (!bad.empty()) return refused(Edit{change::Surface{object, next, next, false}, "", ""}, bad);
  const Object& o = doc.scene.objects[object];
  e.what = change::Surface{object, o.surface, next, o.casts_shadows};
  e.key = idx("objects", object) + "/material/" + surface_diff(o.surface, next).fields;
  return e;
}

Edit set_interior(const Document& doc, size_t object, InteriorKind kind, Vec3 sigma, int volume) {
  Edit e;
  const Interior next{kind, sigma, volume};
  const std::string bad = check_object(doc, object);
  if (!bad.empty()) return refused(Edit{change::ObjectInterior{object, next, next, false}, "", ""}, bad);
  const Object& o = doc.scene.objects[object];
  e.what = change::ObjectInterior{object, interior_of(o), next, o.casts_shadows};
  e.key = idx("objects", object) + "/interior";
  if (o.interior == InteriorKind::Volume && !(kind == InteriorKind::Volume && volume == o.volume)) {
    const std::string& name = o.volume >= 0 && size_t(o.volume) < doc.scene.volumes.size()
                                  ? doc.scene.volumes[size_t(o.volume)].name
                                  : std::string();
    return refused(e, "volume " + std::to_string(o.volume) + (name.empty() ? "" : " '" + name + "'") +
                          " fills this object, and every volume fills exactly one object: it cannot be taken out");
  }
  if (kind == InteriorKind::Volume) {
    if (volume < 0 || size_t(volume) >= doc.scene.volumes.size())
      return refused(e, "volume " + std::to_string(volume) + " does not exist");
    for (size_t k = 0; k < doc.scene.objects.size(); ++k)
      if (k != object && doc.scene.objects[k].interior == InteriorKind::Volume && doc.scene.objects[k].volume == volume)
        return refused(e, "volume " + std::to_string(volume) + " is the interior of object " + std::to_string(k) +
                              " already (a volume fills one object)");
  }
  return e;
}

Edit set_casts_shadows(const Document& doc, size_t object, bool casts) {
  Edit e;
  const std::string bad = check_object(doc, object);
  e.what = change::CastsShadows{object, bad.empty() ? doc.scene.objects[object].casts_shadows : casts, casts};
  e.key = idx("objects", object) + "/casts_shadows";
  return bad.empty() ? e : refused(e, bad);
}

std::vector<TransferPoint> drag_transfer_point(std::vector<TransferPoint> points, size_t i, float dd, float de) {
  if (i >= points.size() || !std::isfinite(dd) || !std::isfinite(de)) return points;
  TransferPoint& p = points[i];
  const float lo = i > 0 ? points[i - 1].density : -3.0e38f;
  const float hi = i + 1 < points.size() ? points[i + 1].density : 3.0e38f;
  p.density = std::min(std::max(p.density + dd, lo), hi);
  const float old = max_channel(p.extinction);
  const float e = std::max(0.0f, old + de);
  p.extinction = old > 0.0f ? p.extinction * (e / old) : vec3(e);
  return points;
}

Edit set_transfer(const Document& doc, size_t volume, const std::vector<TransferPoint>& next) {
  Edit e;
  change::Transfer t;
  t.volume = volume;
  t.after = next;
  e.key = idx("volumes", volume) + "/transfer";
  if (volume >= doc.scene.volumes.size()) {
    t.before = next;
    e.what = t;
    return refused(e, "volume " + std::to_string(volume) + " does not exist (the scene has " +
                          std::to_string(doc.scene.volumes.size()) + ")");
  }
  t.before = doc.scene.volumes[volume].transfer;
  for (size_t k = 0; k < doc.scene.objects.size(); ++k) {
    const Object& o = doc.scene.objects[k];
    if (o.interior == InteriorKind::Volume && o.volume == int(volume)) {
      t.object = int(k);
      t.caster = o.casts_shadows;
    }
  }
  e.what = t;
  if (next.empty() || next.size() > size_t(kMaxTransferPoints))
    return refused(e, "a transfer function has 1 to " + std::to_string(kMaxTransferPoints) + " control points");
  for (size_t k = 1; k < next.size(); ++k)
    if (next[k].density < next[k - 1].density) return refused(e, "control points must be sorted by density");
  return e;
}

Edit rebased(const Document& doc, Edit e) {
  return std::visit(
      [&](const auto& c) -> Edit {
        using T = std::decay_t<decltype(c)>;
        if constexpr (std::is_same_v<T, change::Settings>)
          return set_settings(doc, c.after);
        else if constexpr (std::is_same_v<T, change::Camera>)
          return set_camera(doc, c.after);
        else if constexpr (std::is_same_v<T, change::Background>)
          return set_background(doc, c.after);
        else if constexpr (std::is_same_v<T, change::Light>)
          return set_light(doc, c.light, c.after);
        else if constexpr (std::is_same_v<T, change::AddLight>)
          return insert_light(doc, c.light, c.value);
        else if constexpr (std::is_same_v<T, change::RemoveLight>)
          return remove_light(doc, c.light);
        else if constexpr (std::is_same_v<T, change::Transform>)
          return set_transform(doc, c.object, c.after);
        else if constexpr (std::is_same_v<T, change::Surface>)
          return set_surface(doc, c.object, c.after);
        else if constexpr (std::is_same_v<T, change::ObjectInterior>)
          return set_interior(doc, c.object, c.after.kind, c.after.sigma, c.after.volume);
        else if constexpr (std::is_same_v<T, change::CastsShadows>)
          return set_casts_shadows(doc, c.object, c.after);
        else
          return set_transfer(doc, c.volume, c.after);
      },
      e.what);
}

// ---- properties ---------------------------------------------------------------

bool Edit::structural() const {
  return std::holds_alternative<change::AddLight>(what) || std::holds_alternative<change::RemoveLight>(what);
}

bool Edit::no_op() const {
  if (!refused.empty()) return true;
  return std::visit(
      [](const auto& c) -> bool {
        using T = std::decay_t<decltype(c)>;
        if constexpr (std::is_same_v<T, change::AddLight> || std::is_same_v<T, change::RemoveLight>)
          return false;
        else if constexpr (std::is_same_v<T, change::Settings>)
          return settings_diff(c.before, c.after).fields.empty();
        else if constexpr (std::is_same_v<T, change::Camera>)
          return camera_same(c.before, c.after);
        else if constexpr (std::is_same_v<T, change::Light>)
          return light_same(c.before, c.after);
        else
          return same(c.before, c.after);
      },
      what);
}

Edit Edit::inverse() const {
  Edit inv = *this;
  std::visit(
      [&](auto c) {
        using T = std::decay_t<decltype(c)>;
        if constexpr (std::is_same_v<T, change::AddLight>) {
          inv.what = change::RemoveLight{c.light, c.value};
          inv.key = "lights-";
        } else if constexpr (std::is_same_v<T, change::RemoveLight>) {
          inv.what = change::AddLight{c.light, c.value};
          inv.key = "lights+";
        } else {
          std::swap(c.before, c.after);
          inv.what = c;
        }
      },
      what);
  return inv;
}

std::string Edit::describe() const {
  if (!refused.empty()) return "refused: " + refused;
  return std::visit(
      [&](const auto& c) -> std::string {
        using T = std::decay_t<decltype(c)>;
        if constexpr (std::is_same_v<T, change::AddLight>)
          return "add light " + std::to_string(c.light);
        else if constexpr (std::is_same_v<T, change::RemoveLight>)
          return "remove light " + std::to_string(c.light);
        else if constexpr (std::is_same_v<T, change::Settings>) {
          const Diff d = settings_diff(c.before, c.after);
          if (d.fields == "epsilon")
            return "shadows/epsilon " + number(c.before.epsilon) + " -> " + number(c.after.epsilon);
          if (d.fields == "d0") return "shadows/d0 " + number(c.before.d0) + " -> " + number(c.after.d0);
          if (d.fields == "clusters") {
            auto m = [](const ShadowSettings& s) {
              return s.auto_clusters() ? "auto" : std::to_string(s.max_clusters);
            };
            return "shadows/clusters " + m(c.before) + " -> " + m(c.after);
          }
          return key;
        } else {
          return key;
        }
      },
      what);
}

void apply_to(Scene& scene, const Edit& e) {
  std::visit(
      [&](const auto& c) {
        using T = std::decay_t<decltype(c)>;
        if constexpr (std::is_same_v<T, change::Settings>)
          scene.shadows = c.after;
        else if constexpr (std::is_same_v<T, change::Camera>)
          scene.camera = c.after;
        else if constexpr (std::is_same_v<T, change::Background>)
          scene.background = c.after;
        else if constexpr (std::is_same_v<T, change::Light>)
          scene.lights[c.light] = c.after;
        else if constexpr (std::is_same_v<T, change::AddLight>)
          scene.lights.insert(scene.lights.begin() + ptrdiff_t(c.light), c.value);
        else if constexpr (std::is_same_v<T, change::RemoveLight>)
          scene.lights.erase(scene.lights.begin() + ptrdiff_t(c.light));
        else if constexpr (std::is_same_v<T, change::Transform>)
          scene.objects[c.object].transform = c.after;
        else if constexpr (std::is_same_v<T, change::Surface>)
          scene.objects[c.object].surface = c.after;
        else if constexpr (std::is_same_v<T, change::ObjectInterior>) {
          Object& o = scene.objects[c.object];
          o.interior = c.after.kind;
          o.sigma = c.after.sigma;
          o.volume = c.after.volume;
        } else if constexpr (std::is_same_v<T, change::CastsShadows>)
          scene.objects[c.object].casts_shadows = c.after;
        else
          scene.volumes[c.volume].transfer = c.after;
      },
      e.what);
}

// ---- what it costs a shadow system ------------------------------------------------

Invalidation invalidation_of(const Edit& e) {
  Invalidation inv;
  if (e.no_op()) return inv;
  using Maps = Invalidation::Maps;
  using Compile = Invalidation::Compile;
  std::visit(
      [&](const auto& c) {
        using T = std::decay_t<decltype(c)>;
        if constexpr (std::is_same_v<T, change::Settings>) {
          const ShadowSettings &a = c.before, &b = c.after;
          const uint32_t effects = changed_effects(a, b);
          inv.maps = effects & kAffectsMaps                        ? Maps::All
                     : effects & (kAffectsClusters | kAffectsPlan) ? Maps::Views
                                                                   : Maps::None;
        } else if constexpr (std::is_same_v<T, change::Camera>) {
          inv.maps = c.maps_follow ? Maps::Views : Maps::None;
        } else if constexpr (std::is_same_v<T, change::Light>) {
          const Light &a = c.before, &b = c.after;
          const bool spot = a.type == LightType::Spot || b.type == LightType::Spot;
          const bool view = a.type != b.type || !same(a.position, b.position) ||
                            (spot && (!same(a.direction, b.direction) || !same(a.outer_cone_deg, b.outer_cone_deg)));
          if (view) {
            inv.maps = Maps::Lights;
            inv.light_first = inv.light_last = int(c.light);
          }
        } else if constexpr (std::is_same_v<T, change::AddLight>) {
          inv.maps = Maps::Lights;
          inv.light_first = inv.light_last = int(c.light);
        } else if constexpr (std::is_same_v<T, change::Transform>) {
          inv.compile = Compile::Object;
          inv.object = int(c.object);
          if (c.caster) inv.maps = Maps::Object;
        } else if constexpr (std::is_same_v<T, change::Surface>) {
          inv.object = int(c.object);
          if (c.caster) inv.maps = Maps::Object;
        } else if constexpr (std::is_same_v<T, change::ObjectInterior>) {
          inv.compile = Compile::Structure;
          inv.object = int(c.object);
          if (c.caster) inv.maps = Maps::Object;
        } else if constexpr (std::is_same_v<T, change::CastsShadows>) {
          inv.object = int(c.object);
          inv.maps = Maps::Object;
        } else if constexpr (std::is_same_v<T, change::Transfer>) {
          inv.compile = Compile::Volume;
          inv.volume = int(c.volume);
          inv.object = c.object;
          if (c.caster && c.object >= 0) inv.maps = Maps::Object;
        }
        // Background, RemoveLight: nothing.
      },
      e.what);
  return inv;
}

std::string Invalidation::describe() const {
  std::string m;
  switch (maps) {
    case Maps::None: m = "no map"; break;
    case Maps::Lights:
      m = light_first == light_last
              ? "the maps of light " + std::to_string(light_first)
              : "the maps of lights " + std::to_string(light_first) + "-" + std::to_string(light_last);
      break;
    case Maps::Object: m = "the maps holding object " + std::to_string(object); break;
    case Maps::All: m = "every map"; break;
    case Maps::Views: m = "the maps whose clusters or frusta follow the view"; break;
  }
  switch (compile) {
    case Compile::None: break;
    case Compile::Object: m += "; object " + std::to_string(object) + "'s triangles (BVH refit)"; break;
    case Compile::Structure: m += "; the scene's geometry arrays"; break;
    case Compile::Volume: m += "; volume " + std::to_string(volume) + "'s grid"; break;
  }
  return m;
}

}  // namespace cdsm::editor
