// The tags a scene, the kernels (CPU threads and CUDA) and the GL storage
// share: each one enum, 32 bits wide so it sits in the std430 and device
// structs as it is. cdsm.glsl (share/cdsm/shaders/) names the same values
// (CDSM_LIGHT_*, CDSM_PROJECTION_*, CDSM_LAYOUT_*, CDSM_RECEIVER_*,
// CDSM_PENUMBRA_*, CDSM_MAPS_*); the
// library's tests check they agree.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace cdsm {

// What fills a closed mesh (Material/Object interior).
enum class InteriorKind : uint32_t { None = 0, Constant = 1, Volume = 2 };

// Directional lights (the sun) shine along one direction from infinitely
// far away: no position, orthographic maps (Projection::Orthographic).
enum class LightType : uint32_t { Spot = 0, Point = 1, Directional = 2 };

// How a view maps the world to its image (hd/view.h PinholeView): through
// its eye (cameras, spot and point lights), or along parallel rays
// (directional lights).
enum class Projection : uint32_t { Perspective = 0, Orthographic = 1 };

// How a light's maps combine at a point (hd/lights.h).
enum class MapMode : uint32_t {
  Combine = 0,          // clusters: alpha += alpha_c (1 - alpha)
  CubeFaces = 1,        // six faces +X,-X,+Y,-Y,+Z,-Z: pick by major axis
  FirstContaining = 2,  // parallel splits, near to far: the first map holding the point
};

// How a map's texels hold their nodes (hd/dsm.h).
enum class DsmLayout : uint32_t { Packed = 0, Fixed = 1, Chunked = 2 };

// How a surface looks itself up (hd/lights.h Receiver).
enum class ReceiverLookup : uint32_t {
  Plane = 0,      // each tap at the receiver's plane along its own ray; casters offset slightly
  SlopeBias = 1,  // the previous design, kept as the baseline: every tap at the point's depth minus
                  // 0.5 mm + 1.5 texel footprints x tan(incidence) (tan <= 50), for every surface
};

// How a light with a size (a sphere's radius, the sun's angular diameter)
// softens its shadows (hd/lights.h "lights with a size"). Lights without a
// size take the hard lookup whatever this says.
enum class Penumbra : uint32_t {
  Estimated = 0,    // blockers found in the map, penumbra width by similar triangles (contact hardening)
  FixedKernel = 1,  // baseline: the same taps over a fixed kernel (a blocker halfway to the light)
  Hard = 2,         // the light's size ignored: today's point-light lookup
};

// What each texel stores. Deep shadow maps are the product; the others are
// the baselines the benchmark compares against, built from the same light
// rays and read by the same lookup (hd/baselines.h).
enum class ShadowMethod : uint32_t {
  Dsm = 0,             // epsilon-bounded visibility functions (Lokovic-Veach wedge)
  ShadowMap = 1,       // conventional: opaque at the first surface with opacity >= method_param
  OpacitySlices = 2,   // opacity shadow maps: method_param uniform slices along the ray
  FixedNodes = 3,      // AVSM-style: at most method_param nodes, greedy area-preserving removal
  DeepOpacity = 4,     // deep opacity maps: method_param layers from each texel's first caster depth
  FourierOpacity = 5,  // Fourier opacity maps: method_param real coefficients of the absorption along depth
  Moments = 6,         // moment-based transmittance: method_param (4 or 8) power moments of the absorbance
};

// How a volume's samples are shaded (hd/camera_pass.h, the reference):
// single scattering (smoke, clouds) or Phong with the density gradient as
// the normal (CT data).
enum class VolumeShading : uint32_t { Scatter = 0, Phong = 1 };

// How a volume's grid is stored (hd/scene_data.h VolumeData): a dense array,
// or a NanoVDB grid whose leaves are the macro-cells.
enum class GridKind : uint32_t { Dense = 0, Nano = 1 };

// How a sparse grid's cells without a leaf are skipped: Leaves (the cell is
// background within its apron: load_vdb's grids), Neighbours (the cell and
// its 26 neighbours decide: tiles, grids made in code).
enum class NanoSkip : uint32_t { Leaves = 0, Neighbours = 1 };

// ---- names ------------------------------------------------------------------
// The one spelling of each value, in value order: scene files (reader and
// writer), the command line, the editor and messages all use these.
template <class E>
struct TagNames;
template <>
struct TagNames<InteriorKind> {
  static constexpr const char* names[] = {"none", "constant", "volume"};
};
template <>
struct TagNames<LightType> {
  static constexpr const char* names[] = {"spot", "point", "directional"};
};
template <>
struct TagNames<Projection> {
  static constexpr const char* names[] = {"perspective", "orthographic"};
};
template <>
struct TagNames<MapMode> {
  static constexpr const char* names[] = {"combine", "cube_faces", "first_containing"};
};
template <>
struct TagNames<DsmLayout> {
  static constexpr const char* names[] = {"packed", "fixed", "chunked"};
};
template <>
struct TagNames<ReceiverLookup> {
  static constexpr const char* names[] = {"plane", "slope_bias"};
};
template <>
struct TagNames<Penumbra> {
  static constexpr const char* names[] = {"estimated", "fixed_kernel", "hard"};
};
template <>
struct TagNames<VolumeShading> {
  static constexpr const char* names[] = {"scatter", "phong"};
};
template <>
struct TagNames<ShadowMethod> {
  static constexpr const char* names[] = {"dsm",          "shadow_map",      "opacity_slices", "fixed_nodes",
                                          "deep_opacity", "fourier_opacity", "moments"};
};

template <class E>
constexpr uint32_t tag_count() {
  return uint32_t(sizeof(TagNames<E>::names) / sizeof(TagNames<E>::names[0]));
}

// "packed" for DsmLayout::Packed; "?" for a value outside the enum.
template <class E>
const char* tag_name(E e) {
  return uint32_t(e) < tag_count<E>() ? TagNames<E>::names[uint32_t(e)] : "?";
}

// The value named `s`; false (and `out` unchanged) when no value has that name.
template <class E>
bool parse_tag(std::string_view s, E& out) {
  for (uint32_t i = 0; i < tag_count<E>(); ++i)
    if (s == TagNames<E>::names[i]) {
      out = E(i);
      return true;
    }
  return false;
}

// The names for a message: "packed, fixed or chunked".
template <class E>
std::string tag_choices() {
  std::string s;
  for (uint32_t i = 0; i < tag_count<E>(); ++i) {
    if (i > 0) s += i + 1 == tag_count<E>() ? " or " : ", ";
    s += TagNames<E>::names[i];
  }
  return s;
}

}  // namespace cdsm
