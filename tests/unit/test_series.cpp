// The reconstructions of the series baselines (shadows/hd/series.h) on
// absorbance distributions with known answers: Fourier opacity maps'
// integral of the truncated series, and the moments' bound, which holds
// for every distribution with those moments — so for the true one.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "hd/baselines.h"
#include "hd/series.h"

namespace cdsm {
namespace {

struct Layer {
  double u, A;  // depth, absorbance
};

double true_absorbance(const std::vector<Layer>& ls, double u) {  // strictly in front of u
  double a = 0.0;
  for (const Layer& l : ls)
    if (l.u < u) a += l.A;
  return a;
}

TEST(Series, PolynomialRootsOfKnownPolynomials) {
  // (x - 0.5)(x + 0.25): 0.5 x^2 scaled; (x-1)(x+1)(x-0.3)(x+0.7)
  double roots[4];
  const double quad[3] = {-0.125 * 2, 0.25 * 2, 1.0 * 2};  // 2 (x^2 + 0.25 x - 0.125)
  ASSERT_EQ(polynomial_real_roots(quad, 2, roots), 2);
  EXPECT_NEAR(std::min(roots[0], roots[1]), -0.5, 1e-14);
  EXPECT_NEAR(std::max(roots[0], roots[1]), 0.25, 1e-14);
  // x^4 + c3 x^3 + ...: roots 1, -1, 0.3, -0.7
  const double r[4] = {1.0, -1.0, 0.3, -0.7};
  double p[5] = {1, 0, 0, 0, 0};
  for (double root : r) {  // multiply by (x - root)
    for (int i = 4; i > 0; --i) p[i] = p[i - 1] - root * p[i];
    p[0] = -root * p[0];
  }
  ASSERT_EQ(polynomial_real_roots(p, 4, roots), 4);
  std::vector<double> got(roots, roots + 4);
  std::sort(got.begin(), got.end());
  EXPECT_NEAR(got[0], -1.0, 1e-12);
  EXPECT_NEAR(got[1], -0.7, 1e-12);
  EXPECT_NEAR(got[2], 0.3, 1e-12);
  EXPECT_NEAR(got[3], 1.0, 1e-12);
}

TEST(Series, FourierKeepsTheTotalAndItsMediumIsTheLimitOfSurfaces) {
  for (int n : {3, 4, 8, 16, 31}) {
    FourierSeries f(n);
    f.add_surface(0.3, 0.7);
    f.add_surface(0.62, 1.1);
    f.add_medium(0.7, 0.9, 2.0);  // absorbance 0.4
    EXPECT_DOUBLE_EQ(f.optical_depth(0.0), 0.0) << n;
    EXPECT_NEAR(f.optical_depth(1.0), 0.7 + 1.1 + 0.4, 1e-12) << n;
    // A medium is the limit of many thin surfaces (midpoint rule).
    FourierSeries m(n), s(n);
    m.add_medium(0.2, 0.5, 3.0);
    const int k = 4000;
    for (int i = 0; i < k; ++i) s.add_surface(0.2 + 0.3 * (i + 0.5) / k, 0.9 / k);
    for (int i = 0; i < n; ++i) EXPECT_NEAR(m.c[i], s.c[i], 2e-5) << "n " << n << " coefficient " << i;
  }
  // Enough terms reproduce a smooth medium: the slab's optical depth rises
  // linearly through it, within the Gibbs ringing at its two ends.
  FourierSeries f(31);
  f.add_medium(0.3, 0.7, 1.0);
  for (double u = 0.0; u <= 1.0; u += 0.01) {
    const double exact = std::min(std::max(u - 0.3, 0.0), 0.4);
    EXPECT_NEAR(f.optical_depth(u), exact, 0.02) << u;
  }
}

TEST(Series, FourierRingingAroundAStepIsBoundedAndTheClampKeepsTransmittance) {
  // A surface of absorbance A at 0.5: the partial sum's optical depth
  // overshoots by a Gibbs share of A on either side (0.0895 of the jump as
  // N grows, 0.0963 at N = 4, measured). The maps' tabulation of it
  // (tabulate_absorbance, what a Fourier map stores) keeps alpha physical:
  // never below 0, never above the total it knows (0.9 here, where the
  // overshoot reaches 1 - exp(-1.0963 A) = 0.92), nondecreasing, ending on
  // the total.
  const double A = std::log(10.0);
  const float total = float(1.0 - std::exp(-A));
  for (int n : {4, 8, 16, 31}) {
    FourierSeries f(n);
    f.add_surface(0.5, A);
    double worst_low = 0.0, worst_high = 0.0;
    for (double u = 0.0; u <= 1.0; u += 0.001) {
      const double tau = f.optical_depth(u);
      worst_low = std::min(worst_low, tau);
      worst_high = std::max(worst_high, tau - A);
    }
    std::vector<DsmNode> storage(512);
    NodeBuffer buf{storage.data(), int(storage.size())};
    tabulate_absorbance(buf, 1.0f, 2.0f, 0.0, 1.0, series_samples(n), A, [&](double u) { return f.optical_depth(u); });
    ASSERT_GT(buf.size(), 1) << n;
    float before = 0.0f;
    for (int i = 0; i < buf.size(); ++i) {
      EXPECT_GE(buf.nodes[i].alpha, before) << n << " node " << i;
      EXPECT_LE(buf.nodes[i].alpha, total) << n << " node " << i;
      before = buf.nodes[i].alpha;
    }
    EXPECT_EQ(buf.nodes[buf.size() - 1].alpha, total) << n;
    EXPECT_EQ(buf.nodes[buf.size() - 1].z, 2.0f) << n;
    EXPECT_GT(worst_low, -0.1 * A) << n;
    EXPECT_LT(worst_high, 0.1 * A) << n;
    EXPECT_GT(worst_high, 0.085 * A) << n;  // and it does ring: the clamp has work to do
    // Far from the step the truncation is close: a quarter of the range away.
    EXPECT_NEAR(f.optical_depth(0.25), 0.0, 0.2 * A / std::max(1, n / 4)) << n;
    EXPECT_NEAR(f.optical_depth(0.75), A, 0.2 * A / std::max(1, n / 4)) << n;
  }
}

// The moment bound, b_0 (lower + w) for w between 0 and u's own weight,
// brackets the true absorbance in front of u for every distribution with
// these moments: lower <= true fraction <= lower + at. With the bias the
// moments move by beta, so the bound may miss, by less than beta itself
// (measured: 2.6e-7 of the total for 4 moments, beta 5e-7; 2.9e-5 for 8,
// beta 5e-5).
TEST(Series, MomentBoundBracketsTheTrueAbsorbance) {
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> U(-1.0, 1.0), Aabs(0.05, 2.0);
  for (int n : {4, 8}) {
    const MomentBias bias = moment_bias(n);
    double worst_below = 0.0, worst_above = 0.0;
    for (int trial = 0; trial < 300; ++trial) {
      std::vector<Layer> ls;
      const int k = 1 + int(rng() % 7);
      for (int i = 0; i < k; ++i) ls.push_back({U(rng), Aabs(rng)});
      PowerMoments m(n);
      for (const Layer& l : ls) m.add_surface(l.u, l.A);
      m.store();
      for (double u = -1.0; u <= 1.0; u += 0.01) {
        bool on_layer = false;
        for (const Layer& l : ls) on_layer = on_layer || std::fabs(l.u - u) < 1e-9;
        if (on_layer) continue;
        double lower, at;
        ASSERT_TRUE(m.bound(u, bias, lower, at));
        const double truth = true_absorbance(ls, u) / m.b[0];
        worst_below = std::max(worst_below, lower - truth);       // the lower bound above the truth
        worst_above = std::max(worst_above, truth - lower - at);  // the upper bound below it
      }
    }
    // The bound's miss, as a share of the total absorbance.
    EXPECT_LT(worst_below, bias.beta) << n;
    EXPECT_LT(worst_above, bias.beta) << n;
  }
}

TEST(Series, MomentsOfAMediumAreTheLimitOfSurfacesAndOneLayerIsAStep) {
  PowerMoments m(8), s(8);
  m.add_medium(-0.4, 0.2, 2.5);
  const int k = 4000;
  for (int i = 0; i < k; ++i) s.add_surface(-0.4 + 0.6 * (i + 0.5) / k, 1.5 / k);
  for (int j = 0; j <= 8; ++j) EXPECT_NEAR(m.b[j], s.b[j], 1e-6) << j;
  // One surface: the bound is a step at it (up to the bias).
  for (int n : {4, 8}) {
    PowerMoments one(n);
    one.add_surface(0.1, 1.0);
    one.store();
    double lower, at;
    const double beta = moment_bias(n).beta;
    one.bound(-0.3, moment_bias(n), lower, at);
    EXPECT_LT(lower + at, 3.0 * beta) << n;  // measured 2.4 beta (4), 0.6 beta (8)
    one.bound(0.5, moment_bias(n), lower, at);
    EXPECT_GT(lower, 1.0 - 3.0 * beta) << n;
  }
}

}  // namespace
}  // namespace cdsm
