// Lights with a size in the reference renderer (issue 30 item 3): shadow
// rays stratified over a sphere light's disk (or the sun's cone) against
// the analytic penumbra of a straight edge, and converged: twice the rays
// change the answer by less than 0.002 on average. A light without a size
// keeps its single shadow ray.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "reference/reference.h"
#include "unit_util.h"

using namespace cdsm;
using namespace cdsm_test;

namespace {

constexpr double kPi = 3.14159265358979;

// A half-plane (x < 0) of opacity `a` at height h over a ground (top at
// y = 0), lit by a point light of radius r at height D above the origin.
Scene edge_scene(float a, float h, float D, float r) {
  Scene s = empty_scene("edge");
  s.objects.push_back(surface_object("ground", make_ground(30.0f, 30.0f, 0.05f)));
  s.objects.push_back(surface_object("half-plane", make_quad(20.0f, 20.0f), translation({-10.0f, h, 0}), a));
  Light l = point_light({0, D, 0});
  l.radius = r;
  s.lights.push_back(l);
  s.shadows.resolution = 64;
  return s;
}

// Fraction of a disk of radius r left of the chord at x = c (|c| <= r).
double disk_left_of(double c, double r) {
  const double t = std::fmax(-1.0, std::fmin(1.0, c / r));
  return (kPi - std::acos(t) + t * std::sqrt(1.0 - t * t)) / kPi;
}

}  // namespace

// Ground point (x, 0, 0): the edge, seen from it, cuts the light's disk at
// c = -x (D - h) / h, so T = 1 - a * (the disk's part left of c).
TEST(AreaLights, ReferencePenumbraOfAStraightEdgeIsAnalytic) {
  const float h = 2.0f, D = 4.0f, r = 0.2f;
  for (float a : {1.0f, 0.5f}) {
    ShadowFixture fx(edge_scene(a, h, D, r));
    ReferenceOptions ro;
    ro.area_samples = 256;
    ReferenceRenderer ref(fx.scene_view(), fx.frame.setup.lights, ro);
    ASSERT_GT(fx.frame.setup.lights[0].size, 0.0f);
    double worst = 0.0;
    int inside = 0;
    for (float x = -0.3f; x <= 0.3f; x += 0.01f) {
      const double c = -double(x) * (D - h) / h;
      const double expected = 1.0 - double(a) * disk_left_of(c, r);
      const double T = grey_of(ref.transmittance(0, Receiver{{x, 0.0f, 0.013f}, {0, 1, 0}, 0u}));
      worst = std::fmax(worst, std::fabs(T - expected));
      inside += std::fabs(c) < r;
    }
    std::printf("[ area     ] opacity %.1f: worst |T - analytic| across the penumbra %.4f\n", a, worst);
    EXPECT_GT(inside, 30);
    EXPECT_LE(worst, 0.02) << "opacity " << a;
  }
}

// The default 256 rays against 529 (about twice): the mean change over
// the penumbra itself is below 0.002 (64 rays: 0.0047); a light without a
// size casts one ray, as before.
TEST(AreaLights, ReferenceConvergesAndPointLightsKeepOneRay) {
  const float h = 2.0f, D = 4.0f, r = 0.2f;
  ShadowFixture fx(edge_scene(0.5f, h, D, r));
  ReferenceOptions lo, hi;
  hi.area_samples = 529;
  ReferenceRenderer a(fx.scene_view(), fx.frame.setup.lights, lo), b(fx.scene_view(), fx.frame.setup.lights, hi);
  double sum = 0.0;
  int n = 0;
  for (float x = -0.3f; x <= 0.3f; x += 0.005f)
    for (float z : {-0.4f, 0.1f, 0.7f}) {
      const Receiver rc{{x, 0.0f, z}, {0, 1, 0}, 0u};
      sum += std::fabs(grey_of(a.transmittance(0, rc)) - grey_of(b.transmittance(0, rc)));
      ++n;
    }
  std::printf("[ area     ] mean |T_256 - T_529| over the penumbra: %.5f\n", sum / n);
  EXPECT_LT(sum / n, 0.002);
  EXPECT_EQ(a.area_sample_count(fx.frame.setup.lights[0]), 256);
  LightData point = fx.frame.setup.lights[0];
  point.size = 0.0f;
  EXPECT_EQ(a.area_sample_count(point), 1);
  EXPECT_EQ(a.area_origin(point, {0.1f, 0, 0}, 0, 1).y, D);
}

// The sun's cone: a directional light of angular diameter 2 degrees over
// the same edge: the penumbra's width on the ground is about
// 2 h tan(1 degree) / sin(elevation) (straight down here: 2 h tan 1°).
TEST(AreaLights, SunConeGivesThePenumbraWidth) {
  const float h = 2.0f;
  Scene s = edge_scene(1.0f, h, 4.0f, 0.0f);
  s.lights[0] = sun_light({0, -1, 0});
  s.lights[0].angular_diameter_deg = 2.0f;
  ShadowFixture fx(s);
  ReferenceOptions ro;
  ro.area_samples = 256;
  ReferenceRenderer ref(fx.scene_view(), fx.frame.setup.lights, ro);
  const double half_width = h * std::tan(1.0 * kPi / 180.0);
  double worst = 0.0;
  for (float x = -0.06f; x <= 0.06f; x += 0.002f) {
    const double expected = 1.0 - disk_left_of(-double(x), half_width);
    const double T = grey_of(ref.transmittance(0, Receiver{{x, 0.0f, 0.02f}, {0, 1, 0}, 0u}));
    worst = std::fmax(worst, std::fabs(T - expected));
  }
  std::printf("[ area     ] sun cone: worst |T - analytic| %.4f (half width %.4f)\n", worst, half_width);
  EXPECT_LE(worst, 0.02);
}
