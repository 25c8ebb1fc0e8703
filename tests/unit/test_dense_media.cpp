// Dense constant media keep the epsilon bound (issue "No silent wrong
// answers", item 4): the light pass samples a constant medium only up to
// saturation, with chords close enough there that the compressed function
// stays within eps + 2e-5 of 1 - exp(-sigma z) everywhere — between samples
// too, not only at nodes — for optical depths sigma*L from 10 to 10^4.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "hd/baselines.h"
#include "hd/light_pass.h"
#include "unit_util.h"

using namespace cdsm;
using namespace cdsm_test;

namespace {

struct Fit {
  std::vector<DsmNode> nodes;
  double worst = 0.0;  // max |alpha' - alpha| at the probe depths
  double at = 0.0;
};

// The exact opacity of a constant medium from z = t0 on, entered at alpha0
// (right-continuous: alpha0 from t0 on, like NodeFunction::right).
double exact(double z, double t0, double sigma, double alpha0) {
  return z <= t0 ? alpha0 : 1.0 - (1.0 - alpha0) * std::exp(-sigma * (z - t0));
}

// 1,000 depths over the segment (and a little beyond), and 1,000 more over
// the first 12 / sigma, where a dense medium saturates.
void probe(Fit& f, double t0, double t1, double sigma, double alpha0) {
  NodeFunction fn{f.nodes};
  for (int i = 0; i <= 2000; ++i) {
    double z = i <= 1000 ? t0 + (t1 - t0) * 1.02 * double(i) / 1000.0 : t0 + 12.0 / sigma * double(i - 1000) / 1000.0;
    double e = std::fabs(fn.right(std::min(z, t1)) - exact(std::min(z, t1), t0, sigma, alpha0));
    if (e > f.worst) {
      f.worst = e;
      f.at = z;
    }
  }
}

// One segment [t0, t1] of extinction sigma through the DSM light pass's
// visitor, after a surface of opacity alpha0 at t0.
Fit dsm_segment(float t0, float t1, float sigma, float eps, float alpha0) {
  std::vector<DsmNode> storage(1024);
  NodeBuffer buf{storage.data(), 1024};
  buf.eps = eps;
  SceneView sv{};
  DsmVisitor vis(sv, Vec3{0, 0, 0}, Vec3{0, 0, 1}, eps, buf);
  if (alpha0 > 0.0f) {  // a surface first: a step at t0
    vis.c.push(buf, t0, 0.0f);
    vis.alpha = alpha0;
    vis.c.step(buf, t0, alpha0);
  }
  SegmentMedia m;
  m.sigma = vec3(sigma);
  vis.segment(t0, t1, m);
  vis.c.finish(buf);
  Fit f;
  f.nodes.assign(buf.nodes, buf.nodes + buf.count);
  probe(f, t0, t1, sigma, alpha0);
  return f;
}

}  // namespace

TEST(DenseMedia, DsmWithinEpsilonBetweenSamples) {
  for (float eps : {0.001f, 0.01f})
    for (float optical : {10.0f, 100.0f, 1000.0f, 10000.0f})
      for (float alpha0 : {0.0f, 0.5f}) {
        const float t0 = 2.0f, len = 3.0f, sigma = optical / len;
        Fit f = dsm_segment(t0, t0 + len, sigma, eps, alpha0);
        std::printf("[ dense ] eps %.3f sigma*L %6.0f alpha0 %.1f: %4zu nodes, max |alpha' - alpha| %.2e at z = %.4f\n",
                    eps, optical, alpha0, f.nodes.size(), f.worst, f.at);
        EXPECT_LE(f.worst, eps + 2e-5) << "eps " << eps << " sigma*L " << optical << " alpha0 " << alpha0;
        EXPECT_LE(f.nodes.size(), 300u) << "sampling stops at saturation";
      }
}

// The baselines' exact walk hands the same media to the builders: with
// enough nodes, the AVSM-style map follows a dense medium too (its pieces
// end at saturation instead of spreading 256 pieces over the segment).
TEST(DenseMedia, BaselinePiecesFollowTheExponential) {
  for (float optical : {10.0f, 1000.0f, 10000.0f}) {
    const float t0 = 2.0f, len = 3.0f, sigma = optical / len;
    std::vector<DsmNode> storage(1024);
    NodeBuffer buf{storage.data(), 1024};
    FixedNodeBuilder b{buf, 256};
    SceneView sv{};
    ExactAlphaVisitor<FixedNodeBuilder> vis(sv, Vec3{0, 0, 0}, Vec3{0, 0, 1}, b);
    SegmentMedia m;
    m.sigma = vec3(sigma);
    vis.segment(t0, t0 + len, m);
    Fit f;
    f.nodes.assign(buf.nodes, buf.nodes + buf.count);
    probe(f, t0, t0 + len, sigma, 0.0);
    std::printf("[ dense ] fixed nodes sigma*L %6.0f: %3zu nodes, max |alpha' - alpha| %.2e\n", optical, f.nodes.size(),
                f.worst);
    EXPECT_LE(f.worst, 1e-3) << "sigma*L " << optical;
  }
}
