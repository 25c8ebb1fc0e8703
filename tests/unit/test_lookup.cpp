// Deep shadow map lookup (hd/dsm.h, DESIGN.md §2.5): a texel's visibility
// function (exact at nodes, linear between, 0 before, last value after, a
// step read as 'before' at its depth), the hinted search, and the bilinear
// filter of thesis eq. 4.18-4.19 with taps outside the map counting 0.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "hd/dsm.h"

using namespace cdsm;

namespace {

Span<const DsmNode> span(const std::vector<DsmNode>& v) { return {v.data(), v.size()}; }

// Nodes: ramp 1..2 from 0 to 0.2, a step at 2 to 0.5, ramp to 0.9 at 4.
const std::vector<DsmNode> kTexel = {{1.0f, 0.0f}, {2.0f, 0.2f}, {2.0f, 0.5f}, {4.0f, 0.9f}};

}  // namespace

TEST(Lookup, ExactAtNodesLinearBetween) {
  Span<const DsmNode> n = span(kTexel);
  EXPECT_EQ(lookup_alpha(n, 1.0f), 0.0f);
  EXPECT_FLOAT_EQ(lookup_alpha(n, 1.5f), 0.1f);
  EXPECT_FLOAT_EQ(lookup_alpha(n, 1.25f), 0.05f);
  EXPECT_EQ(lookup_alpha(n, 4.0f), 0.9f);
  EXPECT_FLOAT_EQ(lookup_alpha(n, 3.0f), 0.7f);
  EXPECT_FLOAT_EQ(lookup_alpha(n, 2.5f), 0.6f);
}

TEST(Lookup, BeforeFirstAndAfterLast) {
  Span<const DsmNode> n = span(kTexel);
  EXPECT_EQ(lookup_alpha(n, 0.0f), 0.0f);
  EXPECT_EQ(lookup_alpha(n, 0.999f), 0.0f);
  EXPECT_EQ(lookup_alpha(n, -5.0f), 0.0f);
  EXPECT_EQ(lookup_alpha(n, 4.0001f), 0.9f);
  EXPECT_EQ(lookup_alpha(n, 1e30f), 0.9f);
  // A function whose first node is not at zero opacity: 0 before it, its value at it.
  std::vector<DsmNode> s = {{3.0f, 0.4f}, {5.0f, 0.6f}};
  EXPECT_EQ(lookup_alpha(span(s), 2.9999f), 0.0f);
  EXPECT_EQ(lookup_alpha(span(s), 3.0f), 0.4f);
  EXPECT_FLOAT_EQ(lookup_alpha(span(s), 4.0f), 0.5f);
  EXPECT_EQ(lookup_alpha(span(s), 6.0f), 0.6f);
  // Empty texel: nothing on the ray.
  std::vector<DsmNode> none;
  EXPECT_EQ(lookup_alpha(span(none), 1.0f), 0.0f);
  uint32_t hint = 3;
  EXPECT_EQ(lookup_alpha_from(span(none), 1.0f, hint), 0.0f);
}

TEST(Lookup, StepReadsBeforeAtItsDepth) {
  Span<const DsmNode> n = span(kTexel);
  EXPECT_EQ(lookup_alpha(n, 2.0f), 0.2f) << "exactly at a step: the value before it";
  float just_before = std::nextafter(2.0f, 0.0f), just_after = std::nextafter(2.0f, 3.0f);
  EXPECT_NEAR(lookup_alpha(n, just_before), 0.2f, 1e-6f);
  EXPECT_NEAR(lookup_alpha(n, just_after), 0.5f, 1e-6f) << "just after a step: the value after it";
  // A step as the very first thing on the ray (an opaque surface).
  std::vector<DsmNode> s = {{2.0f, 0.0f}, {2.0f, 1.0f}};
  EXPECT_EQ(lookup_alpha(span(s), 2.0f), 0.0f);
  EXPECT_EQ(lookup_alpha(span(s), just_after), 1.0f);
  // Two coincident steps stored as three nodes at one depth.
  std::vector<DsmNode> c = {{1.0f, 0.0f}, {2.0f, 0.1f}, {2.0f, 0.3f}, {2.0f, 0.6f}, {3.0f, 0.6f}};
  EXPECT_EQ(lookup_alpha(span(c), 2.0f), 0.1f);
  EXPECT_EQ(lookup_alpha(span(c), just_after), 0.6f);
}

// lookup_alpha_from equals lookup_alpha for any hint, marching forward,
// backward or jumping, and leaves a hint that is the lower bound.
TEST(Lookup, HintedSearchEqualsBinarySearch) {
  std::mt19937 rng(5u);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int t = 0; t < 2000; ++t) {
    std::vector<DsmNode> n;
    int count = int(u(rng) * 40.0f);
    float z = u(rng) * 3.0f, a = 0.0f;
    for (int i = 0; i < count; ++i) {
      if (u(rng) < 0.2f && !n.empty()) {  // a step at the previous depth
        a = std::min(1.0f, a + 0.2f * u(rng));
      } else {
        z += 0.05f + u(rng);
        a = std::min(1.0f, a + 0.1f * u(rng));
      }
      n.push_back({z, a});
    }
    Span<const DsmNode> s = span(n);
    std::vector<float> queries;
    for (int q = 0; q < 30; ++q) queries.push_back(-1.0f + u(rng) * (z + 3.0f));
    for (const DsmNode& nd : n) queries.push_back(nd.z);  // exactly at nodes (and steps)
    std::vector<float> fwd = queries, bwd = queries;
    std::sort(fwd.begin(), fwd.end());
    std::sort(bwd.begin(), bwd.end(), std::greater<float>());
    for (const std::vector<float>* order : {&fwd, &bwd, &queries}) {
      uint32_t hint = t % 3 == 0 ? 0u : (t % 3 == 1 ? uint32_t(n.size()) + 7u : uint32_t(n.size() / 2));
      for (float q : *order) {
        float expect = lookup_alpha(s, q);
        float got = lookup_alpha_from(s, q, hint);
        ASSERT_EQ(got, expect) << "query " << q << " texel " << t;
        ASSERT_EQ(hint, lower_bound_z(s, q));
      }
    }
    // Random hints, one query each.
    for (int q = 0; q < 20; ++q) {
      uint32_t hint = uint32_t(u(rng) * float(n.size() + 3));
      float zq = queries[size_t(u(rng) * float(queries.size() - 1))];
      ASSERT_EQ(lookup_alpha_from(s, zq, hint), lookup_alpha(s, zq));
    }
  }
}

namespace {

// A hand-made map: res x res texels, each texel's nodes given; the map is
// placed after `pad_texels` headers of another map to exercise offsets.
struct HandMap {
  std::vector<TexelRange> texels;
  std::vector<DsmNode> nodes;
  DsmMap map{};
  HandMap(int res, const std::vector<std::vector<DsmNode>>& per_texel, int pad_texels) {
    texels.assign(size_t(pad_texels), TexelRange{0, 0});
    nodes.push_back({0.0f, 1.0f});  // belongs to the padding map: must never be read
    for (const auto& t : per_texel) {
      texels.push_back({uint32_t(nodes.size()), uint32_t(t.size())});
      nodes.insert(nodes.end(), t.begin(), t.end());
    }
    map.res = uint32_t(res);
    map.texel_offset = uint64_t(pad_texels);
  }
  DsmStorage storage() const {
    DsmStorage st;  // packed layout (the default)
    st.grey.texels = {texels.data(), texels.size()};
    st.grey.nodes = {nodes.data(), nodes.size()};
    return st;
  }
};

// A texel of constant opacity `a` from depth 0 on.
std::vector<DsmNode> flat(float a) { return {{0.0f, 0.0f}, {0.0f, a}}; }

}  // namespace

TEST(Lookup, BilinearWeightsOnTwoByTwo) {
  // Texels (x, y): (0,0)=0.1, (1,0)=0.2, (0,1)=0.4, (1,1)=0.8; row-major.
  HandMap hm(2, {flat(0.1f), flat(0.2f), flat(0.4f), flat(0.8f)}, 5);
  DsmStorage st = hm.storage();
  const float z = 1.0f;
  auto bil = [&](float u, float v) { return lookup_map<1>(st, hm.map, u, v, z, true); };
  // Texel centres read their own value (thesis eq. 4.18: weights 1, 0, 0, 0).
  EXPECT_NEAR(bil(0.5f, 0.5f), 0.1f, 1e-6f);
  EXPECT_NEAR(bil(1.5f, 0.5f), 0.2f, 1e-6f);
  EXPECT_NEAR(bil(0.5f, 1.5f), 0.4f, 1e-6f);
  EXPECT_NEAR(bil(1.5f, 1.5f), 0.8f, 1e-6f);
  // The map centre: the mean of the four.
  EXPECT_NEAR(bil(1.0f, 1.0f), 0.375f, 1e-6f);
  // eq. 4.19: w_x = frac(u - 1/2), w_y = frac(v - 1/2).
  float u = 0.75f, v = 1.25f, wx = 0.25f, wy = 0.75f;
  float expect = (1 - wx) * (1 - wy) * 0.1f + wx * (1 - wy) * 0.2f + (1 - wx) * wy * 0.4f + wx * wy * 0.8f;
  EXPECT_NEAR(bil(u, v), expect, 1e-6f);
  // Taps outside the map count as alpha 0.
  EXPECT_NEAR(bil(0.25f, 0.5f), 0.75f * 0.1f, 1e-6f);
  EXPECT_NEAR(bil(0.0f, 0.0f), 0.25f * 0.1f, 1e-6f);
  EXPECT_NEAR(bil(2.0f, 2.0f), 0.25f * 0.8f, 1e-6f);
  EXPECT_NEAR(bil(1.0f, 2.0f), 0.25f * (0.4f + 0.8f), 1e-6f);
  EXPECT_EQ(bil(-1.0f, 0.5f), 0.0f);
  EXPECT_EQ(bil(0.5f, 3.0f), 0.0f);
  // Before every texel's first node: 0 everywhere.
  EXPECT_EQ(lookup_map<1>(st, hm.map, 1.0f, 1.0f, -0.5f, true), 0.0f);
  // Nearest texel when filtering is off; outside the map 0.
  EXPECT_EQ(lookup_map<1>(st, hm.map, 0.99f, 1.01f, z, false), 0.4f);
  EXPECT_EQ(lookup_map<1>(st, hm.map, 1.0f, 0.0f, z, false), 0.2f);
  EXPECT_EQ(lookup_map<1>(st, hm.map, -0.01f, 0.5f, z, false), 0.0f);
  EXPECT_EQ(lookup_map<1>(st, hm.map, 0.5f, 2.0f, z, false), 0.0f);
}

// A 4x4 map whose texels hold different depth-dependent functions: the filter
// is the weighted sum of the four taps' lookups at the same depth.
TEST(Lookup, BilinearOnFourByFourWithDepth) {
  std::vector<std::vector<DsmNode>> texels;
  for (int ty = 0; ty < 4; ++ty)
    for (int tx = 0; tx < 4; ++tx) {
      float z0 = 1.0f + 0.25f * float(tx), a = 0.1f * float(ty + 1);
      texels.push_back({{z0, 0.0f}, {z0 + 1.0f, a}, {z0 + 1.0f, a + 0.3f}, {z0 + 2.0f, 0.95f}});
    }
  HandMap hm(4, texels, 0);
  DsmStorage st = hm.storage();
  auto texel_alpha = [&](int tx, int ty, float z) -> double {
    if (tx < 0 || ty < 0 || tx > 3 || ty > 3) return 0.0;
    const auto& t = texels[size_t(ty * 4 + tx)];
    return lookup_alpha(Span<const DsmNode>{t.data(), t.size()}, z);
  };
  std::mt19937 rng(9u);
  std::uniform_real_distribution<float> ud(-0.7f, 4.7f), zd(0.5f, 5.0f);
  for (int i = 0; i < 5000; ++i) {
    float u = ud(rng), v = ud(rng), z = zd(rng);
    double lx = double(u) - 0.5, ly = double(v) - 0.5;
    int x0 = int(std::floor(lx)), y0 = int(std::floor(ly));
    double wx = lx - x0, wy = ly - y0;
    double expect = (1 - wx) * (1 - wy) * texel_alpha(x0, y0, z) + wx * (1 - wy) * texel_alpha(x0 + 1, y0, z) +
                    (1 - wx) * wy * texel_alpha(x0, y0 + 1, z) + wx * wy * texel_alpha(x0 + 1, y0 + 1, z);
    ASSERT_NEAR(lookup_map<1>(st, hm.map, u, v, z, true), expect, 2e-6) << "u " << u << " v " << v << " z " << z;
    int tx = int(std::floor(u)), ty = int(std::floor(v));
    ASSERT_EQ(lookup_map<1>(st, hm.map, u, v, z, false), float(texel_alpha(tx, ty, z)));
  }
}

// floor_int (texel indices of the taps, the blocker search and the filter)
// is int(floorf(x)) for every float within int's range: integers, halves,
// the floats next to them, negative ones, signed zeros, values past 2^24
// (all integers) up to 2^31, and a random sweep.
TEST(Lookup, FloorIntIsIntOfFloorf) {
  std::vector<float> xs = {0.0f,           -0.0f,       0.5f,         -0.5f,      1.0f,        -1.0f,  2147483520.0f,
                           -2147483648.0f, 16777216.0f, -16777217.0f, 8388607.5f, -8388607.5f, 1e-30f, -1e-30f};
  for (int i = -1000; i <= 1000; ++i)
    for (float d : {0.0f, 0.25f, 0.5f, 0.75f}) {
      const float x = float(i) + d;
      xs.push_back(x);
      xs.push_back(std::nextafter(x, -1e30f));
      xs.push_back(std::nextafter(x, 1e30f));
    }
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-3.0e9f, 3.0e9f);
  for (int i = 0; i < 100000; ++i) {
    const float x = u(rng) * (i % 3 == 0 ? 1e-6f : i % 3 == 1 ? 1e-3f : 0.7f);
    xs.push_back(x);
  }
  for (float x : xs) ASSERT_EQ(floor_int(x), int(std::floor(x))) << "x = " << x;
}

// ceil_log2 (the blocker pyramid's level for a square of a given size): the
// least k with 2^k >= n, against a loop, for n up to 2^20 and at 2^31 +- 1.
TEST(Lookup, CeilLog2IsTheLeastPowerAtOrAbove) {
  const auto loop = [](uint64_t n) {
    int k = 0;
    while ((uint64_t(1) << k) < n) ++k;
    return k;
  };
  for (uint32_t n = 1; n <= (1u << 20); ++n) ASSERT_EQ(ceil_log2(n), loop(n)) << "n = " << n;
  for (uint32_t n : {(1u << 31) - 1u, 1u << 31, (1u << 31) + 1u, 0xffffffffu})
    EXPECT_EQ(ceil_log2(n), loop(n)) << "n = " << n;
}
