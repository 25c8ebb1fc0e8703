// Lights as the kernels see them, and the shadow term at a point: spot cone,
// DSM lookups combined over a light's maps (thesis eq. 3.12).
#pragma once

#include "hd/dsm.h"

namespace cdsm {

inline constexpr uint32_t kLightSpot = 0u;
inline constexpr uint32_t kLightPoint = 1u;
inline constexpr uint32_t kMapsCombine = 0u;    // clusters: alpha += alpha_c (1 - alpha)
inline constexpr uint32_t kMapsCubeFaces = 1u;  // six faces +X,-X,+Y,-Y,+Z,-Z: pick by major axis
inline constexpr uint32_t kMapsFirstContaining = 2u;  // parallel splits, near to far: the first map holding the point

struct LightData {
  Vec3 position;
  uint32_t type;       // kLightSpot / kLightPoint
  Vec3 direction;      // spot axis (unit)
  float cos_outer;     // spot: cosine of the outer half-angle
  Vec3 radiance;       // colour * intensity
  float cos_inner;     // spot: cosine of the inner half-angle
  uint32_t first_map;  // maps[first_map .. first_map + map_count)
  uint32_t map_count;
  uint32_t map_mode;   // kMapsCombine / kMapsCubeFaces
  uint32_t pad;
};
static_assert(sizeof(LightData) == 64, "LightData is 64 bytes");

// Everything the camera pass needs to look up shadows.
struct ShadowView {
  Span<const LightData> lights;
  Span<const DsmMap> maps;
  DsmStorage storage;
  bool filtering;
  float bias_constant;  // world units
  float bias_slope;     // times the texel footprint at the point
};

// Spot falloff between the outer and inner cone (1 for point lights).
CDSM_HD CDSM_INLINE float cone_factor(const LightData& L, Vec3 p) {
  if (L.type != kLightSpot) return 1.0f;
  float c = dot(normalize(p - L.position), L.direction);
  if (c <= L.cos_outer) return 0.0f;
  if (c >= L.cos_inner) return 1.0f;
  float t = (c - L.cos_outer) / (L.cos_inner - L.cos_outer);
  return t * t * (3.0f - 2.0f * t);
}

// Tangent of the light's incidence angle for the slope-scaled bias, from
// n . l (> 0). Capped at 50 (about 1.1 degrees of elevation): a lit surface
// at grazing incidence must not shadow itself through its neighbouring
// texels, while the cap bounds how far the lookup can reach past a thin caster.
CDSM_HD CDSM_INLINE float bias_tangent(float ndl) {
  return sqrtf(fmaxf(0.0f, 1.0f - ndl * ndl)) / fmaxf(ndl, 0.02f);
}

// World size of one texel of map m at the point (for slope-scaled bias).
CDSM_HD CDSM_INLINE float texel_footprint(const DsmMap& m, float axial) {
  return 2.0f * m.view.tan_half_x * axial / float(m.res);
}

CDSM_HD CDSM_INLINE int cube_face_of(Vec3 d) {
  float ax = fabsf(d.x), ay = fabsf(d.y), az = fabsf(d.z);
  if (ax >= ay && ax >= az) return d.x >= 0.0f ? 0 : 1;
  if (ay >= az) return d.y >= 0.0f ? 2 : 3;
  return d.z >= 0.0f ? 4 : 5;
}

// Opacity between light L and point p from the light's DSMs. `tan_incidence`
// scales the slope bias (0 for volume samples, which look up at their depth).
CDSM_HD inline float shadow_alpha(const ShadowView& sv, const LightData& L, Vec3 p,
                                  float bias_world, float tan_incidence) {
  float alpha = 0.0f;
  uint32_t first = L.first_map, count = L.map_count;
  if (L.map_mode == kMapsCubeFaces && count == 6) {
    first += uint32_t(cube_face_of(p - L.position));
    count = 1;
  }
  for (uint32_t k = 0; k < count; ++k) {
    const DsmMap& m = sv.maps[first + k];
    ViewProjection pr = project(m.view, p);
    if (pr.axial <= 0.0f) continue;
    if (L.map_mode == kMapsFirstContaining) {
      // Each split map holds every caster: use the finest map whose window
      // (inside its one-texel guard band) holds the point, and only that one.
      float lo = 1.0f, hi = float(m.res) - 1.0f;
      if (k + 1 < count && (pr.u < lo || pr.v < lo || pr.u > hi || pr.v > hi)) continue;
      count = k + 1;
    }
    float bias = bias_world;
    if (tan_incidence > 0.0f) bias += sv.bias_slope * texel_footprint(m, pr.axial) * tan_incidence;
    float a = lookup_map(sv.storage, m, pr.u, pr.v, pr.depth - bias, sv.filtering);
    alpha = alpha + a * (1.0f - alpha);  // thesis eq. 3.12
  }
  return alpha;
}

}  // namespace cdsm
