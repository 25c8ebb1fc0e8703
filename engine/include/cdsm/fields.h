// Field tables: each settings struct's fields written down once — the JSON
// key (also the command line's and the editor's name), the member, the
// range a value must lie in, and what a change makes stale. The scene
// reader and writer, the range checks, the comparison that decides whether
// an edit reached the shadow system, the map-key hash and the editor's
// "what changed" all walk the table (for_each_field); a field added to the
// struct and its table reaches every one of them (the library tests that).
// The default is the struct's own member initializer (S{}.*member).
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>

#include "cdsm/scene.h"

namespace cdsm {

// What a change of the field makes stale (bits).
enum FieldEffect : uint32_t {
  kAffectsNothing = 0,   // nothing built (a budget, a name)
  kAffectsLookup = 1,    // lookups and shading only: no map is rebuilt
  kAffectsPlan = 2,      // which maps a light has (their views; keys find what is reusable)
  kAffectsClusters = 4,  // the clustering of a light's casters (its hysteresis restarts)
  kAffectsMaps = 8,      // the content of every map (part of every map's key)
  // A spelling, not an effect: the integer 0 is read and written as "auto"
  // (the library chooses; its range is that of the other values).
  kZeroIsAuto = 1u << 16,
};
template <class F>
constexpr bool zero_is_auto(const F& f) {
  return (f.affects & kZeroIsAuto) != 0u;
}

// One field of struct S, of type T. Numbers and integers lie within
// [lo, hi]; a vector is finite and each of its components within [lo, hi];
// tags (cdsm/tags.h) are one of their names; booleans are true or false;
// strings are free text (lo, hi unused).
template <class S, class T>
struct Field {
  const char* key;
  T S::*member;
  double lo, hi;
  uint32_t affects;  // FieldEffect bits
  const char* help;
  const char* cpp = nullptr;  // the member's C++ name (CDSM_FIELD writes it from the member itself)
};

template <class S, class T>
constexpr Field<S, T> field(const char* key, T S::*member, double lo, double hi, uint32_t affects, const char* help,
                            const char* cpp = nullptr) {
  return {key, member, lo, hi, affects, help, cpp};
}

// A field of the table's struct S named by its member, whose C++ name the
// field reference (cdsm/scene_io.h scene_field_reference) prints beside the
// JSON key: the two cannot drift apart.
#define CDSM_FIELD(key, member, lo, hi, affects, help) ::cdsm::field(key, &S::member, lo, hi, affects, help, #member)

// Specialized per struct: `static constexpr auto fields = std::make_tuple(field(...), ...)`.
template <class S>
struct FieldTable;

// f(field) for every field of S's table, in table order.
template <class S, class F>
void for_each_field(F&& f) {
  std::apply([&](const auto&... x) { (f(x), ...); }, FieldTable<S>::fields);
}

// ---- what every consumer needs the same way -----------------------------------

// Equal as stored: floats by their bits (a NaN equals itself, -0 differs
// from +0), so an edit that changes any bit reaches the system.
template <class T>
bool same_field_value(const T& a, const T& b) {
  static_assert(std::is_trivially_copyable_v<T>, "fields are plain values or strings");
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}
inline bool same_field_value(const std::string& a, const std::string& b) { return a == b; }

template <class S>
bool same_fields(const S& a, const S& b) {
  bool same = true;
  for_each_field<S>([&](const auto& f) { same = same && same_field_value(a.*f.member, b.*f.member); });
  return same;
}

// The FieldEffect bits of the fields that differ between a and b.
template <class S>
uint32_t changed_effects(const S& a, const S& b) {
  uint32_t bits = 0;
  for_each_field<S>([&](const auto& f) {
    if (!same_field_value(a.*f.member, b.*f.member)) bits |= f.affects;
  });
  return bits;
}

// The keys of the fields that differ, joined by '+' ("epsilon+layout").
template <class S>
std::string changed_fields(const S& a, const S& b) {
  std::string keys;
  for_each_field<S>([&](const auto& f) {
    if (!same_field_value(a.*f.member, b.*f.member)) keys += (keys.empty() ? "" : "+") + std::string(f.key);
  });
  return keys;
}

// FNV-1a, 64 bit, over bytes: the hash of the library's keys (maps, clusters,
// caches); deterministic on every platform. One copy for all of them.
struct Fnv1a {
  uint64_t h = 1469598103934665603ull;
  void bytes(const void* p, size_t n) {
    const unsigned char* c = static_cast<const unsigned char*>(p);
    for (size_t i = 0; i < n; ++i) h = (h ^ c[i]) * 1099511628211ull;
  }
  template <class T>
  void pod(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>, "pod() hashes the bytes of plain values");
    bytes(&v, sizeof(T));
  }
};

// h.pod(value) for every field with one of the `affects` bits (names and
// other strings affect nothing built and are never hashed).
template <class S, class Hash>
void hash_fields(Hash& h, const S& s, uint32_t affects) {
  for_each_field<S>([&](const auto& f) {
    using T = std::remove_cv_t<std::remove_reference_t<decltype(s.*f.member)>>;
    if constexpr (!std::is_same_v<T, std::string>)
      if (f.affects & affects) h.pod(s.*f.member);
  });
}

// ---- the tables ----------------------------------------------------------------

template <>
struct FieldTable<ShadowSettings> {
  using S = ShadowSettings;
  static constexpr double kBig = 1e30;
  static constexpr auto fields = std::make_tuple(
      CDSM_FIELD("epsilon", epsilon, 0.0, 1.0, kAffectsMaps, "compression error bound of the visibility functions"),
      CDSM_FIELD("resolution", resolution, 4, 8192, kAffectsMaps | kAffectsClusters | kZeroIsAuto,
                 "DSM texels per side, or auto: each map's from the screen (texels_per_pixel, max_resolution)"),
      CDSM_FIELD("texels_per_pixel", texels_per_pixel, 0.0625, 16.0, kAffectsPlan,
                 "auto resolution: map texels across one image pixel where the map's receivers are seen"),
      CDSM_FIELD("max_resolution", max_resolution, 16, 8192, kAffectsPlan,
                 "auto resolution: the ladder's top (texels per side)"),
      CDSM_FIELD("filtering", filtering, 0, 1, kAffectsLookup, "bilinear lookup"),
      CDSM_FIELD("receiver", receiver, 0, 0, kAffectsLookup, "how surfaces look themselves up"),
      CDSM_FIELD("penumbra", penumbra, 0, 0, kAffectsLookup,
                 "lights with a size: estimated (blockers from the maps), fixed_kernel (PCF baseline) or hard"),
      CDSM_FIELD("penumbra_taps", penumbra_taps, 5, 32, kAffectsLookup,
                 "lights with a size: filter taps across a penumbra (the cost goes with its square)"),
      CDSM_FIELD("bias_constant", bias_constant, 0.0, 10.0, kAffectsLookup,
                 "a caster's own surface: taps stop this far short of its plane (world units)"),
      CDSM_FIELD("bias_slope", bias_slope, 0.0, 100.0, kAffectsLookup, "... plus this many texel footprints"),
      CDSM_FIELD("clusters", max_clusters, 1, kMaxMapsPerLight, kAffectsClusters | kZeroIsAuto,
                 "m: at most this many maps per light, or auto: per light, the fewest that reach the density"),
      CDSM_FIELD("max_clusters", cluster_limit, 1, kMaxMapsPerLight, kAffectsClusters,
                 "auto clusters: the most maps per light it may choose"),
      CDSM_FIELD("parallel_splits", parallel_splits, 0, kMaxMapsPerLight - 1, kAffectsPlan,
                 "baseline: parallel-split maps per spot light (0: off, else >= 2)"),
      CDSM_FIELD("d0", d0, 0.0, 4.0, kAffectsClusters, "clustering threshold, normalized map units"),
      CDSM_FIELD("layout", layout, 0, 0, kAffectsMaps, "DSM memory layout"),
      CDSM_FIELD("fixed_layers", fixed_layers, 2, 4096, kAffectsMaps, "fixed layout: node slots per texel"),
      CDSM_FIELD("chunk_nodes", chunk_nodes, 1, 4096, kAffectsMaps, "chunked layout: node slots per chunk"),
      CDSM_FIELD("method", method, 0, 0, kAffectsMaps, "what a texel stores: dsm, or a baseline"),
      CDSM_FIELD("method_param", method_param, -kBig, kBig, kAffectsMaps,
                 "the baseline's parameter (0: its default; ranges per method)"),
      CDSM_FIELD("layer_thickness", layer_thickness, 0.0, 1e6, kAffectsMaps,
                 "deep opacity maps: layer thickness along the ray (0: the casters' depth extent / N)"),
      CDSM_FIELD("ambient", ambient_light, 0.0, 100.0, kAffectsLookup, "ambient light, linear RGB"),
      CDSM_FIELD("rgb_maps", rgb_maps, 0, 1, kAffectsMaps, "RGB nodes where a caster is coloured"),
      CDSM_FIELD("max_memory", max_memory_mib, 0, double(int64_t(1) << 30), kAffectsNothing,
                 "MiB a frame may use (0: half the physical memory)"));
};

// Rules a range cannot say stay beside the tables, in the scene validator
// and reader: a spot's and a directional light's nonzero
// direction, 0 < outer_cone and inner_cone <= outer_cone; 0 < near < far,
// 0 < fov_y < 179, target != position; the reader's `target` for a light.
template <>
struct FieldTable<Light> {
  using S = Light;
  static constexpr double kBig = 1e30;
  static constexpr uint32_t kShape = kAffectsPlan | kAffectsClusters | kAffectsMaps;  // where its maps are
  static constexpr auto fields = std::make_tuple(
      CDSM_FIELD("name", name, 0, 0, kAffectsNothing, "shown in the editor and in messages"),
      CDSM_FIELD("type", type, 0, 0, kShape, "spot, point or directional"),
      CDSM_FIELD("position", position, -kBig, kBig, kShape, "world position (directional: unused)"),
      CDSM_FIELD("direction", direction, -kBig, kBig, kShape,
                 "spot: the cone's axis; directional: the way the light travels (a file may give a target instead)"),
      CDSM_FIELD("outer_cone", outer_cone_deg, 0.0, 89.5, kShape, "spot: half-angle where the light ends, degrees"),
      CDSM_FIELD("inner_cone", inner_cone_deg, 0.0, 89.5, kAffectsLookup,
                 "spot: half-angle of full intensity, degrees (at most outer_cone)"),
      CDSM_FIELD("color", color, 0.0, 100.0, kAffectsLookup, "linear RGB"),
      CDSM_FIELD("intensity", intensity, 0.0, 1e9, kAffectsLookup, "scales the colour"),
      CDSM_FIELD("radius", radius, 0.0, 1e6, kAffectsLookup,
                 "spot, point: the sphere light's radius, world units (0: a point; the reference samples its area)"),
      CDSM_FIELD("angular_diameter", angular_diameter_deg, 0.0, 10.0, kAffectsLookup,
                 "directional: apparent size, degrees (the sun: 0.53; 0: a point; the reference samples its cone)"));
};

template <>
struct FieldTable<SurfaceMaterial> {
  using S = SurfaceMaterial;
  static constexpr auto fields = std::make_tuple(
      CDSM_FIELD("color", color, 0.0, 100.0, kAffectsLookup, "Phong colour, linear RGB"),
      CDSM_FIELD("opacity", opacity, 0.0, 1.0, kAffectsMaps, "coverage a at each crossing: 1 opaque, 0 a pure filter"),
      CDSM_FIELD("transmission_color", transmission_color, 0.0, 1.0, kAffectsMaps,
                 "filter of the uncovered part, linear RGB (one number: grey)"),
      CDSM_FIELD("ambient", ambient, 0.0, 100.0, kAffectsLookup, "k_a"),
      CDSM_FIELD("diffuse", diffuse, 0.0, 100.0, kAffectsLookup, "k_d"),
      CDSM_FIELD("specular", specular, 0.0, 100.0, kAffectsLookup, "k_s"),
      CDSM_FIELD("shininess", shininess, 0.0, 1e4, kAffectsLookup, "n_s"));
};

// The plain fields of a volume and an object; what a range cannot say (a
// volume's grid, placement and transfer function; an object's mesh,
// transform, material and interior) is read, written and checked beside
// them by the scene reader, writer and validator.
template <>
struct FieldTable<Volume> {
  using S = Volume;
  static constexpr auto fields = std::make_tuple(
      CDSM_FIELD("name", name, 0, 0, kAffectsNothing, "how objects name it, shown in the editor"),
      CDSM_FIELD("shading", shading, 0, 0, kAffectsLookup,
                 "scatter (lit by the maps) or phong (a surface at its gradient)"),
      CDSM_FIELD("step_voxels", step_voxels, 0.05, 8.0, kAffectsMaps, "march step, in voxels"),
      CDSM_FIELD("gradient_scale", gradient_scale, 0.0, 1e6, kAffectsLookup, "phong: the gradient's scale"));
};

template <>
struct FieldTable<Object> {
  using S = Object;
  static constexpr auto fields =
      std::make_tuple(CDSM_FIELD("name", name, 0, 0, kAffectsNothing, "shown in the editor and in messages"),
                      CDSM_FIELD("casts_shadows", casts_shadows, 0, 1, kAffectsPlan | kAffectsClusters | kAffectsMaps,
                                 "false: a receiver only (in no map; a large ground should be one)"));
};

template <>
struct FieldTable<Camera> {
  using S = Camera;
  static constexpr double kBig = 1e30;
  static constexpr uint32_t kView = kAffectsLookup | kAffectsClusters;  // what is seen; maps focus on it
  static constexpr auto fields = std::make_tuple(
      CDSM_FIELD("position", position, -kBig, kBig, kView, "the eye"),
      CDSM_FIELD("target", target, -kBig, kBig, kView, "a point the eye looks at"),
      CDSM_FIELD("up", up, -kBig, kBig, kView, "the image's up (any vector off the view direction)"),
      CDSM_FIELD("fov_y", fov_y_deg, 0.0, 179.0, kView, "vertical field of view, degrees (0 and 179 excluded)"),
      CDSM_FIELD("near", near, 0.0, kBig, kView, "the nearest distance seen (> 0)"),
      CDSM_FIELD("far", far, 0.0, kBig, kView, "the farthest distance seen (> near)"),
      CDSM_FIELD("width", width, 1, 16384, kView, "image pixels across"),
      CDSM_FIELD("height", height, 1, 16384, kView, "image pixels down"));
};

}  // namespace cdsm
