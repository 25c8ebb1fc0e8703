// Field tables: each settings struct's fields written down once — the JSON
// key (also the command line's and the editor's name), the member, the
// range a value must lie in, and what a change makes stale. The scene
// reader and writer, the range checks, the comparison that decides whether
// an edit reached the shadow system, the map-key hash and the editor's
// "what changed" all walk the table (for_each_field); a field added to the
// struct and its table reaches every one of them (tests/unit/test_fields.cpp).
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
};

// One field of struct S, of type T. Numbers and integers lie within
// [lo, hi]; a colour's channels within [lo, hi]; tags (cdsm/tags.h) are one
// of their names; booleans are true or false.
template <class S, class T>
struct Field {
  const char* key;
  T S::*member;
  double lo, hi;
  uint32_t affects;  // FieldEffect bits
  const char* help;
};

template <class S, class T>
constexpr Field<S, T> field(const char* key, T S::*member, double lo, double hi, uint32_t affects, const char* help) {
  return {key, member, lo, hi, affects, help};
}

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
  static_assert(std::is_trivially_copyable_v<T>, "fields are plain values");
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

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

// h.pod(value) for every field with one of the `affects` bits.
template <class S, class Hash>
void hash_fields(Hash& h, const S& s, uint32_t affects) {
  for_each_field<S>([&](const auto& f) {
    if (f.affects & affects) h.pod(s.*f.member);
  });
}

// ---- the tables ----------------------------------------------------------------

template <>
struct FieldTable<ShadowSettings> {
  using S = ShadowSettings;
  static constexpr double kBig = 1e30;
  static constexpr auto fields = std::make_tuple(
      field("epsilon", &S::epsilon, 0.0, 1.0, kAffectsMaps, "compression error bound of the visibility functions"),
      field("resolution", &S::resolution, 4, 8192, kAffectsMaps | kAffectsClusters, "DSM texels per side"),
      field("filtering", &S::filtering, 0, 1, kAffectsLookup, "bilinear lookup"),
      field("receiver", &S::receiver, 0, 0, kAffectsLookup, "how surfaces look themselves up"),
      field("bias_constant", &S::bias_constant, 0.0, 10.0, kAffectsLookup,
            "a caster's own surface: taps stop this far short of its plane (world units)"),
      field("bias_slope", &S::bias_slope, 0.0, 100.0, kAffectsLookup, "... plus this many texel footprints"),
      field("clusters", &S::max_clusters, 1, kMaxMapsPerLight, kAffectsClusters, "m: at most this many maps per light"),
      field("parallel_splits", &S::parallel_splits, 0, kMaxMapsPerLight - 1, kAffectsPlan,
            "baseline: parallel-split maps per spot light (0: off, else >= 2)"),
      field("d0", &S::d0, 0.0, 4.0, kAffectsClusters, "clustering threshold, normalized map units"),
      field("layout", &S::layout, 0, 0, kAffectsMaps, "DSM memory layout"),
      field("fixed_layers", &S::fixed_layers, 2, 4096, kAffectsMaps, "fixed layout: node slots per texel"),
      field("chunk_nodes", &S::chunk_nodes, 1, 4096, kAffectsMaps, "chunked layout: node slots per chunk"),
      field("method", &S::method, 0, 0, kAffectsMaps, "what a texel stores: dsm, or a baseline"),
      field("method_param", &S::method_param, -kBig, kBig, kAffectsMaps,
            "the baseline's parameter (0: its default; ranges per method)"),
      field("ambient", &S::ambient_light, 0.0, 100.0, kAffectsLookup, "ambient light, linear RGB"),
      field("rgb_maps", &S::rgb_maps, 0, 1, kAffectsMaps, "RGB nodes where a caster is coloured"),
      field("max_memory", &S::max_memory_mib, 0, double(int64_t(1) << 30), kAffectsNothing,
            "MiB a frame may use (0: half the physical memory)"));
};

}  // namespace cdsm
