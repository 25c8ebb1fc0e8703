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
  float bias_constant;  // casters' offset from their own plane: world units
  float bias_slope;     // + this many texel footprints at the point
  uint32_t receiver;    // kReceiverPlane / kReceiverSlopeBias (cdsm::ReceiverLookup)
};

inline constexpr uint32_t kReceiverPlane = 0u;
inline constexpr uint32_t kReceiverSlopeBias = 1u;
// The slope-bias baseline's constants (the defaults before receiver planes).
inline constexpr float kSlopeBiasConstant = 0.0005f;
inline constexpr float kSlopeBiasTexels = 1.5f;

// How far (in texel footprints) a tap's plane depth may lie from the
// point's depth: rays nearly parallel to the receiver's plane.
inline constexpr float kPlaneReachTexels = 50.0f;
// Casters' offset from their own plane relative to the depth: about twice
// the largest relative depth difference measured between the GL and the
// CPU fragment producers (8.9e-6, tests/gl) plus float rounding.
inline constexpr float kRelativeDepthOffset = 2e-5f;

// Spot falloff between the outer and inner cone (1 for point lights).
CDSM_HD CDSM_INLINE float cone_factor(const LightData& L, Vec3 p) {
  if (L.type != kLightSpot) return 1.0f;
  float c = dot(normalize(p - L.position), L.direction);
  if (c <= L.cos_outer) return 0.0f;
  if (c >= L.cos_inner) return 1.0f;
  float t = (c - L.cos_outer) / (L.cos_inner - L.cos_outer);
  return t * t * (3.0f - 2.0f * t);
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

// The point a shadow lookup is for. Receivers find their own surface by its
// plane, not by a depth offset scaled to the slope: each tap of the lookup
// (every bilinear tap, or the one texel without filtering) reads its texel
// at the depth where the tap's texel-centre light ray crosses the receiver's
// plane (a receiver-plane depth, exact for planar receivers: the tap sees
// what lies in front of the receiver along its own ray). A caster's surface
// is in the maps itself: its lookup stops `caster_offset` short of the
// plane, which covers float depth resolution and the facets of curved
// meshes, not the slope. Volume samples have no plane: every tap at the
// sample's own depth.
//
// Measured against the slope-scaled bias this replaced (constant 0.5 mm +
// 1.5 texel footprints x tan incidence, tan capped at 50), default scene at
// 720x480, 512^2, eps 0.01: see the issue note; a translucent box 1 mm above
// a casting slab, stacked sheets 1 mm apart and grazing light all need the
// per-tap plane (tests/unit/test_receivers.cpp). Cost: one normalize and a
// dot product per tap; node size unchanged (no identity tags needed).
inline constexpr uint32_t kNoObject = 0xffffffffu;

struct Receiver {
  Vec3 p;
  Vec3 plane;      // unit geometric normal of its surface (either side); 0: a volume sample
  bool own_step;   // its surface is in the maps (a caster's): stop short of its own step
  uint32_t object = kNoObject;  // the surface's object (the error probe's own-surface identity)
};

// The depth at which texel (tx, ty)'s centre ray crosses the plane through p
// with normal n (radial, as the map's depths), within `reach` of `depth`
// (rays nearly parallel to the plane).
CDSM_HD CDSM_INLINE float plane_depth_at_texel(const PinholeView& v, int tx, int ty, Vec3 p, Vec3 n, float depth,
                                               float reach) {
  const Vec3 d = normalize(view_direction(v, float(tx) + 0.5f, float(ty) + 0.5f));
  const float dn = dot(d, n);
  float t = dn != 0.0f ? dot(p - v.eye, n) / dn : depth + reach;
  if (!(t > depth - reach)) t = depth - reach;  // also NaN
  if (!(t < depth + reach)) t = depth + reach;
  return t;
}

// The depth at which tap (tx, ty) of map m reads its texel for receiver r
// (projected to pr), before any offset: the receiver's plane along the
// tap's ray, or the point's own depth (volume samples; the slope-bias
// baseline for every tap).
CDSM_HD CDSM_INLINE float tap_depth(const ShadowView& sv, const DsmMap& m, const ViewProjection& pr,
                                    const Receiver& r, int tx, int ty) {
  if (sv.receiver == kReceiverSlopeBias || !(dot(r.plane, r.plane) > 0.0f)) return pr.depth;
  return plane_depth_at_texel(m.view, tx, ty, r.p, r.plane, pr.depth,
                              kPlaneReachTexels * texel_footprint(m, pr.axial));
}

// How far short of tap_depth() receiver r's taps read in map m.
CDSM_HD CDSM_INLINE float receiver_offset(const ShadowView& sv, const LightData& L, const DsmMap& m,
                                          const ViewProjection& pr, const Receiver& r) {
  const float footprint = texel_footprint(m, pr.axial);
  if (sv.receiver == kReceiverSlopeBias) {  // every surface: constant + slope-scaled
    if (!(dot(r.plane, r.plane) > 0.0f)) return 0.0f;
    const float ndl = fabsf(dot(r.plane, normalize(L.position - r.p)));
    const float tan_inc = sqrtf(fmaxf(0.0f, 1.0f - ndl * ndl)) / fmaxf(ndl, 0.02f);
    return kSlopeBiasConstant + kSlopeBiasTexels * footprint * tan_inc;
  }
  return r.own_step ? sv.bias_constant + sv.bias_slope * footprint + kRelativeDepthOffset * pr.depth : 0.0f;
}

// One more layer of opacity, thesis eq. 3.12: alpha + a (1 - alpha), per channel.
CDSM_HD CDSM_INLINE float over(float alpha, float a) { return alpha + a * (1.0f - alpha); }
CDSM_HD CDSM_INLINE Vec3 over(Vec3 alpha, Vec3 a) { return alpha + a * one_minus(alpha); }

// The maps a lookup at p uses and how their alphas combine: every cluster
// map by thesis eq. 3.12, the one cube face by major axis, or the first
// parallel split holding the point. map_alpha(map_index, map, projection)
// gives one map's alpha (float, or Vec3 per channel); the combined alpha is
// returned in the same type.
template <class MapAlpha>
CDSM_HD CDSM_INLINE auto combine_maps(const ShadowView& sv, const LightData& L, Vec3 p, MapAlpha&& map_alpha) {
  using Alpha = decltype(map_alpha(0u, sv.maps[0], ViewProjection{}));
  Alpha alpha{};
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
    alpha = over(alpha, map_alpha(first + k, m, pr));  // thesis eq. 3.12
  }
  return alpha;
}

// Opacity between light L and receiver r from one map (its taps, each at
// its receiver-plane depth less the receiver's offset), per channel. A grey
// map's value is computed as scalar and given to every channel.
CDSM_HD inline Vec3 map_alpha_rgb(const ShadowView& sv, const LightData& L, const DsmMap& m, const ViewProjection& pr,
                                  const Receiver& r) {
  const float offset = receiver_offset(sv, L, m, pr, r);
  if (m.rgb == 0u) {
    float a = 0.0f;
    for_each_tap(m, pr.u, pr.v, sv.filtering, [&](int tx, int ty, float w) {
      a += w * texel_alpha(sv.storage, m, tx, ty, tap_depth(sv, m, pr, r, tx, ty) - offset);
    });
    return vec3(a);
  }
  Vec3 a{0, 0, 0};
  for_each_tap(m, pr.u, pr.v, sv.filtering, [&](int tx, int ty, float w) {
    a = a + texel_alpha_rgb(sv.storage, m, tx, ty, tap_depth(sv, m, pr, r, tx, ty) - offset) * w;
  });
  return a;
}

// Opacity per channel between light L and receiver r from the light's DSMs.
CDSM_HD inline Vec3 shadow_alpha_rgb(const ShadowView& sv, const LightData& L, const Receiver& r) {
  return combine_maps(sv, L, r.p, [&](uint32_t, const DsmMap& m, const ViewProjection& pr) {
    return map_alpha_rgb(sv, L, m, pr, r);
  });
}

// The grey opacity: exactly the one value where every channel agrees (grey
// casters), else the channel mean. Per-channel callers use shadow_alpha_rgb.
CDSM_HD inline float shadow_alpha(const ShadowView& sv, const LightData& L, const Receiver& r) {
  return grey_of(shadow_alpha_rgb(sv, L, r));
}

// A point lookup at p's own depth (volume samples, probes).
CDSM_HD CDSM_INLINE float shadow_alpha(const ShadowView& sv, const LightData& L, Vec3 p) {
  return shadow_alpha(sv, L, Receiver{p, Vec3{0, 0, 0}, false});
}
CDSM_HD CDSM_INLINE Vec3 shadow_alpha_rgb(const ShadowView& sv, const LightData& L, Vec3 p) {
  return shadow_alpha_rgb(sv, L, Receiver{p, Vec3{0, 0, 0}, false});
}

}  // namespace cdsm
