// Visibility per colour channel, written once for N channels (issue "One
// code path per concept"; pbrt-v4's SampledSpectrum is the model): a grey
// map keeps one alpha per node (N = 1, a float), a coloured one three
// (N = 3, a Vec3). Everything above this header — the wedge, the node
// buffers, the light pass's visitor, the lookups — is written over
// Channels<N> with the operations below, which for N = 1 are the plain
// float operations in the same order, so grey maps stay bit for bit what
// the scalar code made.
#pragma once

#include "cdsm/math.h"

namespace cdsm {

template <int N>
struct ChannelsOf;
template <>
struct ChannelsOf<1> {
  using type = float;
};
template <>
struct ChannelsOf<3> {
  using type = Vec3;
};
template <int N>
using Channels = typename ChannelsOf<N>::type;

// Channel k of a value (a float has only channel 0).
CDSM_HD CDSM_INLINE float channel(float a, int) { return a; }
CDSM_HD CDSM_INLINE float channel(const Vec3& v, int k) { return v[k]; }
CDSM_HD CDSM_INLINE void set_channel(float& a, int, float v) { a = v; }
CDSM_HD CDSM_INLINE void set_channel(Vec3& a, int k, float v) { a[k] = v; }

CDSM_HD CDSM_INLINE float max_channel(float a) { return a; }
CDSM_HD CDSM_INLINE float min_channel(float a) { return a; }
CDSM_HD CDSM_INLINE float one_minus(float a) { return 1.0f - a; }
CDSM_HD CDSM_INLINE float channel_max(float a, float b) { return fmaxf(a, b); }
CDSM_HD CDSM_INLINE Vec3 channel_max(Vec3 a, Vec3 b) { return vmax(a, b); }
CDSM_HD CDSM_INLINE float clamp01(float a) { return clampf(a, 0.0f, 1.0f); }
CDSM_HD CDSM_INLINE Vec3 clamp01(Vec3 a) { return {clamp01(a.x), clamp01(a.y), clamp01(a.z)}; }
CDSM_HD CDSM_INLINE float abs_channels(float a) { return fabsf(a); }
CDSM_HD CDSM_INLINE Vec3 abs_channels(Vec3 a) { return {fabsf(a.x), fabsf(a.y), fabsf(a.z)}; }
// a + (b - a) t per channel.
CDSM_HD CDSM_INLINE Vec3 lerpf(Vec3 a, Vec3 b, float t) {
  return {lerpf(a.x, b.x, t), lerpf(a.y, b.y, t), lerpf(a.z, b.z, t)};
}
// Whether a is above b in some channel.
CDSM_HD CDSM_INLINE bool rises(float a, float b) { return a > b; }
CDSM_HD CDSM_INLINE bool rises(Vec3 a, Vec3 b) { return a.x > b.x || a.y > b.y || a.z > b.z; }
CDSM_HD CDSM_INLINE bool same_channels(float a, float b) { return a == b; }
CDSM_HD CDSM_INLINE bool same_channels(Vec3 a, Vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

// An RGB quantity (a material's absorption, an extinction) in N channels:
// the three themselves, or for a grey map their one value (grey_of: exact
// for a grey triple, the channel mean of a coloured one, ShadowSettings::
// rgb_maps).
template <int N>
CDSM_HD CDSM_INLINE Channels<N> from_rgb(Vec3 v);
template <>
CDSM_HD CDSM_INLINE float from_rgb<1>(Vec3 v) {
  return grey_of(v);
}
template <>
CDSM_HD CDSM_INLINE Vec3 from_rgb<3>(Vec3 v) {
  return v;
}
// And back: a grey value in every channel.
CDSM_HD CDSM_INLINE Vec3 to_rgb(float a) { return vec3(a); }
CDSM_HD CDSM_INLINE Vec3 to_rgb(Vec3 a) { return a; }

}  // namespace cdsm
