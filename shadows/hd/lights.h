// Lights as the kernels see them, and the shadow term at a point: spot cone,
// DSM lookups combined over a light's maps (thesis eq. 3.12).
#pragma once

#include "hd/blocker_pyramid.h"
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

// Filter taps across a penumbra's longer axis unless the settings say
// otherwise (ShadowSettings::penumbra_taps; soft_map_alpha_in_colour).
inline constexpr int kPenumbraTaps = 11;

// Everything the camera pass needs to look up shadows.
struct ShadowView {
  Span<const LightData> lights;
  Span<const DsmMap> maps;
  DsmStorage storage;
  bool filtering;
  Penumbra penumbra;  // lights with a size (LightData::size > 0); the others are hard whatever it says
  int32_t penumbra_taps = kPenumbraTaps;  // their filter's taps across a penumbra (>= 5)
  float bias_constant;                    // a surface's own step is searched this far around its plane: world units
  float bias_slope;  // + this many texel footprints at the point (+ kRelativeDepthOffset of the depth)
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
// Cost: a few multiply-adds and a square root per tap (PlaneRays), and for a surface in the
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
// plane_depth_clamped takes the ray's cosine to n (dn) and the plane's
// distance along n from the ray's origin (num), or both scaled alike.
CDSM_HD CDSM_INLINE float plane_depth_clamped(float dn, float num, float depth, float reach) {
  float t = dn != 0.0f ? num / dn : depth + reach;
  if (!(t > depth - reach)) t = depth - reach;  // also NaN
  if (!(t < depth + reach)) t = depth + reach;
  return t;
}
// A map's texel-centre rays against one plane, set up once per lookup
// (plane_rays) so that each tap costs a few multiply-adds and a square
// root (ray_crossing). Texel (tx, ty)'s centre lies at window coordinates
//   sx = x0 + dx tx,  sy = y0 + dy ty          (hd/view.h window_at)
// and its ray runs from the eye along F + R sx + U sy, of length
// sqrt(1 + sx^2 + sy^2) (the view's axes are orthonormal), or, orthographic,
// from eye + R sx + U sy along F. Its crossing with the plane through p with
// normal n lies at num / dn, with
//   pinhole:       num = (p - eye) . n sqrt(1 + sx^2 + sy^2),  dn = F.n + sx R.n + sy U.n
//   orthographic:  num = (p - eye) . n - sx R.n - sy U.n,       dn = F.n
struct PlaneRays {
  float x0, dx, y0, dy;
  float num;         // (p - eye) . n
  float fn, rn, un;  // F.n, R.n, U.n
  bool pinhole;
};
CDSM_HD CDSM_INLINE PlaneRays plane_rays(const PinholeView& v, Vec3 p, Vec3 n) {
  PlaneRays r;
  const float iw = 1.0f / float(v.width), ih = 1.0f / float(v.height);
  r.dx = 2.0f * v.tan_half_x * iw;
  r.x0 = v.center.x + (iw - 1.0f) * v.tan_half_x;
  r.dy = -2.0f * v.tan_half_y * ih;
  r.y0 = v.center.y + (1.0f - ih) * v.tan_half_y;
  r.num = dot(p - v.eye, n);
  r.fn = dot(v.forward, n);
  r.rn = dot(v.right, n);
  r.un = dot(v.up, n);
  r.pinhole = !is_orthographic(v);
  return r;
}
// Texel (tx, ty)'s ray against the plane: the plane's depth along it is
// num / dn (plane_depth_clamped), and the plane lies in front of the ray's
// origin where num dn > 0.
struct RayCrossing {
  float num, dn;
};
CDSM_HD CDSM_INLINE RayCrossing ray_crossing(const PlaneRays& r, int tx, int ty) {
  const float sx = r.x0 + r.dx * float(tx), sy = r.y0 + r.dy * float(ty);
  if (r.pinhole) return RayCrossing{r.num * sqrtf(1.0f + sx * sx + sy * sy), r.fn + sx * r.rn + sy * r.un};
  return RayCrossing{r.num - sx * r.rn - sy * r.un, r.fn};
}
CDSM_HD CDSM_INLINE float plane_depth_of(const PlaneRays& r, int tx, int ty, float depth, float reach) {
  const RayCrossing c = ray_crossing(r, tx, ty);
  return plane_depth_clamped(c.dn, c.num, depth, reach);
}
CDSM_HD CDSM_INLINE float plane_depth_at_texel(const PinholeView& v, int tx, int ty, Vec3 p, Vec3 n, float depth,
                                               float reach) {
  return plane_depth_of(plane_rays(v, p, n), tx, ty, depth, reach);
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

// What every tap of receiver r's lookup in map m shares: the reach of its
// plane depths (tap_depth) and its own step's search window less the
// coplanar band (receiver_read_at), from the map's texel footprint at the
// point, computed once per lookup.
struct TapShared {
  float reach;   // plane depths within +-reach of the point's depth
  float search;  // bias_constant + bias_slope texel footprints
  uint32_t own;  // tag_object() of the receiver's object; 0: none
};
CDSM_HD CDSM_INLINE TapShared tap_shared(const ShadowView& sv, const DsmMap& m, const ViewProjection& pr,
                                         const Receiver& r) {
  const float footprint = texel_footprint(m, pr.axial);
  return TapShared{kPlaneReachTexels * footprint, sv.bias_constant + sv.bias_slope * footprint,
                   r.object == kNoObject ? 0u : tag_object(r.object)};
}
// How a tap whose ray crosses the receiver's plane at `depth` reads its
// texel (DESIGN.md §8, hd/dsm.h TexelRead).
CDSM_HD CDSM_INLINE TexelRead receiver_read_of(const TapShared& sh, float depth) {
  TexelRead tr;
  tr.depth = depth;
  tr.coplanar = kRelativeDepthOffset * depth;
  tr.window = sh.search + tr.coplanar;
  tr.own = sh.own;
  return tr;
}
// How receiver r reads a tap of map m whose ray crosses its plane at
// `depth`.
CDSM_HD CDSM_INLINE TexelRead receiver_read_at(const ShadowView& sv, const DsmMap& m, const ViewProjection& pr,
                                               const Receiver& r, float depth) {
  return receiver_read_of(tap_shared(sv, m, pr, r), depth);
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

// How one lookup of receiver r in map m reads its texels: surfaces each at
// the receiver's plane along the texel's ray with their own step left out
// (receiver_read_of), volume samples at the point's depth, the slope-bias
// baseline at the point's depth less its offset. Once per lookup.
struct MapTaps {
  TapShared sh;
  PlaneRays rays;  // the map's texel rays against the receiver's plane, when plane
  float z;         // every texel's depth when !plane
  bool plane;      // a surface read at its plane
};
CDSM_HD CDSM_INLINE MapTaps map_taps(const ShadowView& sv, const LightData& L, const DsmMap& m,
                                     const ViewProjection& pr, const Receiver& r) {
  MapTaps t;
  t.sh = tap_shared(sv, m, pr, r);
  t.plane = sv.receiver != ReceiverLookup::SlopeBias && dot(r.plane, r.plane) > 0.0f;
  t.z = pr.depth - (sv.receiver == ReceiverLookup::SlopeBias ? slope_bias_offset(L, m, pr, r) : 0.0f);
  if (t.plane) t.rays = plane_rays(m.view, r.p, r.plane);
  return t;
}
// What texel (tx, ty) gives lookup `t` (map_taps) of receiver r at pr;
// Plane = t.plane, decided once per lookup.
template <int N, bool Plane>
CDSM_HD CDSM_INLINE Channels<N> texel_of(const ShadowView& sv, const DsmMap& m, const ViewProjection& pr,
                                         const Receiver& r, const MapTaps& t, int tx, int ty) {
  if (!Plane) return texel_alpha<N>(sv.storage, m, tx, ty, t.z);
  const float depth = plane_depth_of(t.rays, tx, ty, pr.depth, t.sh.reach);
  return texel_receive<N>(sv.storage, m, tx, ty, receiver_read_of(t.sh, depth));
}

// Opacity between light L and receiver r from one map of node kind N: its
// taps (for_each_tap), each texel as texel_of reads it.
template <int N>
CDSM_HD inline Channels<N> map_alpha(const ShadowView& sv, const DsmMap& m, const ViewProjection& pr, const Receiver& r,
                                     const MapTaps& t) {
  Channels<N> a{};
  if (t.plane)
    for_each_tap(m, pr.u, pr.v, sv.filtering,
                 [&](int tx, int ty, float w) { a = a + texel_of<N, true>(sv, m, pr, r, t, tx, ty) * w; });
  else
    for_each_tap(m, pr.u, pr.v, sv.filtering,
                 [&](int tx, int ty, float w) { a = a + texel_of<N, false>(sv, m, pr, r, t, tx, ty) * w; });
  return a;
}
template <int N>
CDSM_HD inline Channels<N> map_alpha(const ShadowView& sv, const LightData& L, const DsmMap& m,
                                     const ViewProjection& pr, const Receiver& r) {
  return map_alpha<N>(sv, m, pr, r, map_taps(sv, L, m, pr, r));
}

// The same per colour channel for a map of either kind (a grey map's value,
// computed as a scalar, in every channel).
CDSM_HD inline Vec3 map_alpha_in_colour(const ShadowView& sv, const DsmMap& m, const ViewProjection& pr,
                                        const Receiver& r, const MapTaps& t) {
  return m.rgb ? map_alpha<3>(sv, m, pr, r, t) : to_rgb(map_alpha<1>(sv, m, pr, r, t));
}
CDSM_HD inline Vec3 map_alpha_in_colour(const ShadowView& sv, const LightData& L, const DsmMap& m,
                                        const ViewProjection& pr, const Receiver& r) {
  return map_alpha_in_colour(sv, m, pr, r, map_taps(sv, L, m, pr, r));
}

// ---- lights with a size: penumbrae from the maps -------------------------------
//
// A sphere light of radius r (or the sun's cone, tan of its half-angle r)
// seen from a receiver at depth z: the shadow rays to its area cross depth
// z_b inside a disk around the receiver's own light ray of radius
//   rho(z_b) = r (z - z_b) / (z z_b)   radians across the ray (a pinhole map's depths are radial),
//   rho(z_b) = r (z - z_b)             world units of an orthographic one
// (similar triangles), placed in the map through the window's stretch off
// its axis (PenumbraFrame below: an ellipse). A blocker at z_b whose texel
// lies farther than rho(z_b) from the receiver's ray casts nothing on it.
// The lookup
//   1. searches the map around the receiver (a disk of radius rho at the
//      map's near plane, at most kPenumbraSearchTexels texels): the texel
//      under it and rings of 8 texels at 1, 2, 4, ... texels out to the
//      disk's edge (blockers near the receiver cast only within a texel or
//      two, far ones wide: the rings' spacing follows); each texel
//      gives the opacity in front of the receiver and its opacity-weighted
//      mean depth (a visibility function says more than a first depth: a
//      medium's blockers lie where its opacity rises), and counts only when
//      it lies within twice its own rho (plus a texel) of the receiver (twice:
//      the rings sample a blocker region sparsely, at 1, 2, 4, ...) — so the
//      blockers touching a receiver, which cast on it through a disk of
//      radius ~0, are the only ones read at a contact (contact hardening);
//   2. takes the opacity-weighted mean depth z_b of what counted and filters
//      today's lookup (bilinear taps, each at the receiver's plane) over the
//      disk of radius rho(z_b) (an ellipse in the map): the points of a
//      lattice fixed in the map inside it, a texel apart, or 1 /
//      ShadowView::penumbra_taps (kPenumbraTaps) of the ellipse's longer axis for wide ones,
//      weighted down across its rim (soft_map_alpha_in_colour); a tap whose texel's blockers lie beyond
//      their own reach of the receiver counts as lit (blocks_receiver: the
//      body of a cup beside a receiver on the ground, in the disk but too
//      near the ground to shadow it). Averaging a step over a disk is
//      exactly the visible fraction of a uniform disk light behind a
//      straight edge.
// Nothing in front of the receiver, or a radius under half a texel: the
// hard lookup. Penumbra::FixedKernel skips step 1 and filters with the
// radius of a blocker halfway to the light (rho(z/2)): a fixed-kernel PCF
// of the same taps, the baseline. Cost: up to 8 kPenumbraSearchRings + 1 node
// walks plus about (penumbra_taps + 1)^2 pi / 4 bilinear taps per map (each with one
// more node walk, blocks_receiver; taps under two texels apart share their
// texels, each walked once: about one walk per tap instead of four),
// against one bilinear tap for a hard lookup.
inline constexpr int kPenumbraSearchRings = 7;         // blocker search: rings at 1, 2, 4, ... texels (<= 64)
inline constexpr float kPenumbraSearchTexels = 64.0f;  // blocker search radius cap
inline constexpr float kPenumbraMinAlpha = 1.0e-3f;    // less opacity in front: no blocker
// Unit direction d of 16, every 22.5 degrees (cos, sin): ring k's 8 use
// the even ones, or the odd ones when k is odd.
CDSM_HD CDSM_INLINE Vec2 penumbra_direction(int d) {
  switch (d) {
    case 0: return {1.00000000f, 0.00000000f};
    case 1: return {0.92387953f, 0.38268343f};
    case 2: return {0.70710678f, 0.70710678f};
    case 3: return {0.38268343f, 0.92387953f};
    case 4: return {0.00000000f, 1.00000000f};
    case 5: return {-0.38268343f, 0.92387953f};
    case 6: return {-0.70710678f, 0.70710678f};
    case 7: return {-0.92387953f, 0.38268343f};
    case 8: return {-1.00000000f, 0.00000000f};
    case 9: return {-0.92387953f, -0.38268343f};
    case 10: return {-0.70710678f, -0.70710678f};
    case 11: return {-0.38268343f, -0.92387953f};
    case 12: return {-0.00000000f, -1.00000000f};
    case 13: return {0.38268343f, -0.92387953f};
    case 14: return {0.70710678f, -0.70710678f};
    default: return {0.92387953f, -0.38268343f};
  }
}

// rho(z_b) above, for light L through map m at receiver depth z.
CDSM_HD CDSM_INLINE float penumbra_radius(const LightData& L, const DsmMap& m, float z, float zb) {
  const float d = fmaxf(z - zb, 0.0f);
  return is_orthographic(m.view) ? L.size * d : L.size * d / (z * fmaxf(zb, 1e-6f));
}

// A penumbra's disk is a cone of angular radius rho around the receiver's
// light ray (radial depths: rho in radians; orthographic maps: world units).
// Off the map's axis the window stretches it: a pinhole maps the ray's
// direction (w, 1) / L, L = sqrt(1 + |w|^2) = 1 / cos(angle off the axis),
// to window coordinates w, so an angle g across the ray lands as L g
// tangentially and L^2 g radially (away from the axis): the disk is an
// ellipse in the map, wider the farther off the axis (45 degrees: 1.4 x 2,
// a cube face's corner: 1.7 x 3). Lookups measure their offsets in angles
// and place them through this frame (to_pixels, angle_of): J g =
// L (g + (g . w) w / (L + 1)), J^-1 d = (d - (d . w) w / (L (L + 1))) / L.
// Orthographic maps: L = 1, the identity.
struct PenumbraFrame {
  float to_u, to_v;  // pixels per window unit
  Vec2 w;            // the receiver's window coordinates (tangents off the axis; 0 orthographic)
  float l;           // sqrt(1 + |w|^2)
  float texel;       // one texel across the ray: radians (the window's texel / L); world units orthographic
  // Reciprocals, once per lookup (a soft lookup places and measures up to
  // 57 ring texels and its filter taps: multiplications, not divisions):
  float inv_u, inv_v;  // 1 / to_u, 1 / to_v
  float inv_l;         // 1 / l
  float inv_l1;        // 1 / (l + 1)
  float inv_ll1;       // 1 / (l (l + 1))
};
CDSM_HD CDSM_INLINE PenumbraFrame penumbra_frame(const DsmMap& m, const ViewProjection& pr) {
  PenumbraFrame f;
  f.to_u = float(m.res) / (2.0f * m.view.tan_half_x);
  f.to_v = float(m.res) / (2.0f * m.view.tan_half_y);
  f.w = is_orthographic(m.view) ? Vec2{0.0f, 0.0f} : window_at(m.view, pr.u, pr.v);
  f.l = sqrtf(1.0f + f.w.x * f.w.x + f.w.y * f.w.y);
  f.texel = 2.0f * fmaxf(m.view.tan_half_x, m.view.tan_half_y) / (float(m.res) * f.l);
  f.inv_u = 1.0f / f.to_u;
  f.inv_v = 1.0f / f.to_v;
  f.inv_l = 1.0f / f.l;
  f.inv_l1 = 1.0f / (f.l + 1.0f);
  f.inv_ll1 = 1.0f / (f.l * (f.l + 1.0f));
  return f;
}
// The pixel offset (du, dv) of angle g (right, up) across the receiver's ray.
CDSM_HD CDSM_INLINE Vec2 to_pixels(const PenumbraFrame& f, float gx, float gy) {
  const float k = (gx * f.w.x + gy * f.w.y) * f.inv_l1;
  return Vec2{f.l * (gx + k * f.w.x) * f.to_u, -f.l * (gy + k * f.w.y) * f.to_v};
}
// The angle across the receiver's ray of pixel offset (du, dv).
CDSM_HD CDSM_INLINE float angle_of(const PenumbraFrame& f, float du, float dv) {
  const float x = du * f.inv_u, y = -dv * f.inv_v;
  const float k = (x * f.w.x + y * f.w.y) * f.inv_ll1;
  const float ax = x - k * f.w.x, ay = y - k * f.w.y;
  return sqrtf(ax * ax + ay * ay) * f.inv_l;
}
// The largest pixel length of an angle (the stretch along the radial: L^2).
CDSM_HD CDSM_INLINE float max_pixels_per_angle(const PenumbraFrame& f) { return f.l * f.l * fmaxf(f.to_u, f.to_v); }

// What texel (tx, ty) holds in front of depth z_lim: its opacity there (grey_of
// per channel) and the opacity-weighted mean depth of it (steps at their
// depth, a linear stretch at its middle).
struct TexelBlockers {
  float alpha = 0.0f;
  float depth = 0.0f;
};
struct BlockerScan {
  float z_lim;
  float prev_z = 0.0f, prev_a = 0.0f, moment = 0.0f;
  bool have_prev = false;
  CDSM_HD bool visit(float z, float a) {
    if (z >= z_lim) {  // a stretch crossing z_lim counts up to it
      if (have_prev && z > prev_z) {
        const float at = prev_a + (a - prev_a) * ((z_lim - prev_z) / (z - prev_z));
        moment += (at - prev_a) * 0.5f * (prev_z + z_lim);
        prev_a = at;
      }
      return false;
    }
    moment += (a - prev_a) * (have_prev ? 0.5f * (prev_z + z) : z);  // the first node: a step at its depth
    prev_z = z;
    prev_a = a;
    have_prev = true;
    return true;
  }
  CDSM_HD TexelBlockers result() const {
    return prev_a > 0.0f ? TexelBlockers{prev_a, moment / prev_a} : TexelBlockers{};
  }
};
template <int N>
CDSM_HD inline TexelBlockers texel_blockers(const DsmStorage& st, const DsmMap& m, int tx, int ty, float z_lim) {
  const NodeArrays<N> a = st.arrays<N>();
  const uint64_t t = texel_index(m, tx, ty);
  BlockerScan scan{z_lim};
  if (st.layout == DsmLayout::Chunked) {
    const TexelRange h = a.texels[t];
    uint32_t slot = h.offset;
    for (uint32_t i = 0; i < h.count; ++i) {
      const ChunkNodeN<N> c = a.chunks[slot];
      if (!scan.visit(c.z, grey_of(to_rgb(c.alpha)))) break;
      slot = c.next;
    }
    return scan.result();
  }
  const Span<const DsmNodeN<N>> n = texel_nodes<N>(st, m, tx, ty);
  for (uint64_t i = 0; i < n.size(); ++i)
    if (!scan.visit(n[i].z, grey_of(to_rgb(n[i].alpha)))) break;
  return scan.result();
}

// The depth in front of which a tap's texel holds blockers of receiver r:
// its read depth less the own step's search window (surfaces), or the
// point's depth (volume samples; the slope-bias baseline's offset depth).
// `t`: map_taps(sv, L, m, pr, r), once per lookup.
CDSM_HD CDSM_INLINE float blocker_limit(const DsmMap& m, const ViewProjection& pr, const Receiver& r, const MapTaps& t,
                                        int tx, int ty) {
  if (!t.plane) return t.z;
  const float depth = plane_depth_of(t.rays, tx, ty, pr.depth, t.sh.reach);
  return depth - receiver_read_of(t.sh, depth).window;
}
CDSM_HD CDSM_INLINE float blocker_limit(const ShadowView& sv, const LightData& L, const DsmMap& m,
                                        const ViewProjection& pr, const Receiver& r, int tx, int ty) {
  return blocker_limit(m, pr, r, map_taps(sv, L, m, pr, r), tx, ty);
}

// The deepest depth a blocker search tap at texels [x0, x1] x [y0, y1] of
// map m reads receiver r to (blocker_limit's largest there), or more. A
// plane's depth along the rays of a rectangle of texels is largest at a
// corner: linear in the texel orthographically; through a pinhole the
// plane's distance over the cosine of the ray's angle to its normal, which
// is largest at a corner of the rectangle's (convex) cone of rays when the
// plane lies in front of all four — else at most the reach's cap.
CDSM_HD inline float blocker_limit_bound(const DsmMap& m, const ViewProjection& pr, const Receiver& r,
                                         const MapTaps& taps, int x0, int x1, int y0, int y1) {
  if (!taps.plane) return taps.z;
  const TapShared& sh = taps.sh;
  float t = pr.depth - sh.reach;
  bool in_front = true;
  for (int c = 0; c < 4; ++c) {
    const int tx = c & 1 ? x1 : x0, ty = c & 2 ? y1 : y0;
    const RayCrossing x = ray_crossing(taps.rays, tx, ty);
    t = fmaxf(t, plane_depth_clamped(x.dn, x.num, pr.depth, sh.reach));  // plane_depth_of
    in_front = in_front && x.dn * x.num > 0.0f;
  }
  if (!in_front && !is_orthographic(m.view)) t = pr.depth + sh.reach;
  t += 4.0e-6f * fabsf(t);  // the taps' own rounding
  return t - receiver_read_of(sh, t).window;
}

// How far from receiver r the blocker search (penumbra_filter_radius, out
// to `search` across its ray) can count anything, from map m's blocker
// pyramid (hd/blocker_pyramid.h): an angle no counted texel's centre lies
// farther than, or -1 when it counts nothing. The cells over the search's
// square give the least depth of any blocker in it, so the farthest reach
// of any (2 rho + a texel, with rho at that depth: rho shrinks with depth);
// the square shrinks to it. Then squares of texels the search may read
// (within that reach in pixels, times max_pixels_per_angle) are
// dismissed when none of their texels holds opacity in front of the
// deepest depth the search reads there (blocker_limit_bound), or when they
// lie farther from the receiver than their nearest blocker could reach
// (the search's own test, with rho at the square's least depth); the
// others are split, coarse to fine. Every square dismissed: -1, the lookup
// is hard. A square of 2 x 2 texels left, or the visit budget spent: the
// reach. A map without a pyramid: `search`. Exact either way: the search
// decides, and reads no texel that could count past the reach.
inline constexpr int kPyramidVisits = 48;
// Map m's pyramid as a lookup reads it: its levels' first cells (offset[k],
// k = 1 .. top) in its kind's array; top 0 when it has none (or was built
// without one).
struct PyramidCells {
  const float* cells = nullptr;
  uint64_t offset[33];
  int top = 0;
};
template <int N>
CDSM_HD CDSM_INLINE PyramidCells pyramid_cells_of(const ShadowView& sv, const DsmMap& m) {
  const NodeArrays<N> a = sv.storage.arrays<N>();
  PyramidCells p;
  p.top = pyramid_offsets(a, m, p.offset);
  if (p.top == 0) return p;
  p.cells = a.pyramid.data();
  if (!(p.cells[p.offset[p.top]] > -kNoOpacityDepth)) p.top = 0;  // built without one
  return p;
}
// Cell (x, y) of level k (1 .. p.top) of map m's pyramid p.
CDSM_HD CDSM_INLINE float pyramid_cell(const PyramidCells& p, const DsmMap& m, int k, int x, int y) {
  return p.cells[p.offset[k] + uint64_t(y) * (((m.res - 1u) >> k) + 1u) + uint64_t(x)];
}
// The farthest angle from the receiver a blocker at depth zb or deeper
// reaches it from (the search's test, with a margin for its rounding).
CDSM_HD CDSM_INLINE float blocker_reach(const LightData& L, const DsmMap& m, const PenumbraFrame& f, float z,
                                        float zb) {
  return (2.0f * penumbra_radius(L, m, z, zb) + f.texel) * (1.0f + 1.0e-4f);
}
CDSM_HD inline float blockers_within_reach(const PyramidCells& p, const LightData& L, const DsmMap& m,
                                           const ViewProjection& pr, const Receiver& r, const PenumbraFrame& f,
                                           const MapTaps& taps, float search) {
  const uint32_t w = m.res, h = uint32_t(m.view.height);
  const int top = p.top;
  if (top == 0) return search;
  const float ppa = max_pixels_per_angle(f), inv_ppa = 1.0f / ppa;
  int bx0 = 0, bx1 = -1, by0 = 0, by1 = -1, k0 = 1;
  // The search's square (radius R pixels) and the level whose cells are
  // about its size.
  // (Each bound clamped before its floor, one texel past the map, so that
  // floor_int stays in range: the same squares as the clamped floors.)
  const float fw = float(w), fh = float(h);
  const auto square = [&](float R) {
    bx0 = floor_int(fminf(fmaxf(pr.u - R, 0.0f), fw)), bx1 = floor_int(fmaxf(fminf(pr.u + R, fw - 1.0f), -1.0f));
    by0 = floor_int(fminf(fmaxf(pr.v - R, 0.0f), fh)), by1 = floor_int(fmaxf(fminf(pr.v + R, fh - 1.0f), -1.0f));
    // the least k0 >= 1 with 2^k0 >= R (R >= 1), at most top
    k0 = !(R > 2.0f) ? 1 : R >= float(1 << top) ? top : ceil_log2(uint32_t(R) + (float(uint32_t(R)) < R));
  };
  square(search * ppa + 1.0f);
  if (bx0 > bx1 || by0 > by1) return -1.0f;
  float least = kNoOpacityDepth;
  for (int y = by0 >> k0; y <= by1 >> k0; ++y)
    for (int x = bx0 >> k0; x <= bx1 >> k0; ++x) least = fminf(least, pyramid_cell(p, m, k0, x, y));
  if (!(least < kNoOpacityDepth)) return -1.0f;
  const float reach = fminf(blocker_reach(L, m, f, pr.depth, least), search);
  square(reach * ppa + 1.0f);
  // Cells (level, x, y) to visit, depth first; those with no opacity are
  // not pushed.
  uint32_t stack[64];
  int n = 0;
  for (int y = by0 >> k0; y <= by1 >> k0; ++y)
    for (int x = bx0 >> k0; x <= bx1 >> k0; ++x)
      if (pyramid_cell(p, m, k0, x, y) < kNoOpacityDepth)
        stack[n++] = (uint32_t(k0) << 26) | (uint32_t(y) << 13) | uint32_t(x);
  for (int visits = 0; n > 0; ++visits) {
    if (visits == kPyramidVisits) return reach;
    const uint32_t c = stack[--n];
    const int k = int(c >> 26), cy = int((c >> 13) & 0x1fffu), cx = int(c & 0x1fffu);
    const float cell = pyramid_cell(p, m, k, cx, cy);
    // The cell's texels the search may read.
    const int x0 = cx << k > bx0 ? cx << k : bx0, x1 = ((cx + 1) << k) - 1 < bx1 ? ((cx + 1) << k) - 1 : bx1;
    const int y0 = cy << k > by0 ? cy << k : by0, y1 = ((cy + 1) << k) - 1 < by1 ? ((cy + 1) << k) - 1 : by1;
    const float dx = fmaxf(fmaxf(float(x0) + 0.5f - pr.u, pr.u - (float(x1) + 0.5f)), 0.0f);
    const float dy = fmaxf(fmaxf(float(y0) + 0.5f - pr.v, pr.v - (float(y1) + 0.5f)), 0.0f);
    const float nearest = sqrtf(dx * dx + dy * dy) * inv_ppa;  // an angle no texel centre of it is nearer than
    if (nearest * (1.0f - 1.0e-4f) > 2.0f * penumbra_radius(L, m, pr.depth, cell) * (1.0f + 1.0e-4f) + f.texel)
      continue;
    if (cell >= blocker_limit_bound(m, pr, r, taps, x0, x1, y0, y1)) continue;
    if (k == 1 || n + 4 > 64) return reach;
    for (int y = 2 * cy; y <= 2 * cy + 1; ++y)
      for (int x = 2 * cx; x <= 2 * cx + 1; ++x)
        if ((x << (k - 1)) <= bx1 && ((x + 1) << (k - 1)) - 1 >= bx0 && (y << (k - 1)) <= by1 &&
            ((y + 1) << (k - 1)) - 1 >= by0 && pyramid_cell(p, m, k - 1, x, y) < kNoOpacityDepth)
          stack[n++] = (uint32_t(k - 1) << 26) | (uint32_t(y) << 13) | uint32_t(x);
  }
  return -1.0f;
}
template <int N>
CDSM_HD inline bool blockers_within_reach(const ShadowView& sv, const LightData& L, const DsmMap& m,
                                          const ViewProjection& pr, const Receiver& r, const PenumbraFrame& f,
                                          float search) {
  return blockers_within_reach(pyramid_cells_of<N>(sv, m), L, m, pr, r, f, map_taps(sv, L, m, pr, r), search) >= 0.0f;
}

// The search of step 1 above in a map of kind N. With the map's pyramid, a
// ring texel whose 2 x 2 cell of level 1 holds no opacity, or whose least
// depth there (a bound on the texel's blockers' mean depth, so on their
// reach from above) puts the receiver out of reach, is passed without
// reading the texel: the pyramid's cells lie together, the texels' nodes
// do not (two cache misses a ring texel). The same sums, to the bit.
template <int N>
CDSM_HD inline float blocker_search(const ShadowView& sv, const LightData& L, const DsmMap& m, const ViewProjection& pr,
                                    const Receiver& r, const PenumbraFrame& f, const MapTaps& taps, float search) {
  const PyramidCells p = pyramid_cells_of<N>(sv, m);
  const float reach = blockers_within_reach(p, L, m, pr, r, f, taps, search);
  if (!(reach >= 0.0f)) return 0.0f;
  // A ring texel's centre lies within 0.71 pixels of its ring, so within
  // `slack` of its angle (a pixel spans at least 1 / (L min(to_u, to_v))).
  const float slack = 0.75f / (f.l * fminf(f.to_u, f.to_v));
  const float z = pr.depth;
  const int res = int(m.res);
  float weight = 0.0f, moment = 0.0f;
  // The texel under the receiver, then rings of 8 at 1, 2, 4, ... texels
  // out to the search radius (every other ring turned by 22.5 degrees).
  float ring = 0.0f;
  for (int k = 0; k < 2 + 8 * kPenumbraSearchRings; ++k) {
    if (k > 0 && (k - 1) % 8 == 0) {  // the next ring
      if (ring >= search) break;
      ring = fminf(k == 1 ? f.texel : 2.0f * ring, search);
      if (ring * (1.0f - 1.0e-5f) - slack > reach) break;  // it and the rings past it: nothing within reach
    }
    const int d = k == 0 ? 0 : ((k - 1) % 8) * 2 + (((k - 1) / 8) & 1);
    const Vec2 dir = penumbra_direction(d);
    const Vec2 at = k == 0 ? Vec2{0.0f, 0.0f} : to_pixels(f, ring * dir.x, ring * dir.y);
    const int tx = floor_int(pr.u + at.x), ty = floor_int(pr.v + at.y);
    if (tx < 0 || ty < 0 || tx >= res || ty >= res) continue;
    // Its texel centre's angle from the receiver's ray. Its blockers lie at
    // or behind its first node (and its cell's least depth), and reach no
    // farther than from there: a texel too far for that (or empty) is
    // passed without its walk.
    float off = -1.0f;
    if (p.top != 0) {  // its cell of level 1
      const float least = pyramid_cell(p, m, 1, tx >> 1, ty >> 1);
      if (!(least < kNoOpacityDepth)) continue;
      off = angle_of(f, float(tx) + 0.5f - pr.u, float(ty) + 0.5f - pr.v);
      if (off > (2.0f * penumbra_radius(L, m, z, least) + f.texel) * (1.0f + 1.0e-5f)) continue;
    }
    const float first = texel_first_depth<N>(sv.storage, m, tx, ty);
    if (!(first < kFixedPadZ)) continue;  // empty: no angle to measure
    if (p.top == 0) off = angle_of(f, float(tx) + 0.5f - pr.u, float(ty) + 0.5f - pr.v);
    if (off > (2.0f * penumbra_radius(L, m, z, first) + f.texel) * (1.0f + 1.0e-5f)) continue;
    const TexelBlockers b = texel_blockers<N>(sv.storage, m, tx, ty, blocker_limit(m, pr, r, taps, tx, ty));
    if (!(b.alpha > kPenumbraMinAlpha)) continue;
    if (off > 2.0f * penumbra_radius(L, m, z, b.depth) + f.texel) continue;
    weight += b.alpha;
    moment += b.alpha * b.depth;
  }
  return weight > kPenumbraMinAlpha ? penumbra_radius(L, m, z, moment / weight) : 0.0f;
}

// The filter radius (radians across the ray; world units orthographic) of light L's penumbra at receiver r in
// map m (0: a hard lookup), step 1 above; f = penumbra_frame(m, pr), taps = map_taps(sv, L, m, pr, r).
CDSM_HD inline float penumbra_filter_radius(const ShadowView& sv, const LightData& L, const DsmMap& m,
                                            const ViewProjection& pr, const Receiver& r, const PenumbraFrame& f,
                                            const MapTaps& taps) {
  const float z = pr.depth;
  if (sv.penumbra == Penumbra::FixedKernel) return penumbra_radius(L, m, z, 0.5f * z);
  const float search = fminf(penumbra_radius(L, m, z, fmaxf(m.view.near, 1e-6f)), kPenumbraSearchTexels * f.texel);
  return m.rgb ? blocker_search<3>(sv, L, m, pr, r, f, taps, search)
               : blocker_search<1>(sv, L, m, pr, r, f, taps, search);
}
CDSM_HD inline float penumbra_filter_radius(const ShadowView& sv, const LightData& L, const DsmMap& m,
                                            const ViewProjection& pr, const Receiver& r) {
  return penumbra_filter_radius(sv, L, m, pr, r, penumbra_frame(m, pr), map_taps(sv, L, m, pr, r));
}

// Whether a filter tap at `at` may shadow receiver r (at pr): its texel's
// blockers lie within their own reach of the receiver (plus a texel), or it
// holds none. A blocker next to the receiver in the map but near its depth
// (the body of a cup standing on the ground beside the receiver) casts only
// within a texel or two of itself: the tap counts as lit.
CDSM_HD inline bool blocks_receiver(const ShadowView& sv, const LightData& L, const DsmMap& m, const ViewProjection& pr,
                                    const PenumbraFrame& f, const Receiver& r, const MapTaps& t,
                                    const ViewProjection& at) {
  const int tx = floor_int(at.u), ty = floor_int(at.v), res = int(m.res);
  if (tx < 0 || ty < 0 || tx >= res || ty >= res) return true;
  const float limit = blocker_limit(m, pr, r, t, tx, ty);
  const TexelBlockers b =
      m.rgb ? texel_blockers<3>(sv.storage, m, tx, ty, limit) : texel_blockers<1>(sv.storage, m, tx, ty, limit);
  if (!(b.alpha > kPenumbraMinAlpha)) return true;
  return angle_of(f, at.u - pr.u, at.v - pr.v) <= penumbra_radius(L, m, pr.depth, b.depth) + f.texel;
}

// The weight of a filter tap `du, dv` pixels from the receiver, `angle`
// across its ray (angle_of), in a penumbra of radius `radius` filtered on a
// lattice of spacing `spacing` pixels: 1 inside, 0 outside, ramping over
// one spacing across the ellipse's rim (along the tap's direction the rim
// lies |d| radius / angle pixels out), so that the filter's sum changes
// continuously as the receiver moves over the fixed lattice.
CDSM_HD CDSM_INLINE float rim_weight(float du, float dv, float angle, float radius, float spacing) {
  if (!(angle > 0.0f)) return 1.0f;
  const float w = (radius / angle - 1.0f) * sqrtf(du * du + dv * dv) / spacing + 0.5f;
  return fminf(fmaxf(w, 0.0f), 1.0f);
}

// The texels of a soft lookup's filter taps (soft_filter): taps less than
// two texels apart share bilinear texels with their neighbours in the row
// and the row before, so two rows of texel values are kept, each texel read
// once (texel_of: the value every tap reading it would get).
inline constexpr int kFilterRowTexels = 32;
template <int N>
struct FilterRows {
  int x0 = 0;  // the rows' first texel column
  int y[2] = {-1, -1};
  uint32_t have[2] = {0u, 0u};  // bit k: column x0 + k read
  Channels<N> at[2][kFilterRowTexels];
};

// The sum of the filter taps' opacity times their weights (their weights'
// sum added to `weight`): the lattice of soft_map_alpha_in_colour.
template <int N, bool Plane>
CDSM_HD inline Channels<N> soft_filter(const ShadowView& sv, const LightData& L, const DsmMap& m,
                                       const ViewProjection& pr, const Receiver& r, const PenumbraFrame& f,
                                       const MapTaps& t, float radius, float reach, float& weight) {
  const float spacing = fmaxf(1.0f, 2.0f * reach / float(sv.penumbra_taps));
  const float inv = 1.0f / spacing, out = reach + 0.5f * spacing;
  const int i0 = int(ceilf((pr.u - out) * inv)), i1 = int(floorf((pr.u + out) * inv));
  const int j0 = int(ceilf((pr.v - out) * inv)), j1 = int(floorf((pr.v + out) * inv));
  FilterRows<N> rows;
  rows.x0 = int(floorf(float(i0) * spacing - 0.5f));  // for_each_tap's first column
  const bool shared =
      sv.filtering && spacing < 2.0f && int(floorf(float(i1) * spacing - 0.5f)) + 1 - rows.x0 < kFilterRowTexels;
  Channels<N> sum{};
  for (int j = j0; j <= j1; ++j) {
    if (shared) {  // this row of taps reads texel rows y and y + 1: keep those held
      const int y = floor_int(float(j) * spacing - 0.5f);
      for (int k = 0; k < 2; ++k)
        if (rows.y[k] != y && rows.y[k] != y + 1) {
          rows.y[k] = rows.y[k ^ 1] == y ? y + 1 : y;
          rows.have[k] = 0u;
        }
    }
    for (int i = i0; i <= i1; ++i) {
      ViewProjection at = pr;
      at.u = float(i) * spacing;
      at.v = float(j) * spacing;
      const float du = at.u - pr.u, dv = at.v - pr.v;
      if (du * du + dv * dv > out * out) continue;  // past the rim's ramp along the longer axis too
      const float w = rim_weight(du, dv, angle_of(f, du, dv), radius, spacing);
      if (!(w > 0.0f)) continue;
      weight += w;
      if (sv.penumbra == Penumbra::Estimated && !blocks_receiver(sv, L, m, pr, f, r, t, at)) continue;
      Channels<N> a{};
      for_each_tap(m, at.u, at.v, sv.filtering, [&](int tx, int ty, float tw) {
        // (A texel outside the rows, should a rounding place a tap's
        // texels other than where the rows expect them, is read directly.)
        const int k = rows.y[0] == ty ? 0 : rows.y[1] == ty ? 1 : -1, c = tx - rows.x0;
        if (!shared || k < 0 || c < 0 || c >= kFilterRowTexels) {
          a = a + texel_of<N, Plane>(sv, m, pr, r, t, tx, ty) * tw;
          return;
        }
        if (!(rows.have[k] >> c & 1u)) {
          rows.at[k][c] = texel_of<N, Plane>(sv, m, pr, r, t, tx, ty);
          rows.have[k] |= 1u << c;
        }
        a = a + rows.at[k][c] * tw;
      });
      sum = sum + a * w;
    }
  }
  return sum;
}

// One map's opacity at receiver r from light L with a size: today's lookup
// filtered over the penumbra's ellipse (step 2 above). The taps lie on a
// lattice fixed in the map (points k s, s = the ellipse's longer axis over
// penumbra_taps, at least a texel), weighted by rim_weight: a tap grid
// moving with the receiver would shift whole columns of taps across an
// edge at once (a staircase of about 1 / penumbra_taps per column when
// the taps are several texels apart); on a fixed lattice the taps enter and
// leave one at a time at the rim, with their weights. Penumbrae of half a
// texel to 1.5 blend from the hard lookup.
CDSM_HD inline Vec3 soft_map_alpha_in_colour(const ShadowView& sv, const LightData& L, const DsmMap& m,
                                             const ViewProjection& pr, const Receiver& r) {
  const PenumbraFrame f = penumbra_frame(m, pr);
  const MapTaps t = map_taps(sv, L, m, pr, r);
  const float radius = penumbra_filter_radius(sv, L, m, pr, r, f, t);
  const float reach = radius * max_pixels_per_angle(f);  // the ellipse's longer half-axis, pixels
  if (!(reach >= 0.5f)) return map_alpha_in_colour(sv, m, pr, r, t);
  float weight = 0.0f;
  const Vec3 sum = m.rgb ? (t.plane ? soft_filter<3, true>(sv, L, m, pr, r, f, t, radius, reach, weight)
                                    : soft_filter<3, false>(sv, L, m, pr, r, f, t, radius, reach, weight))
                         : to_rgb(t.plane ? soft_filter<1, true>(sv, L, m, pr, r, f, t, radius, reach, weight)
                                          : soft_filter<1, false>(sv, L, m, pr, r, f, t, radius, reach, weight));
  const Vec3 soft = sum * (1.0f / weight);
  if (reach >= 1.5f) return soft;
  const float s = reach - 0.5f;
  return map_alpha_in_colour(sv, m, pr, r, t) * (1.0f - s) + soft * s;
}

// One map's opacity at r: soft for a light with a size (unless the
// settings say hard), else today's lookup.
CDSM_HD CDSM_INLINE Vec3 light_map_alpha(const ShadowView& sv, const LightData& L, const DsmMap& m,
                                         const ViewProjection& pr, const Receiver& r) {
  if (L.size > 0.0f && sv.penumbra != Penumbra::Hard) return soft_map_alpha_in_colour(sv, L, m, pr, r);
  return map_alpha_in_colour(sv, L, m, pr, r);
}

// Opacity per channel between light L and receiver r from the light's DSMs
// (grey_of() of it: exactly the one value where every channel agrees, grey
// casters, else the channel mean).
CDSM_HD inline Vec3 shadow_alpha(const ShadowView& sv, const LightData& L, const Receiver& r) {
  return combine_maps(sv, L, r.p, [&](uint32_t, const DsmMap& m, const ViewProjection& pr) {
    return light_map_alpha(sv, L, m, pr, r);
  });
}

// A point lookup at p's own depth (volume samples, probes).
CDSM_HD CDSM_INLINE Vec3 shadow_alpha(const ShadowView& sv, const LightData& L, Vec3 p) {
  return shadow_alpha(sv, L, Receiver{p, Vec3{0, 0, 0}, kNoObject});
}

}  // namespace cdsm
