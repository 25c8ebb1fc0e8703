// The reference renderer converges (DESIGN.md §7): on the default scene,
// marching at 1/4 and 1/8 voxel gives transmittances within 1e-4 at points
// inside the volumes and on the surfaces.
#include <gtest/gtest.h>

#include <iostream>
#include <random>
#include <vector>

#include "cdsm/scene_io.h"
#include "reference/reference.h"
#include "unit_util.h"

using namespace cdsm;
using namespace cdsm_test;

namespace {

struct Convergence {
  double quarter_eighth = 0.0;    // max |T(1/4) - T(1/8)|
  double eighth_sixteenth = 0.0;  // max |T(1/8) - T(1/16)|
  Vec3 worst_at;
  int partial = 0;  // probes with 0.01 < T < 0.999
};

Convergence measure_convergence() {
  Scene scene = load_scene(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/default.json");
  SceneBuffers sb = compiled_scene(scene);
  SceneView sv = sb.view();
  std::vector<LightData> lights = setup_lights(scene.lights, sb, 4).lights;
  EXPECT_FALSE(lights.empty());
  ReferenceRenderer quarter(sv, lights, ReferenceOptions{0.25f});
  ReferenceRenderer eighth(sv, lights, ReferenceOptions{0.125f});
  ReferenceRenderer sixteenth(sv, lights, ReferenceOptions{0.0625f});

  std::mt19937 rng(61u);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Vec3> points;
  // Inside the volumes' boxes.
  int volumes = 0;
  for (uint32_t o = 0; o < sv.objects.size(); ++o) {
    if (sv.objects[o].interior != InteriorKind::Volume) continue;
    ++volumes;
    const Box3& b = sb.object_bounds[o];
    for (int i = 0; i < 1500; ++i) {
      Vec3 e = b.extent();
      points.push_back(b.lo + Vec3{e.x * u(rng), e.y * u(rng), e.z * u(rng)});
    }
  }
  EXPECT_EQ(volumes, 2);
  // On the visible surfaces (area-weighted random points on triangles).
  std::vector<double> cdf;
  double area = 0.0;
  for (uint32_t t = 0; t < sv.tri_object.size(); ++t) {
    const ObjectData& od = sv.objects[sv.tri_object[t]];
    Vec3 a = sv.tri_vertices[3 * t], b = sv.tri_vertices[3 * t + 1], c = sv.tri_vertices[3 * t + 2];
    area += od.opacity > 0.0f ? 0.5 * length(cross(b - a, c - a)) : 0.0;
    cdf.push_back(area);
  }
  for (int i = 0; i < 1500; ++i) {
    size_t t = size_t(std::lower_bound(cdf.begin(), cdf.end(), u(rng) * area) - cdf.begin());
    t = std::min(t, cdf.size() - 1);
    float r1 = u(rng), r2 = u(rng);
    if (r1 + r2 > 1.0f) {
      r1 = 1.0f - r1;
      r2 = 1.0f - r2;
    }
    Vec3 a = sv.tri_vertices[3 * t], b = sv.tri_vertices[3 * t + 1], c = sv.tri_vertices[3 * t + 2];
    points.push_back(a + (b - a) * r1 + (c - a) * r2);
  }

  Convergence c;
  double& worst = c.quarter_eighth;
  double& worst_finer = c.eighth_sixteenth;
  Vec3& worst_at = c.worst_at;
  int shadowed = 0, in_volume_shadow = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    for (int l = 0; l < int(lights.size()); ++l) {
      double a = grey_of(quarter.transmittance(l, points[i])), b = grey_of(eighth.transmittance(l, points[i]));
      worst_finer = std::max(worst_finer, std::fabs(b - double(grey_of(sixteenth.transmittance(l, points[i])))));
      if (std::fabs(a - b) > worst) {
        worst = std::fabs(a - b);
        worst_at = points[i];
      }
      if (b < 0.95) ++shadowed;
      if (b < 0.999 && b > 0.01 && i < 3000) ++in_volume_shadow;
    }
  }
  std::cout << points.size() << " points, " << shadowed << " shadowed, " << in_volume_shadow
            << " partly transmitted in the volumes; max |T(1/4) - T(1/8)| = " << worst << " at (" << worst_at.x << ", "
            << worst_at.y << ", " << worst_at.z << "); max |T(1/8) - T(1/16)| = " << worst_finer << "\n";
  c.partial = in_volume_shadow;
  return c;
}

}  // namespace

// DESIGN.md §7: 1/4 vs 1/8 voxel differ < 1e-4.
TEST(Reference, QuarterVoxelConvergedOnDefaultScene) {
  Convergence c = measure_convergence();
  RecordProperty("max_step_difference", std::to_string(c.quarter_eighth));
  EXPECT_GT(c.partial, 300) << "the probe should see partial transmittance through the volumes";
  EXPECT_LT(c.quarter_eighth, 1e-4);
}

// The reference's marching converges (second order, as the midpoint rule
// should): halving the step shrinks the difference about fourfold, and at
// 1/8 vs 1/16 voxel it is below 1e-4.
TEST(Reference, MarchingConvergesOnDefaultScene) {
  Convergence c = measure_convergence();
  RecordProperty("max_step_difference_8_16", std::to_string(c.eighth_sixteenth));
  EXPECT_GT(c.partial, 300) << "the probe should see partial transmittance through the volumes";
  EXPECT_LT(c.eighth_sixteenth, 1e-4);
  EXPECT_LT(c.eighth_sixteenth, 0.5 * c.quarter_eighth);
}
