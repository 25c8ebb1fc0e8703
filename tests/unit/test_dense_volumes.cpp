// Dense and sharp-edged volumes keep the epsilon bound (issue 25, hard case
// a): the light pass marches a volume every `step_voxels` voxels, which
// cannot follow exp(-sigma z) once sigma * step >> 1. Its step inside a
// macro-cell is bounded by the cell's largest extinction and sampling ends
// at saturation, so the map stays within eps + 0.005 of the reference at
// every point along a light ray — dense grids at extinction 10 to 10^4, a
// smoke whose transfer function is a threshold (a step in extinction) and
// the same smoke with a smooth ramp — in grey and RGB maps.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "cdsm/loaders.h"
#include "map_probe.h"

using namespace cdsm;
using namespace cdsm_test;

namespace {

// One volume of `grid` (voxel `voxel` world units, centred at the origin)
// in its box proxy through `transfer`, lit by a spot from above, slightly
// off axis; its map at 64^2 and `eps`.
Scene volume_scene(const std::string& name, std::shared_ptr<DenseGrid> grid, float voxel,
                   std::vector<TransferPoint> transfer, float eps) {
  Scene s = empty_scene(name);
  Volume v;
  v.name = name;
  v.grid = grid;
  v.index_to_object = make_transform(
      {-0.5f * voxel * float(grid->nx - 1), -0.5f * voxel * float(grid->ny - 1), -0.5f * voxel * float(grid->nz - 1)},
      {0, 0, 0}, vec3(voxel));
  v.transfer = std::move(transfer);
  v.step_voxels = 0.5f;
  s.volumes.push_back(v);
  Object o;
  o.name = name;
  o.interior = InteriorKind::Volume;
  o.volume = 0;
  o.mesh = share(make_volume_proxy(s.volumes[0]));
  o.surface.opacity = 0.0f;
  s.objects.push_back(o);
  const float size = voxel * float(std::max({grid->nx, grid->ny, grid->nz}));
  s.lights.push_back(spot_light({0.07f * size, 4.0f * size, 0.04f * size}, {-0.07f, -4.0f, -0.04f}, 15, 12));
  s.shadows.resolution = 64;
  s.shadows.epsilon = eps;
  return s;
}

std::shared_ptr<DenseGrid> uniform_grid(int n, float density) {
  auto g = std::make_shared<DenseGrid>();
  g->nx = g->ny = g->nz = n;
  g->values.assign(size_t(n) * n * n, density);
  return g;
}

// A soft ball of fractal noise (make_noise_volume), densities in [0, 1].
std::shared_ptr<DenseGrid> smoke_grid() {
  NoiseVolumeParams p;
  p.nx = p.ny = p.nz = 24;
  p.seed = 5;
  p.plume = 0.0f;
  p.frequency = 2.5f;
  return make_noise_volume(p);
}

std::vector<TransferPoint> grey_ramp(std::vector<std::pair<float, float>> points, Vec3 tint = {1, 1, 1}) {
  std::vector<TransferPoint> tf;
  for (auto [d, e] : points) tf.push_back(TransferPoint{d, tint * e, {1, 1, 1}});
  return tf;
}

void expect_within(const std::string& what, const Scene& scene, float sigma_max) {
  const float eps = scene.shadows.epsilon;
  const MapError m = map_error_along_rays(scene, sigma_max);
  std::printf(
      "[ dense vol ] %-40s eps %.3f: %2d rays, %zu points: map error p99 %.4f max %.4f "
      "(at %.4f of the chord: map T %.4f, reference %.4f)\n",
      what.c_str(), eps, m.rays, m.points, m.p99, m.max, m.worst_depth, m.map_at_worst, m.exact_at_worst);
  EXPECT_LE(m.max, eps + 0.005) << what;
}

}  // namespace

// A 4^3 grid of density 1 (voxel 0.08, step 0.04): sigma * step 0.4 .. 400.
TEST(DenseVolumes, UniformGridsWithinEpsilonAtAnyExtinction) {
  for (float eps : {0.01f, 0.002f})
    for (float sigma : {10.0f, 100.0f, 1000.0f, 10000.0f}) {
      char what[64];
      std::snprintf(what, sizeof what, "4^3 grid, extinction %g", double(sigma));
      expect_within(
          what, volume_scene(what, uniform_grid(4, 1.0f), 0.08f, grey_ramp({{0.0f, 0.0f}, {1.0f, sigma}}), eps), sigma);
    }
}

// The same grids with extinction differing per channel: RGB maps.
TEST(DenseVolumes, ColouredGridsWithinEpsilonInEveryChannel) {
  for (float sigma : {100.0f, 10000.0f}) {
    char what[64];
    std::snprintf(what, sizeof what, "4^3 grid, extinction %g x (1, .3, .05)", double(sigma));
    expect_within(what,
                  volume_scene(what, uniform_grid(4, 1.0f), 0.08f,
                               grey_ramp({{0.0f, 0.0f}, {1.0f, sigma}}, {1.0f, 0.3f, 0.05f}), 0.01f),
                  sigma);
  }
}

// A smoke whose transfer function is a threshold (extinction 0 below
// density 0.3, 150 from 0.31 on: an edge where the trilinear density
// crosses 0.3, as CT iso-transfer functions make), and the same smoke with
// a smooth ramp to the same extinction.
TEST(DenseVolumes, ThresholdedSmokeWithinEpsilon) {
  const float voxel = 0.02f, sigma = 150.0f;  // sigma * step = 1.5 in the dense part
  for (float eps : {0.01f, 0.002f}) {
    expect_within("smoke, threshold at density 0.3",
                  volume_scene("threshold", smoke_grid(), voxel, grey_ramp({{0.3f, 0.0f}, {0.31f, sigma}}), eps),
                  sigma);
    expect_within("smoke, smooth ramp",
                  volume_scene("ramp", smoke_grid(), voxel, grey_ramp({{0.0f, 0.0f}, {1.0f, sigma}}), eps), sigma);
  }
}
