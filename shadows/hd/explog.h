// exp(x) and ln(x) in single precision, the same bits on CPU threads and
// on a GPU.
//
// The walk's nodes depend on every transmittance along a ray: one ulp of a
// medium's or a volume sample's exp changes where the compressor puts a
// node. glibc's expf and CUDA's libdevice expf differ in the last bit for
// some inputs, so the light pass, camera pass and baselines call expf_hd
// and logf_hd: range reduction and a polynomial, every step an explicit
// fused multiply-add, a plain product or a quotient (IEEE-754 rounds each
// exactly, on both sides). Their accuracy is asserted in
// tests/unit/test_explog.cpp (every 64th float; CDSM_EXPLOG_STRIDE=1 for
// all of them). Measured over every float (2026-12-03):
//   expf_hd, 2,239,889,410 inputs in [-104, 89]: at most 1 ulp from the
//     correctly rounded value, relative difference from glibc's expf at
//     most 1.19e-7, 99.54% of results bit-identical to glibc's;
//   logf_hd, 2,139,095,039 positive finite inputs: at most 2 ulp, at most
//     2.38e-7 from glibc's logf, 99.16% bit-identical.
// On one x86-64 core an expf_hd call takes ~8 ns against glibc's ~9.6 ns.
// They need IEEE division and no contraction of their own (every sum is
// already an explicit fma): never build them with --use_fast_math.
// (powf in hd/shading.h stays the platform's: it shades, it builds no node.)
#pragma once

#include <cstdint>

#include "cdsm/config.h"
#include "hd/bits.h"

#if !defined(__CUDACC__)
#include <cmath>
#endif

namespace cdsm {

// Where g++ targets x86-64 without FMA, the host copy is compiled twice
// (FMA instructions / libm's fmaf) and the loader picks one for the CPU:
// both round a*b+c once, so both give the same bits. Not with clang: clang
// 14 emits the resolver of an inline multi-versioned function as a strong
// symbol, so two units that call expf_hd fail to link ("multiple definition
// of cdsm::expf_hd(float) [clone .resolver]", the fuzz build); there the
// host copy calls libm's fmaf, slower and the same bits.
#if !defined(__CUDACC__) && defined(__x86_64__) && !defined(__FMA__) && defined(__GNUC__) && !defined(__clang__)
#define CDSM_FMA_CLONES __attribute__((target_clones("fma", "default")))
#else
#define CDSM_FMA_CLONES
#endif

namespace exp_detail {

CDSM_HD CDSM_INLINE float fma_hd(float a, float b, float c) {
#if defined(__CUDACC__)
  return fmaf(a, b, c);  // device: one FFMA; host side of a .cu: libm's fmaf
#else
  return __builtin_fmaf(a, b, c);
#endif
}

// 2^k as a float, for k in [-126, 127].
CDSM_HD CDSM_INLINE float pow2(int k) { return bits_float(uint32_t(k + 127) << 23); }

}  // namespace exp_detail

CDSM_FMA_CLONES CDSM_HD inline float expf_hd(float x) {
  using exp_detail::fma_hd;
  // Below ln(2^-150) every result rounds to 0; above ln(FLT_MAX) to inf.
  if (!(x > -104.0f)) return x != x ? x : 0.0f;  // NaN stays NaN; -inf -> 0
  if (x > 89.0f) return x * 1e30f;               // +inf (overflows like expf)
  // x = n ln2 + r, |r| <= ln2/2 (+ a rounding of x log2e): ln2 in two parts,
  // the high one with 16 bits so n * ln2_hi is exact for |n| <= 256.
  const float n = rintf(x * 1.44269502f);
  float r = fma_hd(n, -0.693145751953125f, x);
  r = fma_hd(n, -1.428606765330187e-6f, r);
  // e^r by its Taylor polynomial of degree 7 (remainder <= 0.35^8/8! =
  // 5.3e-9, 0.09 ulp), Horner with one rounding per step.
  float p = 1.98412698e-4f;          // 1/7!
  p = fma_hd(p, r, 1.38888889e-3f);  // 1/6!
  p = fma_hd(p, r, 8.33333333e-3f);  // 1/5!
  p = fma_hd(p, r, 4.16666667e-2f);  // 1/4!
  p = fma_hd(p, r, 1.66666667e-1f);  // 1/3!
  p = fma_hd(p, r, 0.5f);
  p = fma_hd(p, r, 1.0f);
  p = fma_hd(p, r, 1.0f);
  // p 2^n in two exact halves, so a subnormal result is rounded once.
  const int k = int(n);
  const int k1 = k / 2;
  return p * exp_detail::pow2(k1) * exp_detail::pow2(k - k1);
}

// ln(x): x = 2^e m with m in [sqrt(1/2), sqrt(2)), ln m = 2 atanh(s) with
// s = (m - 1)/(m + 1), |s| <= 0.1716, by its odd series to s^9 (remainder
// 2 s^11/11 <= 7e-10 relative), ln x = e ln2 + ln m with ln2 in two parts.
CDSM_FMA_CLONES CDSM_HD inline float logf_hd(float x) {
  using exp_detail::fma_hd;
  if (!(x > 0.0f)) return x == 0.0f ? -1e30f * 1e30f : (x - x) / (x - x);  // 0 -> -inf; < 0, NaN -> NaN
  if (x == x * 2.0f) return x;                                             // +inf
  uint32_t u = float_bits(x);
  int e = -127;
  if (u < 0x00800000u) {             // subnormal: into the normal range first
    u = float_bits(x * 8388608.0f);  // 2^23
    e -= 23;
  }
  // Exponent and mantissa split at sqrt(1/2) (bits 0x3f3504f3), not at 1.
  u += 0x3f800000u - 0x3f3504f3u;
  e += int(u >> 23);
  const float m = bits_float((u & 0x007fffffu) + 0x3f3504f3u);
  const float s = (m - 1.0f) / (m + 1.0f);
  const float s2 = s * s;
  float q = 0.111111111f;           // 1/9
  q = fma_hd(q, s2, 0.142857143f);  // 1/7
  q = fma_hd(q, s2, 0.2f);
  q = fma_hd(q, s2, 0.333333333f);  // 1/3
  // ln m = 2s + 2s s2 q, the small term added last
  const float two_s = 2.0f * s;
  const float ln_m = fma_hd(two_s * s2, q, two_s);
  const float fe = float(e);
  return fma_hd(fe, 0.693145751953125f, fma_hd(fe, 1.428606765330187e-6f, ln_m));
}

}  // namespace cdsm
