// Transmittance from a few numbers per texel, for the baselines
// (hd/baselines.h): the Fourier series of the absorption density along the
// ray (Fourier opacity maps, Jansen & Bavoil 2010) and the power moments of
// the absorbance (moment shadow mapping, Peters & Klein 2015; moment-based
// order-independent transparency, Münstermann et al. 2018).
//
// Both describe the ray's absorbance A (optical depth, -ln(1 - alpha) of a
// surface, sigma dz of a medium) as a density over a depth interval mapped
// to a unit one. The coefficients are summed in double and stored as floats
// (32-bit textures: what an engine keeps), and the reconstruction reads the
// stored floats, in double.
#pragma once

#include <cmath>

#include "hd/compress.h"

namespace cdsm {

// A surface's absorbance is capped where its opacity reaches 0.999 (an
// opaque caster would otherwise make the series' coefficients infinite).
inline constexpr double kMaxSurfaceOpacity = 0.999;
CDSM_HD inline double surface_absorbance(float opacity) {
  const double a = opacity < float(kMaxSurfaceOpacity) ? double(opacity) : kMaxSurfaceOpacity;
  return -log1p(-a);
}

inline constexpr double kTwoPi = 6.283185307179586;

// ---- Fourier opacity maps -----------------------------------------------
// N real coefficients in the order a0, a1, b1, a2, b2, ...: the absorption
// density over d in [0, 1] is
//   sigma(d) ~ a0 / 2 + sum_k a_k cos(2 pi k d) + b_k sin(2 pi k d),
// a_k = 2 integral sigma cos(2 pi k d), b_k = 2 integral sigma sin(...); an
// even N ends on a cosine term. The optical depth in front of d is the
// integral of the partial sum from 0: 0 at d = 0 and exactly the total
// (a0 / 2) at d = 1, whatever N.
inline constexpr int kMaxFourierCoefficients = 32;

struct FourierSeries {
  int n = 0;
  double c[kMaxFourierCoefficients] = {};

  CDSM_HD explicit FourierSeries(int count) : n(count) {}

  // Coefficient i is a cosine (odd i, and a0) or a sine (even i > 0) of
  // frequency k.
  CDSM_HD static int frequency(int i) { return (i + 1) / 2; }
  CDSM_HD static bool is_sine(int i) { return i > 0 && i % 2 == 0; }

  // Absorbance A concentrated at depth d (a surface).
  CDSM_HD void add_surface(double d, double A) {
    c[0] += 2.0 * A;
    for (int i = 1; i < n; ++i) {
      const double w = kTwoPi * frequency(i) * d;
      c[i] += 2.0 * A * (is_sine(i) ? sin(w) : cos(w));
    }
  }
  // A constant absorption density s (absorbance per unit d) over [d0, d1].
  CDSM_HD void add_medium(double d0, double d1, double s) {
    c[0] += 2.0 * s * (d1 - d0);
    for (int i = 1; i < n; ++i) {
      const double w = kTwoPi * frequency(i);
      c[i] += is_sine(i) ? 2.0 * s * (cos(w * d0) - cos(w * d1)) / w : 2.0 * s * (sin(w * d1) - sin(w * d0)) / w;
    }
  }
  CDSM_HD void store() {
    for (int i = 0; i < n; ++i) c[i] = double(float(c[i]));
  }
  // The optical depth in front of d (may dip below 0 or overshoot between
  // the surfaces: the truncation's ringing).
  CDSM_HD double optical_depth(double d) const {
    double tau = 0.5 * c[0] * d;
    const double c1 = cos(kTwoPi * d), s1 = sin(kTwoPi * d);
    double ck = 1.0, sk = 0.0;  // cos, sin of 2 pi k d by rotation
    for (int i = 1; i < n; i += 2) {
      const double t = ck * c1 - sk * s1;
      sk = sk * c1 + ck * s1;
      ck = t;
      const double w = kTwoPi * frequency(i);
      tau += c[i] * sk / w;
      if (i + 1 < n) tau += c[i + 1] * (1.0 - ck) / w;
    }
    return tau;
  }
};

// ---- power moments ------------------------------------------------------
// b_0 = the total absorbance, b_j = sum of A u^j over the ray (u in [-1, 1]
// the depth mapped to the range), j = 1 .. n, n = 4 or 8. The
// reconstruction: the absorbance in front of u is b_0 times a bound of the
// fraction of it in front, from the moments b_j / b_0 — the canonical
// representation through u (the Hamburger bound of moment shadow mapping,
// n = 4, and of MBOIT's eight power moments): support at u and at the roots
// of the kernel polynomial; the lower bound sums the weights of the roots
// in front of u, the upper one adds u's own weight.
inline constexpr int kMaxMoments = 8;

// Before the bound the normalized moments are mixed with those of a fixed
// distribution, (1 - beta) b + beta b_ref, which keeps the Hankel matrix
// positive definite at float precision (otherwise light leaks where the
// reconstruction breaks down). beta and b_ref as MBOIT publishes them for
// power moments in 32-bit floats.
struct MomentBias {
  double beta = 0.0;
  double ref[kMaxMoments] = {};  // b_ref_1 .. b_ref_n (the odd ones 0)
};
// (By value, not a table: device code reads no host constants.)
CDSM_HD inline MomentBias moment_bias(int n) {
  MomentBias b;
  if (n <= 4) {
    b.beta = 5e-7;
    b.ref[1] = b.ref[3] = 0.375;
  } else {
    b.beta = 5e-5;
    b.ref[1] = 0.75;
    b.ref[3] = 0.676666666666667;
    b.ref[5] = 0.63;
    b.ref[7] = 0.600303030303030;
  }
  return b;
}
// Which point between the bound's two sides the shadow takes: the lower
// bound of the absorbance in front (0), plus this share of u's own weight.
// Shadows take the bound, as moment shadow mapping does: the transmittance
// is never below the truth by more than the bias allows (light may leak,
// a caster never shadows itself). MBOIT's transparency takes 0.25; on the
// default scene's opaque casters that share of their own front surface
// darkens them (transmittance RMSE 0.087 with 0, 0.162 with 0.25, mom4 at
// 256², measured).
inline constexpr double kMomentOverestimation = 0.0;

// The real roots of sum_i p[i] x^i (degree `deg` <= kMaxMoments / 2, all
// real: a kernel polynomial of a positive definite Hankel matrix) into
// `roots`; returns how many.
CDSM_HD inline int polynomial_real_roots(const double* p, int deg, double* roots) {
  double q[kMaxMoments / 2 + 1];
  while (deg > 0 && p[deg] == 0.0) --deg;
  for (int i = 0; i <= deg; ++i) q[i] = p[i] / p[deg];
  int found = 0;
  while (deg > 2) {  // Laguerre's method (cubic convergence for real-rooted polynomials), then deflate
    double x = 0.0;
    for (int it = 0; it < 80; ++it) {
      double v = q[deg], d1 = 0.0, d2 = 0.0;
      for (int i = deg - 1; i >= 0; --i) {
        d2 = d2 * x + d1;
        d1 = d1 * x + v;
        v = v * x + q[i];
      }
      if (v == 0.0) break;
      const double g = d1 / v, h = g * g - 2.0 * d2 / v;
      const double disc = sqrt(fmax(0.0, (deg - 1) * (deg * h - g * g)));
      const double den = fabs(g + disc) >= fabs(g - disc) ? g + disc : g - disc;
      const double step = den != 0.0 ? deg / den : 1e-3;
      x -= step;
      if (fabs(step) <= 1e-15 * (1.0 + fabs(x))) break;
    }
    roots[found++] = x;
    double carry = q[deg];  // divide by (x - root)
    for (int i = deg - 1; i >= 0; --i) {
      const double t = q[i];
      q[i] = carry;
      carry = t + carry * x;
    }
    --deg;
  }
  if (deg == 2) {
    const double disc = sqrt(fmax(0.0, q[1] * q[1] - 4.0 * q[0]));
    const double t = -0.5 * (q[1] + (q[1] >= 0.0 ? disc : -disc));
    roots[found++] = t;
    roots[found++] = t != 0.0 ? q[0] / t : 0.0;
  } else if (deg == 1) {
    roots[found++] = -q[0];
  }
  return found;
}

struct PowerMoments {
  int n = 0;                       // power moments beside b_0: 4 or 8
  double b[kMaxMoments + 1] = {};  // b_0 .. b_n

  CDSM_HD explicit PowerMoments(int count) : n(count) {}

  CDSM_HD void add_surface(double u, double A) {
    double p = 1.0;
    for (int j = 0; j <= n; ++j, p *= u) b[j] += A * p;
  }
  // A constant absorption density s (absorbance per unit u) over [u0, u1].
  CDSM_HD void add_medium(double u0, double u1, double s) {
    double p0 = u0, p1 = u1;
    for (int j = 0; j <= n; ++j, p0 *= u0, p1 *= u1) b[j] += s * (p1 - p0) / double(j + 1);
  }
  CDSM_HD void store() {
    for (int j = 0; j <= n; ++j) b[j] = double(float(b[j]));
  }

  // The share of the absorbance in front of u: `lower` (the bound) and
  // `at` (the weight the canonical representation puts at u itself).
  // False when the moments are empty.
  CDSM_HD bool bound(double u, const MomentBias& bias, double& lower, double& at) const {
    lower = 0.0;
    at = 0.0;
    if (!(b[0] > 0.0)) return false;
    const int m = n / 2;
    double mu[kMaxMoments + 1];
    mu[0] = 1.0;
    for (int j = 1; j <= n; ++j) mu[j] = (1.0 - bias.beta) * b[j] / b[0] + bias.beta * bias.ref[j - 1];
    // Cholesky factor of the Hankel matrix H_ij = mu_{i+j}, i, j <= m.
    double L[kMaxMoments / 2 + 1][kMaxMoments / 2 + 1] = {};
    for (int i = 0; i <= m; ++i)
      for (int j = 0; j <= i; ++j) {
        double s = mu[i + j];
        for (int k = 0; k < j; ++k) s -= L[i][k] * L[j][k];
        if (i == j) {
          if (!(s > 0.0)) s = 1e-300;  // only a degenerate store gets here
          L[i][i] = sqrt(s);
        } else {
          L[i][j] = s / L[j][j];
        }
      }
    // Solves H c = v(x), v(x) = (1, x, .., x^m); returns v(x) . c.
    auto solve = [&](double x, double* c) {
      double v[kMaxMoments / 2 + 1], y[kMaxMoments / 2 + 1];
      double p = 1.0;
      for (int i = 0; i <= m; ++i, p *= x) v[i] = p;
      for (int i = 0; i <= m; ++i) {
        double s = v[i];
        for (int k = 0; k < i; ++k) s -= L[i][k] * y[k];
        y[i] = s / L[i][i];
      }
      double q = 0.0;
      for (int i = m; i >= 0; --i) {
        double s = y[i];
        for (int k = i + 1; k <= m; ++k) s -= L[k][i] * c[k];
        c[i] = s / L[i][i];
        q += y[i] * y[i];
      }
      return q;
    };
    double kernel[kMaxMoments / 2 + 1], scratch[kMaxMoments / 2 + 1], roots[kMaxMoments / 2];
    at = 1.0 / solve(u, kernel);
    const int r = polynomial_real_roots(kernel, m, roots);
    for (int i = 0; i < r; ++i)
      if (roots[i] < u) lower += 1.0 / solve(roots[i], scratch);
    lower = fmin(fmax(lower, 0.0), 1.0);
    at = fmin(fmax(at, 0.0), 1.0 - lower);
    return true;
  }
};

}  // namespace cdsm
