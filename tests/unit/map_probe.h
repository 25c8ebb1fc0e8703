// The error of a light's deep shadow map along its rays through an object,
// against the reference renderer (issue 25 a, b: dense volumes, nested
// media): shared by test_dense_volumes.cpp and test_nested_media.cpp.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "reference/reference.h"
#include "unit_util.h"

namespace cdsm_test {

struct MapError {
  double max = 0.0, p99 = 0.0;
  size_t points = 0;
  int rays = 0;
  double worst_depth = 0.0;  // fraction of the ray's chord through the box
  double map_at_worst = 0.0, exact_at_worst = 0.0;
};

// 1,000 points along each of 9 texel-centre rays of light 0's first map
// through object 0's box, aimed at points `spread` of its extent out from
// its centre (500 over its whole chord and beyond, 500 over the first
// 15 / sigma_max of it, where a dense medium saturates): the map's
// transmittance at the point's own depth (shadow_alpha, every channel)
// against the reference's (ReferenceRenderer::transmittance_segment:
// exact for constant media, a fine Simpson integral for volumes).
inline MapError map_error_along_rays(const Scene& scene, float sigma_max, float spread = 0.3f) {
  ShadowFixture fx(scene);
  const ShadowView sv = fx.view();
  const SceneView scv = fx.scene_view();
  ReferenceOptions ro;
  ro.step_voxels = 0.02f;  // the reference's own error stays far below the bound at sharp edges
  ReferenceRenderer ref(scv, {}, ro);
  const LightData& light = sv.lights[0];
  const PinholeView& lv = fx.map_view(0);
  const Box3& box = fx.sb.object_bounds[0];
  const Vec3 c = box.center(), e = box.extent();
  MapError out;
  std::vector<double> errors;
  for (int a = -1; a <= 1; ++a)
    for (int b = -1; b <= 1; ++b) {
      // The texel that sees a point `spread` out from the centre, its centre's ray.
      const ViewProjection pr = project(lv, c + Vec3{spread * float(a) * e.x, 0.0f, spread * float(b) * e.z});
      const Vec3 dir = pixel_ray(lv, int(std::floor(pr.u)), int(std::floor(pr.v)));
      float t_in = 0.0f, t_out = 3.0e38f;  // the ray's chord through the box (slabs)
      for (int k = 0; k < 3; ++k) {
        const float u = (box.lo[k] - lv.eye[k]) / dir[k], w = (box.hi[k] - lv.eye[k]) / dir[k];
        t_in = std::max(t_in, std::min(u, w));
        t_out = std::min(t_out, std::max(u, w));
      }
      EXPECT_LT(t_in, t_out);
      const float len = t_out - t_in, dense = std::min(len, 15.0f / sigma_max);
      ++out.rays;
      for (int i = 0; i < 1000; ++i) {
        // (offsets of 0.382, not simple fractions, keep the points off the
        // depths of surfaces, where a point's side of the step is a tie)
        const float z = i < 500 ? t_in - 0.02f * len + 1.1f * len * (float(i) + 0.382f) / 500.0f
                                : t_in + dense * (float(i - 500) + 0.382f) / 500.0f;
        const Vec3 p = lv.eye + dir * z;
        const Vec3 map = one_minus(shadow_alpha(sv, light, p));
        const Vec3 exact = ref.transmittance_segment(lv.eye, p);
        double err = 0.0;
        for (int k = 0; k < 3; ++k) err = std::max(err, std::fabs(double(map[k]) - double(exact[k])));
        errors.push_back(err);
        if (err > out.max) {
          out.max = err;
          out.worst_depth = (z - t_in) / len;
          out.map_at_worst = grey_of(map);
          out.exact_at_worst = grey_of(exact);
        }
      }
    }
  out.points = errors.size();
  std::sort(errors.begin(), errors.end());
  out.p99 = errors[size_t(0.99 * double(errors.size() - 1))];
  return out;
}

}  // namespace cdsm_test
