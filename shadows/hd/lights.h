// Lights as the kernels see them, and the shadow term at a point: spot cone,
// DSM lookups combined over a light's maps (thesis eq. 3.12).
#pragma once

#include "hd/dsm.h"

namespace cdsm {

struct LightData {
  Vec3 position;  // spot, point; directional: unused (0)
  LightType type;
  Vec3 direction;      // spot axis, directional: the way the light travels (unit)
  float cos_outer;     // spot: cosine of the outer half-angle
  Vec3 radiance;       // colour * intensity
  float cos_inner;     // spot: cosine of the inner half-angle
  uint32_t first_map;  // maps[first_map .. first_map + map_count)
  uint32_t map_count;
  MapMode map_mode;
  float size;  // spot, point: the sphere's radius; directional: tan of half the angular diameter (0: a point)
};
static_assert(sizeof(LightData) == 64, "LightData is 64 bytes");

// Everything the camera pass needs to look up shadows.
struct ShadowView {
  Span<const LightData> lights;
  Span<const DsmMap> maps;
  DsmStorage storage;
  bool filtering;
  float bias_constant;  // a surface's own step is searched this far around its plane: world units
  float bias_slope;     // + this many texel footprints at the point (+ kRelativeDepthOffset of the depth)
  ReceiverLookup receiver;
};

// The slope-bias baseline's constants (the defaults before receiver planes).
inline constexpr float kSlopeBiasConstant = 0.0005f;
inline constexpr float kSlopeBiasTexels = 1.5f;

// How far (in texel footprints) a tap's plane depth may lie from the
// point's depth: rays nearly parallel to the receiver's plane.
inline constexpr float kPlaneReachTexels = 50.0f;

// Spot falloff between the outer and inner cone (1 for point lights).
CDSM_HD CDSM_INLINE float cone_factor(const LightData& L, Vec3 p) {
  if (L.type != LightType::Spot) return 1.0f;
  float c = dot(normalize(p - L.position), L.direction);
  if (c <= L.cos_outer) return 0.0f;
  if (c >= L.cos_inner) return 1.0f;
  float t = (c - L.cos_outer) / (L.cos_inner - L.cos_outer);
  return t * t * (3.0f - 2.0f * t);
}

// The unit direction from p toward light L, and how far the light is
// (directional lights: infinitely far, along -direction).
struct ToLight {
  Vec3 l;
  float distance;
};
CDSM_HD CDSM_INLINE ToLight to_light(const LightData& L, Vec3 p) {
  if (L.type == LightType::Directional) return ToLight{L.direction * -1.0f, 3.0e38f};
  const Vec3 d = L.position - p;
  const float dist = length(d);
  return ToLight{dist > 0.0f ? d * (1.0f / dist) : Vec3{0, 0, 0}, dist};
}

// World size of one texel of map m at the point (for slope-scaled bias):
// grows with the axial distance through a pinhole, constant when orthographic.
CDSM_HD CDSM_INLINE float texel_footprint(const DsmMap& m, float axial) {
  return 2.0f * m.view.tan_half_x * (is_orthographic(m.view) ? 1.0f : axial) / float(m.res);
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
// what lies in front of the receiver along its own ray). A surface in the
// maps leaves out its own step by identity (hd/dsm.h TexelRead): the step
// its object's tag marks nearest to that depth, searched within
// `bias_constant` + `bias_slope` texel footprints + kRelativeDepthOffset of
// the depth (the facets of curved meshes, the producers' depth
// differences), and nothing else: every other surface in front of it
// counts, down to float resolution; of surfaces touching it (within
// kRelativeDepthOffset of the depth) those the light leaves or crosses open
// before entering it count (a glass resting on it, a decal), two coplanar
// tops side by side do not (hd/compress.h SurfaceRank). Volume samples have
// no plane: every tap at the sample's own depth.
//
// Cost: one normalize and a dot product per tap, and for a surface in the
// maps a scan of the nodes within the search window (usually the two of its
// own step); 2 bytes of tag per node (hd/compress.h SurfaceTag).
inline constexpr uint32_t kNoObject = 0xffffffffu;

template <class T>
struct enable_if_bool {};
template <>
struct enable_if_bool<bool> {
  using type = void;
};

struct Receiver {
  Vec3 p{0, 0, 0};
  Vec3 plane{0, 0, 0};          // unit geometric normal of its surface (either side); 0: a volume sample
  uint32_t object = kNoObject;  // the surface's object: its own step is left out (kNoObject: none in the maps)

  Receiver() = default;
  CDSM_HD Receiver(Vec3 at, Vec3 plane_normal, uint32_t surface_object)
      : p(at), plane(plane_normal), object(surface_object) {}
  // The receiver once said whether its step was in the maps; it now says
  // which object's step is its own (a bool there is a mistake).
  template <class B, class = typename enable_if_bool<B>::type>
  Receiver(Vec3, Vec3, B) = delete;
};

// The depth at which texel (tx, ty)'s centre ray crosses the plane through p
// with normal n (radial, as the map's depths), within `reach` of `depth`
// (rays nearly parallel to the plane).
CDSM_HD CDSM_INLINE float plane_depth_at_texel(const PinholeView& v, int tx, int ty, Vec3 p, Vec3 n, float depth,
                                               float reach) {
  const Vec3 d = normalize(view_direction(v, float(tx) + 0.5f, float(ty) + 0.5f));
  const float dn = dot(d, n);
  float t = dn != 0.0f ? dot(p - pixel_origin(v, tx, ty), n) / dn : depth + reach;
  if (!(t > depth - reach)) t = depth - reach;  // also NaN
  if (!(t < depth + reach)) t = depth + reach;
  return t;
}

// The depth at which tap (tx, ty) of map m reads its texel for receiver r
// (projected to pr), before any offset: the receiver's plane along the
// tap's ray, or the point's own depth (volume samples; the slope-bias
// baseline for every tap).
CDSM_HD CDSM_INLINE float tap_depth(const ShadowView& sv, const DsmMap& m, const ViewProjection& pr, const Receiver& r,
                                    int tx, int ty) {
  if (sv.receiver == ReceiverLookup::SlopeBias || !(dot(r.plane, r.plane) > 0.0f)) return pr.depth;
  return plane_depth_at_texel(m.view, tx, ty, r.p, r.plane, pr.depth, kPlaneReachTexels * texel_footprint(m, pr.axial));
}

// The slope-bias baseline's offset: how far short of the point's depth
// every tap of a surface reads (constant + slope-scaled).
CDSM_HD CDSM_INLINE float slope_bias_offset(const LightData& L, const DsmMap& m, const ViewProjection& pr,
                                            const Receiver& r) {
  if (!(dot(r.plane, r.plane) > 0.0f)) return 0.0f;
  const float ndl = fabsf(dot(r.plane, to_light(L, r.p).l));
  const float tan_inc = sqrtf(fmaxf(0.0f, 1.0f - ndl * ndl)) / fmaxf(ndl, 0.02f);
  return kSlopeBiasConstant + kSlopeBiasTexels * texel_footprint(m, pr.axial) * tan_inc;
}

// How receiver r reads a tap of map m whose ray crosses its plane at
// `depth` (DESIGN.md §8, hd/dsm.h TexelRead).
CDSM_HD CDSM_INLINE TexelRead receiver_read_at(const ShadowView& sv, const DsmMap& m, const ViewProjection& pr,
                                               const Receiver& r, float depth) {
  TexelRead tr;
  tr.depth = depth;
  tr.coplanar = kRelativeDepthOffset * depth;
  tr.window = sv.bias_constant + sv.bias_slope * texel_footprint(m, pr.axial) + tr.coplanar;
  tr.own = r.object == kNoObject ? 0u : tag_object(r.object);
  return tr;
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
  if (L.map_mode == MapMode::CubeFaces && count == 6) {
    first += uint32_t(cube_face_of(p - L.position));
    count = 1;
  }
  for (uint32_t k = 0; k < count; ++k) {
    const DsmMap& m = sv.maps[first + k];
    ViewProjection pr = project(m.view, p);
    if (pr.axial <= 0.0f) continue;
    if (L.map_mode == MapMode::FirstContaining) {
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

// Opacity between light L and receiver r from one map of node kind N: its
// taps, volume samples each at the point's depth, surfaces each at its
// plane depth with their own step left out (receiver_read_at); the
// slope-bias baseline at the point's depth less its offset.
template <int N>
CDSM_HD inline Channels<N> map_alpha(const ShadowView& sv, const LightData& L, const DsmMap& m,
                                     const ViewProjection& pr, const Receiver& r) {
  const bool surface = dot(r.plane, r.plane) > 0.0f;
  Channels<N> a{};
  if (sv.receiver == ReceiverLookup::SlopeBias || !surface) {
    const float z = pr.depth - (sv.receiver == ReceiverLookup::SlopeBias ? slope_bias_offset(L, m, pr, r) : 0.0f);
    for_each_tap(m, pr.u, pr.v, sv.filtering,
                 [&](int tx, int ty, float w) { a = a + texel_alpha<N>(sv.storage, m, tx, ty, z) * w; });
    return a;
  }
  for_each_tap(m, pr.u, pr.v, sv.filtering, [&](int tx, int ty, float w) {
    a = a +
        texel_receive<N>(sv.storage, m, tx, ty, receiver_read_at(sv, m, pr, r, tap_depth(sv, m, pr, r, tx, ty))) * w;
  });
  return a;
}

// The same per colour channel for a map of either kind (a grey map's value,
// computed as a scalar, in every channel).
CDSM_HD inline Vec3 map_alpha_in_colour(const ShadowView& sv, const LightData& L, const DsmMap& m,
                                        const ViewProjection& pr, const Receiver& r) {
  return m.rgb ? map_alpha<3>(sv, L, m, pr, r) : to_rgb(map_alpha<1>(sv, L, m, pr, r));
}

// Opacity per channel between light L and receiver r from the light's DSMs
// (grey_of() of it: exactly the one value where every channel agrees, grey
// casters, else the channel mean).
CDSM_HD inline Vec3 shadow_alpha(const ShadowView& sv, const LightData& L, const Receiver& r) {
  return combine_maps(sv, L, r.p, [&](uint32_t, const DsmMap& m, const ViewProjection& pr) {
    return map_alpha_in_colour(sv, L, m, pr, r);
  });
}

// A point lookup at p's own depth (volume samples, probes).
CDSM_HD CDSM_INLINE Vec3 shadow_alpha(const ShadowView& sv, const LightData& L, Vec3 p) {
  return shadow_alpha(sv, L, Receiver{p, Vec3{0, 0, 0}, kNoObject});
}

}  // namespace cdsm
