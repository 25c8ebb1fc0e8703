// Small POD vector/matrix math for CDSM_HD code (no GLM in device code).
// Column vectors; Mat4 is row-major: m[row][col] (GL and GLM store
// column-major: transpose when handing a Mat4 to either).
#pragma once

#include <cmath>
#include <cstdint>

#include "cdsm/config.h"

namespace cdsm {

// fminf / fmaxf for host code: glibc's are out-of-line calls (GCC inlines
// them only under -ffinite-math-only), a tenth of the light pass's time in
// volume marches. These return what glibc's functions return (x86-64:
// minss / maxss, a NaN operand ignored, the second operand of an equal pair
// such as 0 and -0), inline.
// Unqualified calls inside namespace cdsm find them before ::fminf; the
// device pass of nvcc keeps CUDA's own.
#if !defined(__CUDA_ARCH__)
CDSM_HD CDSM_INLINE float fminf(float a, float b) { return (a < b || b != b) ? a : b; }
CDSM_HD CDSM_INLINE float fmaxf(float a, float b) { return (a > b || b != b) ? a : b; }
#endif

// int(floorf(x)) for x within int's range (texel indices), the same value:
// on x86-64 without SSE4.1 floorf is a libm call or a long inline sequence,
// here a truncation and one compare (a float of 2^24 or more is an integer,
// so float(i) is exact wherever it matters).
CDSM_HD CDSM_INLINE int floor_int(float x) {
#if defined(__CUDA_ARCH__)
  return int(floorf(x));
#else
  const int i = int(x);
  return x < float(i) ? i - 1 : i;
#endif
}

// The least k >= 0 with 2^k >= n (n >= 1): 0 for 1, 1 for 2, 2 for 3 and 4, ...
CDSM_HD CDSM_INLINE int ceil_log2(uint32_t n) {
#if defined(__CUDA_ARCH__)
  return n <= 1u ? 0 : 32 - __clz(int(n - 1u));
#else
  return n <= 1u ? 0 : 32 - __builtin_clz(n - 1u);
#endif
}

struct Vec2 {
  float x = 0, y = 0;
};

struct Vec3 {
  float x = 0, y = 0, z = 0;
  CDSM_HD constexpr float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  CDSM_HD float& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
};

struct Vec4 {
  float x = 0, y = 0, z = 0, w = 0;
};

CDSM_HD CDSM_INLINE Vec3 vec3(float x, float y, float z) { return Vec3{x, y, z}; }
CDSM_HD CDSM_INLINE Vec3 vec3(float s) { return Vec3{s, s, s}; }
CDSM_HD CDSM_INLINE Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
CDSM_HD CDSM_INLINE Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
CDSM_HD CDSM_INLINE Vec3 operator-(Vec3 a) { return {-a.x, -a.y, -a.z}; }
CDSM_HD CDSM_INLINE Vec3 operator*(Vec3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
CDSM_HD CDSM_INLINE Vec3 operator*(float s, Vec3 a) { return {a.x * s, a.y * s, a.z * s}; }
CDSM_HD CDSM_INLINE Vec3 operator*(Vec3 a, Vec3 b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
CDSM_HD CDSM_INLINE Vec3 operator/(Vec3 a, float s) { return a * (1.0f / s); }
CDSM_HD CDSM_INLINE Vec3& operator+=(Vec3& a, Vec3 b) { return a = a + b; }
CDSM_HD CDSM_INLINE Vec3& operator*=(Vec3& a, float s) { return a = a * s; }
CDSM_HD CDSM_INLINE float dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
CDSM_HD CDSM_INLINE Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
CDSM_HD CDSM_INLINE float length(Vec3 a) { return sqrtf(dot(a, a)); }
CDSM_HD CDSM_INLINE Vec3 normalize(Vec3 a) {
  float l = length(a);
  return l > 0.0f ? a * (1.0f / l) : a;
}
CDSM_HD CDSM_INLINE Vec3 vmin(Vec3 a, Vec3 b) { return {fminf(a.x, b.x), fminf(a.y, b.y), fminf(a.z, b.z)}; }
CDSM_HD CDSM_INLINE Vec3 vmax(Vec3 a, Vec3 b) { return {fmaxf(a.x, b.x), fmaxf(a.y, b.y), fmaxf(a.z, b.z)}; }
CDSM_HD CDSM_INLINE float clampf(float v, float lo, float hi) { return fminf(fmaxf(v, lo), hi); }

// Colour channels (RGB transmittance, issue "Coloured shadows").
CDSM_HD CDSM_INLINE float max_channel(Vec3 a) { return fmaxf(a.x, fmaxf(a.y, a.z)); }
CDSM_HD CDSM_INLINE float min_channel(Vec3 a) { return fminf(a.x, fminf(a.y, a.z)); }
CDSM_HD CDSM_INLINE bool is_grey(Vec3 a) { return a.x == a.y && a.y == a.z; }
// The one value of a grey triple (exactly), else the channel mean.
CDSM_HD CDSM_INLINE float grey_of(Vec3 a) { return is_grey(a) ? a.x : (a.x + a.y + a.z) * (1.0f / 3.0f); }
CDSM_HD CDSM_INLINE Vec3 one_minus(Vec3 a) { return {1.0f - a.x, 1.0f - a.y, 1.0f - a.z}; }
CDSM_HD CDSM_INLINE float lerpf(float a, float b, float t) { return a + (b - a) * t; }
// True unless NaN or +-Inf (x - x is NaN exactly then); works on both sides.
CDSM_HD CDSM_INLINE bool is_finite(float x) { return (x - x) == 0.0f; }
CDSM_HD CDSM_INLINE bool is_finite(Vec3 a) { return is_finite(a.x) && is_finite(a.y) && is_finite(a.z); }

// Axis-aligned box.
struct Box3 {
  Vec3 lo{1e30f, 1e30f, 1e30f};
  Vec3 hi{-1e30f, -1e30f, -1e30f};
  CDSM_HD void grow(Vec3 p) {
    lo = vmin(lo, p);
    hi = vmax(hi, p);
  }
  CDSM_HD void grow(const Box3& b) {
    lo = vmin(lo, b.lo);
    hi = vmax(hi, b.hi);
  }
  CDSM_HD bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  CDSM_HD Vec3 center() const { return (lo + hi) * 0.5f; }
  CDSM_HD Vec3 extent() const { return hi - lo; }
  CDSM_HD Vec3 corner(int i) const { return {(i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z}; }
};

// Row-major 4x4 matrix acting on column vectors.
struct Mat4 {
  float m[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};

  CDSM_HD static Mat4 identity() { return Mat4{}; }
  CDSM_HD Vec3 point(Vec3 p) const {  // affine transform of a point (w = 1, no divide)
    return {m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
            m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
            m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3]};
  }
  CDSM_HD Vec3 vector(Vec3 v) const {  // linear part only
    return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z, m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
  }
  CDSM_HD Vec4 apply(Vec4 v) const {
    return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z + m[0][3] * v.w,
            m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z + m[1][3] * v.w,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z + m[2][3] * v.w,
            m[3][0] * v.x + m[3][1] * v.y + m[3][2] * v.z + m[3][3] * v.w};
  }
};

CDSM_HD CDSM_INLINE Mat4 operator*(const Mat4& a, const Mat4& b) {
  Mat4 r;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      float s = 0.0f;
      for (int k = 0; k < 4; ++k) s += a.m[i][k] * b.m[k][j];
      r.m[i][j] = s;
    }
  return r;
}

CDSM_HD CDSM_INLINE Mat4 transpose(const Mat4& a) {
  Mat4 r;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) r.m[i][j] = a.m[j][i];
  return r;
}

// Determinant of the upper-left 3x3 (linear) block: < 0 means the
// transform mirrors, which reverses the winding of the triangles it maps.
CDSM_HD CDSM_INLINE float det3(const Mat4& a) {
  return a.m[0][0] * (a.m[1][1] * a.m[2][2] - a.m[1][2] * a.m[2][1]) -
         a.m[0][1] * (a.m[1][0] * a.m[2][2] - a.m[1][2] * a.m[2][0]) +
         a.m[0][2] * (a.m[1][0] * a.m[2][1] - a.m[1][1] * a.m[2][0]);
}

// Whether the transform mirrors, decided on the linear block scaled to unit
// size, so tiny or huge transforms keep their sign (det3 would under- or
// overflow).
CDSM_HD CDSM_INLINE bool mirrors(const Mat4& a) {
  float s = 0.0f;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) s = fmaxf(s, fabsf(a.m[i][j]));
  if (!(s > 0.0f)) return false;
  Mat4 n = a;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) n.m[i][j] = a.m[i][j] / s;
  return det3(n) < 0.0f;
}

// Inverse of an affine matrix (last row 0 0 0 1), scale-normalized so that
// transforms of any magnitude float can hold invert (scale 1e-30 or 1e20:
// the plain cofactors would under- or overflow): A = s N, A^-1 = N^-1 / s.
// Returns false (and identity) when N is singular (det N = 0: the transform
// flattens space) or the inverse does not fit in float.
CDSM_HD inline bool invert_affine(const Mat4& a, Mat4& out) {
  float s = 0.0f;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) s = fmaxf(s, fabsf(a.m[i][j]));
  out = Mat4{};
  if (!(s > 0.0f) || !(s < 3.0e38f)) return false;
  float n[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) n[i][j] = a.m[i][j] / s;
  float c00 = n[1][1] * n[2][2] - n[1][2] * n[2][1], c01 = n[1][2] * n[2][0] - n[1][0] * n[2][2],
        c02 = n[1][0] * n[2][1] - n[1][1] * n[2][0];
  float det = n[0][0] * c00 + n[0][1] * c01 + n[0][2] * c02;
  if (!(fabsf(det) > 0.0f)) return false;
  float inv[3][3] = {{c00, n[0][2] * n[2][1] - n[0][1] * n[2][2], n[0][1] * n[1][2] - n[0][2] * n[1][1]},
                     {c01, n[0][0] * n[2][2] - n[0][2] * n[2][0], n[0][2] * n[1][0] - n[0][0] * n[1][2]},
                     {c02, n[0][1] * n[2][0] - n[0][0] * n[2][1], n[0][0] * n[1][1] - n[0][1] * n[1][0]}};
  const float k = 1.0f / (det * s);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out.m[i][j] = inv[i][j] * k;
  for (int i = 0; i < 3; ++i)
    out.m[i][3] = -(out.m[i][0] * a.m[0][3] + out.m[i][1] * a.m[1][3] + out.m[i][2] * a.m[2][3]);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j)
      if (!is_finite(out.m[i][j])) {
        out = Mat4{};
        return false;
      }
  return true;
}

// General inverse by cofactors (affine matrices: invert_affine); returns
// false (and identity) if singular.
CDSM_HD inline bool invert(const Mat4& a, Mat4& out) {
  if (a.m[3][0] == 0.0f && a.m[3][1] == 0.0f && a.m[3][2] == 0.0f && a.m[3][3] == 1.0f) return invert_affine(a, out);
  const float* s = &a.m[0][0];
  float inv[16];
  inv[0] = s[5] * s[10] * s[15] - s[5] * s[11] * s[14] - s[9] * s[6] * s[15] + s[9] * s[7] * s[14] +
           s[13] * s[6] * s[11] - s[13] * s[7] * s[10];
  inv[4] = -s[4] * s[10] * s[15] + s[4] * s[11] * s[14] + s[8] * s[6] * s[15] - s[8] * s[7] * s[14] -
           s[12] * s[6] * s[11] + s[12] * s[7] * s[10];
  inv[8] = s[4] * s[9] * s[15] - s[4] * s[11] * s[13] - s[8] * s[5] * s[15] + s[8] * s[7] * s[13] +
           s[12] * s[5] * s[11] - s[12] * s[7] * s[9];
  inv[12] = -s[4] * s[9] * s[14] + s[4] * s[10] * s[13] + s[8] * s[5] * s[14] - s[8] * s[6] * s[13] -
            s[12] * s[5] * s[10] + s[12] * s[6] * s[9];
  inv[1] = -s[1] * s[10] * s[15] + s[1] * s[11] * s[14] + s[9] * s[2] * s[15] - s[9] * s[3] * s[14] -
           s[13] * s[2] * s[11] + s[13] * s[3] * s[10];
  inv[5] = s[0] * s[10] * s[15] - s[0] * s[11] * s[14] - s[8] * s[2] * s[15] + s[8] * s[3] * s[14] +
           s[12] * s[2] * s[11] - s[12] * s[3] * s[10];
  inv[9] = -s[0] * s[9] * s[15] + s[0] * s[11] * s[13] + s[8] * s[1] * s[15] - s[8] * s[3] * s[13] -
           s[12] * s[1] * s[11] + s[12] * s[3] * s[9];
  inv[13] = s[0] * s[9] * s[14] - s[0] * s[10] * s[13] - s[8] * s[1] * s[14] + s[8] * s[2] * s[13] +
            s[12] * s[1] * s[10] - s[12] * s[2] * s[9];
  inv[2] = s[1] * s[6] * s[15] - s[1] * s[7] * s[14] - s[5] * s[2] * s[15] + s[5] * s[3] * s[14] + s[13] * s[2] * s[7] -
           s[13] * s[3] * s[6];
  inv[6] = -s[0] * s[6] * s[15] + s[0] * s[7] * s[14] + s[4] * s[2] * s[15] - s[4] * s[3] * s[14] -
           s[12] * s[2] * s[7] + s[12] * s[3] * s[6];
  inv[10] = s[0] * s[5] * s[15] - s[0] * s[7] * s[13] - s[4] * s[1] * s[15] + s[4] * s[3] * s[13] +
            s[12] * s[1] * s[7] - s[12] * s[3] * s[5];
  inv[14] = -s[0] * s[5] * s[14] + s[0] * s[6] * s[13] + s[4] * s[1] * s[14] - s[4] * s[2] * s[13] -
            s[12] * s[1] * s[6] + s[12] * s[2] * s[5];
  inv[3] = -s[1] * s[6] * s[11] + s[1] * s[7] * s[10] + s[5] * s[2] * s[11] - s[5] * s[3] * s[10] - s[9] * s[2] * s[7] +
           s[9] * s[3] * s[6];
  inv[7] = s[0] * s[6] * s[11] - s[0] * s[7] * s[10] - s[4] * s[2] * s[11] + s[4] * s[3] * s[10] + s[8] * s[2] * s[7] -
           s[8] * s[3] * s[6];
  inv[11] = -s[0] * s[5] * s[11] + s[0] * s[7] * s[9] + s[4] * s[1] * s[11] - s[4] * s[3] * s[9] - s[8] * s[1] * s[7] +
            s[8] * s[3] * s[5];
  inv[15] = s[0] * s[5] * s[10] - s[0] * s[6] * s[9] - s[4] * s[1] * s[10] + s[4] * s[2] * s[9] + s[8] * s[1] * s[6] -
            s[8] * s[2] * s[5];
  float det = s[0] * inv[0] + s[1] * inv[4] + s[2] * inv[8] + s[3] * inv[12];
  if (!(fabsf(det) > 1e-30f)) {
    out = Mat4{};
    return false;
  }
  float r = 1.0f / det;
  for (int i = 0; i < 16; ++i) (&out.m[0][0])[i] = inv[i] * r;
  return true;
}

}  // namespace cdsm
