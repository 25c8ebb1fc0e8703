// expf_hd and logf_hd (shadows/hd/explog.h), the exp and ln that the walk,
// the camera pass and the baselines use on CPU threads and on a GPU alike
// (issue 27 item 3): accuracy over their whole input range against the
// correctly rounded result (exp in double, rounded once) and against
// glibc's expf/logf, special values, and monotonicity where the range
// reduction switches from one power of two to the next.
//
// The sweep visits every 64th float (every 512th under sanitizers);
// CDSM_EXPLOG_STRIDE=1 visits them all (about 3 minutes).
#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "hd/explog.h"
#include "common/sanitized.h"

using namespace cdsm;

namespace {

float float_of(uint32_t u) {
  float f;
  std::memcpy(&f, &u, sizeof f);
  return f;
}

uint32_t bits_of(float f) {
  uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
}

// Position on the number line in ulps (monotone in the float's value).
int64_t ulp_index(float f) {
  int32_t i;
  std::memcpy(&i, &f, sizeof i);
  return i < 0 ? int64_t(INT32_MIN) - i : int64_t(i);
}

uint32_t stride_from_environment() {
  if (const char* s = std::getenv("CDSM_EXPLOG_STRIDE")) return uint32_t(std::max(1, std::atoi(s)));
  return CDSM_TEST_SANITIZED ? 512 : 64;
}

const uint32_t kStride = stride_from_environment();

struct Sweep {
  int64_t max_ulps = 0;       // against the correctly rounded result
  float worst = 0.0f;         // an input where max_ulps is reached
  double max_rel_libm = 0.0;  // |f - libm| / |libm|, libm's result normal and non-zero
  uint64_t same_as_libm = 0;  // bit-identical to glibc
  uint64_t count = 0;
};

template <class F, class Exact, class Libm>
Sweep sweep(uint32_t first, uint64_t end, F f, Exact exact, Libm libm, float lo, float hi) {
  Sweep s;
  for (uint64_t u = first; u < end; u += kStride) {
    const float x = float_of(uint32_t(u));
    if (!(x >= lo && x <= hi)) continue;
    const float y = f(x), c = exact(x), l = libm(x);
    const int64_t d = std::llabs(ulp_index(y) - ulp_index(c));
    if (d > s.max_ulps) s.max_ulps = d, s.worst = x;
    if (std::fabs(l) >= FLT_MIN && std::isfinite(l))
      s.max_rel_libm = std::max(s.max_rel_libm, std::fabs(double(y) - double(l)) / std::fabs(double(l)));
    s.same_as_libm += bits_of(y) == bits_of(l);
    ++s.count;
  }
  return s;
}

void report(const char* name, const Sweep& s) {
  std::printf(
      "%s: %llu inputs (every %u-th float): max %lld ulp from the rounded exact value (at %a), "
      "max relative difference from glibc %.3g, bit-identical to glibc %.3f%%\n",
      name, (unsigned long long)s.count, kStride, (long long)s.max_ulps, double(s.worst), s.max_rel_libm,
      100.0 * double(s.same_as_libm) / double(s.count));
}

// Every float in [-104, 89] (below, exp rounds to 0; above, to inf): at most
// 1 ulp from the correctly rounded exp, subnormal results included (their
// ulp is 2^-149), within 2^-22 relative of glibc's expf.
TEST(ExpHd, WithinOneUlpOverItsWholeRange) {
  auto exact = [](float x) { return float(std::exp(double(x))); };
  auto libm = [](float x) { return std::exp(x); };
  const Sweep neg = sweep(0x80000000u, 0x100000000ull, expf_hd, exact, libm, -104.0f, 89.0f);
  const Sweep pos = sweep(0u, 0x80000000ull, expf_hd, exact, libm, -104.0f, 89.0f);
  report("expf_hd x < 0", neg);
  report("expf_hd x >= 0", pos);
  EXPECT_GT(neg.count + pos.count, 2'000'000'000ull / kStride);
  EXPECT_LE(neg.max_ulps, 1) << "at x = " << neg.worst;
  EXPECT_LE(pos.max_ulps, 1) << "at x = " << pos.worst;
  EXPECT_LE(std::max(neg.max_rel_libm, pos.max_rel_libm), 0x1p-22);  // measured over every input: 1.19e-7
}

// Every positive finite float, subnormals included: at most 2 ulp from the
// correctly rounded ln (the largest relative error is near x = 1, where ln
// is small), within 2^-21 relative of glibc's logf.
TEST(LogHd, WithinTwoUlpOverItsWholeRange) {
  auto exact = [](float x) { return float(std::log(double(x))); };
  auto libm = [](float x) { return std::log(x); };
  const Sweep s = sweep(1u, 0x7f800000ull, logf_hd, exact, libm, 0.0f, FLT_MAX);
  report("logf_hd", s);
  EXPECT_GT(s.count, 2'000'000'000ull / kStride);
  EXPECT_LE(s.max_ulps, 2) << "at x = " << s.worst;
  EXPECT_LE(s.max_rel_libm, 0x1p-21);  // measured over every input: 2.38e-7
}

TEST(ExpHd, SpecialValues) {
  EXPECT_TRUE(std::isnan(expf_hd(NAN)));
  EXPECT_EQ(expf_hd(INFINITY), INFINITY);
  EXPECT_EQ(expf_hd(-INFINITY), 0.0f);
  EXPECT_EQ(expf_hd(0.0f), 1.0f);
  EXPECT_EQ(expf_hd(-0.0f), 1.0f);
  EXPECT_EQ(expf_hd(88.8f), INFINITY);  // above ln(FLT_MAX) = 88.7228
  EXPECT_EQ(expf_hd(1e30f), INFINITY);
  EXPECT_EQ(expf_hd(-1e30f), 0.0f);
  EXPECT_EQ(expf_hd(-103.98f), 0.0f);         // below ln(2^-150)
  EXPECT_EQ(expf_hd(-103.2789f), 0x1p-149f);  // the smallest subnormal
  EXPECT_TRUE(std::isfinite(expf_hd(88.72f)));
}

TEST(LogHd, SpecialValues) {
  EXPECT_TRUE(std::isnan(logf_hd(NAN)));
  EXPECT_TRUE(std::isnan(logf_hd(-1.0f)));
  EXPECT_TRUE(std::isnan(logf_hd(-INFINITY)));
  EXPECT_EQ(logf_hd(0.0f), -INFINITY);
  EXPECT_EQ(logf_hd(-0.0f), -INFINITY);
  EXPECT_EQ(logf_hd(INFINITY), INFINITY);
  EXPECT_EQ(logf_hd(1.0f), 0.0f);
  EXPECT_EQ(logf_hd(2.0f), float(std::log(2.0)));
  EXPECT_NEAR(logf_hd(0x1p-149f), -103.27893f, 1e-4f);
}

// A transmittance exp(-sigma d) must not rise as d grows: the walk's alpha
// is monotone only if exp is. Checked ulp by ulp around every switch of the
// range reduction (x log2e = k + 1/2), where a polynomial could jump.
TEST(ExpHd, MonotoneAcrossRangeReductionSwitches) {
  for (int k = -150; k <= 127; ++k) {
    const float x0 = (float(k) + 0.5f) / 1.44269504f;
    float x = x0;
    for (int i = 0; i < 2000; ++i) x = std::nextafter(x, -INFINITY);
    float prev = expf_hd(x);
    for (int i = 0; i < 4000; ++i) {
      x = std::nextafter(x, INFINITY);
      const float y = expf_hd(x);
      ASSERT_GE(y, prev) << "exp falls between x = " << std::nextafter(x, -INFINITY) << " and " << x;
      prev = y;
    }
  }
}

TEST(LogHd, MonotoneAcrossTheMantissaSplit) {
  // The split at sqrt(1/2) 2^e, for every binade.
  for (int e = -125; e <= 127; ++e) {
    float x = std::ldexp(0.70710678f, e);
    for (int i = 0; i < 2000; ++i) x = std::nextafter(x, 0.0f);
    float prev = logf_hd(x);
    for (int i = 0; i < 4000; ++i) {
      x = std::nextafter(x, INFINITY);
      const float y = logf_hd(x);
      ASSERT_GE(y, prev) << "ln falls at x = " << x;
      prev = y;
    }
  }
}

// exp and ln undo each other to a few ulps (the baselines' threshold
// crossing inverts an exp with a log).
TEST(ExpLogHd, RoundTrip) {
  for (float x = -80.0f; x < 80.0f; x += 0.37f) {
    const float y = logf_hd(expf_hd(x));
    EXPECT_NEAR(y, x, 4.0f * std::fabs(x) * FLT_EPSILON + 1e-6f) << x;
  }
}

}  // namespace
