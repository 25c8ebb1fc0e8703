// Empty-space skipping against brute force (issue "No silent wrong
// answers", item 7): the reference renderer integrates volumes with no
// skipping structure of the DSM path, and both it and the DSM light pass
// agree with a brute-force integral (fine Simpson over the whole ray inside
// the proxy, every sample read from the grid) on
//   - a dense grid whose proxy is larger than the grid, with data up to its
//     border (samples within a voxel outside the grid read real voxels),
//   - sparse (NanoVDB) grids made in code with active tiles above leaf level,
//     and without the neighbour leaves load_vdb adds.
#include <gtest/gtest.h>

#include <nanovdb/util/GridBuilder.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

#include "cdsm/loaders.h"
#include "reference/reference.h"
#include "unit_util.h"
#include "common/host_maps.h"

using namespace cdsm;
using namespace cdsm_test;

namespace {

// A SparseGrid from a NanoVDB grid built in code: values func(ijk) over
// bbox; uniform 8^3 blocks become tiles (GridBuilder prunes them).
template <class F>
std::shared_ptr<SparseGrid> sparse_grid(F func, nanovdb::CoordBBox bbox, float background) {
  nanovdb::GridBuilder<float> builder(background);
  builder([&](const nanovdb::Coord& ijk) { return func(ijk); }, bbox);
  auto handle = builder.getHandle();
  auto g = std::make_shared<SparseGrid>();
  g->name = "in code";
  g->nanovdb_bytes = handle.size();
  g->nanovdb.resize((handle.size() + sizeof(SparseGrid::Block) - 1) / sizeof(SparseGrid::Block));
  std::memcpy(g->nanovdb.data(), handle.data(), handle.size());
  const auto* grid = handle.grid<float>();
  const nanovdb::CoordBBox active = grid->indexBBox();
  for (int a = 0; a < 3; ++a) {
    g->active_min[a] = active.min()[a];
    g->active_max[a] = active.max()[a];
  }
  g->active_voxels = grid->activeVoxelCount();
  g->background = background;
  return g;
}

// How many tiles (values not in leaves) hold a non-background value.
int count_tiles(const SparseGrid& g) {
  const auto* grid = reinterpret_cast<const nanovdb::FloatGrid*>(g.data());
  const auto& tree = grid->tree();
  int tiles = 0;
  const auto* lower = tree.getFirstLower();
  for (uint32_t i = 0; i < tree.nodeCount(1); ++i)
    for (auto it = lower[i].beginValue(); it; ++it) tiles += *it != g.background;
  return tiles;
}

struct Medium {
  std::string name;
  Scene scene;
  float eps = 0.002f;
};

// One volume of `grid` scaled to `voxel` world units, index (0,0,0) at
// world `origin`, bounded by `proxy_lo .. proxy_hi` (index space), lit from
// above; extinction = 4 * density.
Medium make_medium(const std::string& name, std::shared_ptr<DenseGrid> dense, std::shared_ptr<SparseGrid> sparse,
                   Vec3 proxy_lo, Vec3 proxy_hi) {
  Medium m;
  m.name = name;
  Scene& s = m.scene;
  s = empty_scene(name);
  Volume v;
  v.name = name;
  v.grid = dense;
  v.sparse = sparse;
  v.index_to_object = make_transform({0, 0, 0}, {0, 0, 0}, {0.05f, 0.05f, 0.05f});
  v.transfer = {TransferPoint{0.0f, vec3(0.0f), {1, 1, 1}}, TransferPoint{1.0f, vec3(4.0f), {1, 1, 1}}};
  v.step_voxels = 0.25f;
  s.volumes.push_back(v);
  TriangleMesh box = make_box((proxy_hi - proxy_lo) * 0.05f);
  Vec3 c = (proxy_lo + proxy_hi) * (0.5f * 0.05f);
  for (Vec3& p : box.positions) p = p + c;
  Object o = surface_object(name, box, Mat4{}, 0.0f);
  o.interior = InteriorKind::Volume;
  o.volume = 0;
  s.objects.push_back(o);
  return m;
}

// 1 - exp(-tau) along org + t dir, t in [0, z], inside the object's box
// [lo, hi] (world), by Simpson with 4,000 panels: every sample a grid read.
double brute_alpha(const SceneView& sv, Vec3 org, Vec3 dir, double z, Vec3 lo, Vec3 hi) {
  double t0 = 0.0, t1 = z;
  for (int a = 0; a < 3; ++a) {  // clip to the box (slabs)
    double inv = 1.0 / dir[a];
    double ta = (lo[a] - org[a]) * inv, tb = (hi[a] - org[a]) * inv;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (!(t1 > t0)) return 0.0;
  const VolumeData& v = sv.volumes[0];
  auto sigma = [&](double t) {
    Vec3 p = org + dir * float(t);
    return double(apply_transfer(v.tf, density_at(sv, v, p)).extinction.x);
  };
  const int n = 4000;
  double h = (t1 - t0) / n, tau = 0.0;
  for (int i = 0; i < n; ++i) {
    double a = t0 + i * h;
    tau += (sigma(a) + 4.0 * sigma(a + 0.5 * h) + sigma(a + h)) * h / 6.0;
  }
  return 1.0 - std::exp(-tau);
}

struct Agreement {
  double dsm = 0.0, reference = 0.0;
  int rays = 0, partial = 0;
};

// Light rays from a point above the volume through it: the light pass's
// visibility function and the reference's transmittance against brute force.
Agreement compare(const Medium& m) {
  SceneBuffers sb = compiled_scene(m.scene);
  SceneView sv = sb.view();
  const Box3& box = sb.object_bounds[0];
  Vec3 c = box.center(), e = box.extent();
  Vec3 eye = c + Vec3{0.13f * e.x, 2.5f * e.y + 0.5f, 0.07f * e.z};
  PinholeView lv = light_view(eye, c - eye, {1, 0, 0}, 0.45f, 48, 1, 0.01f, 20.0f);
  FragmentBuffers fb;
  cast_fragments(sv, lv, ObjectMask{}, fb);
  cdsm_test::HostMaps dsm;
  LightPassParams lp{lv, m.eps, {}};
  cdsm_test::build_host_map(sb, lp, fb, dsm);
  ReferenceRenderer ref(sv, {});
  Agreement out;
  for (int ty = 2; ty < 46; ty += 3)
    for (int tx = 2; tx < 46; tx += 3) {
      Vec3 dir = pixel_ray(lv, tx, ty);
      Span<const DsmNode> nodes = texel_nodes<1>(dsm.storage(), dsm.maps[0], tx, ty);
      ++out.rays;
      for (int k = 1; k <= 8; ++k) {
        float z = length(c - eye) + (float(k) / 8.0f - 0.5f) * 1.8f * length(e);
        double exact = brute_alpha(sv, eye, dir, z, box.lo, box.hi);
        out.partial += exact > 0.02 && exact < 0.98;
        out.dsm = std::max(out.dsm, std::fabs(double(lookup_alpha(nodes, z)) - exact));
        double t_ref = grey_of(ref.transmittance_segment(eye, eye + dir * z));
        out.reference = std::max(out.reference, std::fabs((1.0 - t_ref) - exact));
      }
    }
  return out;
}

void expect_agreement(const Medium& m) {
  Agreement a = compare(m);
  std::printf("[ skipping ] %-34s %3d rays (%4d partial samples): DSM %.2e, reference %.2e from brute force\n",
              m.name.c_str(), a.rays, a.partial, a.dsm, a.reference);
  EXPECT_GT(a.partial, 100) << m.name << ": the probes must see the medium";
  EXPECT_LE(a.reference, 2e-4) << m.name;
  EXPECT_LE(a.dsm, m.eps + 2e-3) << m.name;
}

}  // namespace

// A dense 16^3 grid with data up to its border; the proxy extends two voxels
// beyond it on every side, so samples in [-1, -0.5) and [n - 0.5, n) read
// the border voxels through trilinear filtering.
TEST(VolumeSkipping, DenseProxyLargerThanTheGrid) {
  auto g = std::make_shared<DenseGrid>();
  g->nx = g->ny = g->nz = 16;
  g->values.resize(16 * 16 * 16);
  for (int k = 0; k < 16; ++k)
    for (int j = 0; j < 16; ++j)
      for (int i = 0; i < 16; ++i)  // strongest at the grid's faces
        g->values[(size_t(k) * 16 + j) * 16 + i] =
            0.3f + 0.7f * std::max({std::fabs(i - 7.5f), std::fabs(j - 7.5f), std::fabs(k - 7.5f)}) / 7.5f;
  expect_agreement(
      make_medium("dense, proxy 2 voxels larger", g, nullptr, {-2.5f, -2.5f, -2.5f}, {17.5f, 17.5f, 17.5f}));
}

// A NanoVDB grid made in code: a uniform 32^3 block (pruned to tiles of the
// lower internal nodes) inside a noisy shell of leaves, and a lone uniform
// tile region away from any leaf. No extra neighbour leaves.
TEST(VolumeSkipping, SparseGridWithTilesAboveLeafLevel) {
  auto value = [](const nanovdb::Coord& ijk) -> float {
    int x = ijk[0], y = ijk[1], z = ijk[2];
    if (x >= 8 && x < 40 && y >= 8 && y < 40 && z >= 8 && z < 40) return 0.8f;     // 4^3 leaves, uniform: tiles
    if (x >= 56 && x < 64 && y >= 16 && y < 24 && z >= 16 && z < 24) return 0.5f;  // one lone uniform leaf: a tile
    if (x >= 0 && x < 48 && y >= 0 && y < 48 && z >= 0 && z < 48)                  // a noisy shell around the block
      return 0.2f + 0.1f * float((x * 7 + y * 13 + z * 3) % 5);
    return 0.0f;
  };
  auto sg = sparse_grid(value, nanovdb::CoordBBox(nanovdb::Coord(0), nanovdb::Coord(70, 47, 47)), 0.0f);
  ASSERT_GT(count_tiles(*sg), 60) << "the builder must have pruned uniform leaves into tiles";
  expect_agreement(
      make_medium("sparse, tiles above leaf level", nullptr, sg, {-0.5f, -0.5f, -0.5f}, {71.5f, 47.5f, 47.5f}));
}

// The same grid with a non-zero background (every unstored voxel reads it).
TEST(VolumeSkipping, SparseGridWithTilesAndABackground) {
  auto value = [](const nanovdb::Coord& ijk) -> float {
    int x = ijk[0], y = ijk[1], z = ijk[2];
    if (x >= 16 && x < 32 && y >= 0 && y < 32 && z >= 8 && z < 24) return 0.9f;
    if ((x + y + z) % 11 == 0 && x < 40 && y < 40 && z < 40) return 0.6f;
    return 0.1f;
  };
  auto sg = sparse_grid(value, nanovdb::CoordBBox(nanovdb::Coord(0), nanovdb::Coord(39, 39, 39)), 0.1f);
  ASSERT_GT(count_tiles(*sg), 0);
  expect_agreement(
      make_medium("sparse, tiles, background 0.1", nullptr, sg, {-4.5f, -4.5f, -4.5f}, {43.5f, 43.5f, 43.5f}));
}

// The dense trilinear read (hd/volume.h density_at_index): its in-grid
// path reads the 8 corners as two rows of two planes, the border path one
// voxel at a time with the background outside. Both against trilinear
// weights written out here, over a non-cubic grid (every stride distinct),
// at positions inside, across every border and far outside.
TEST(VolumeSkipping, DenseTrilinearMatchesWeightsInsideAndAcrossBorders) {
  auto g = std::make_shared<DenseGrid>();
  g->nx = 7, g->ny = 5, g->nz = 6;
  g->background = 0.25f;
  g->values.resize(size_t(g->nx) * g->ny * g->nz);
  for (size_t n = 0; n < g->values.size(); ++n) g->values[n] = float((n * 7919u) % 101u) / 100.0f;
  Medium m = make_medium("dense 7x5x6", g, nullptr, {-0.5f, -0.5f, -0.5f}, {6.5f, 4.5f, 5.5f});
  SceneBuffers sb = compiled_scene(m.scene);
  SceneView sv = sb.view();
  const VolumeData& v = sv.volumes[0];
  auto voxel = [&](int i, int j, int k) -> double {
    if (i < 0 || j < 0 || k < 0 || i >= g->nx || j >= g->ny || k >= g->nz) return g->background;
    return g->values[(size_t(k) * g->ny + size_t(j)) * g->nx + size_t(i)];
  };
  int inside = 0, border = 0;
  double worst = 0.0;
  for (int n = 0; n < 20000; ++n) {
    // Index positions from -2.3 to n + 1.3 on each axis (a fixed lattice).
    const Vec3 q{-2.3f + float(n % 97) * (g->nx + 3.6f) / 96.0f, -2.3f + float((n / 97) % 23) * (g->ny + 3.6f) / 22.0f,
                 -2.3f + float(n % 89) * (g->nz + 3.6f) / 88.0f};
    const int i = int(std::floor(q.x)), j = int(std::floor(q.y)), k = int(std::floor(q.z));
    const double tx = q.x - i, ty = q.y - j, tz = q.z - k;
    double expect = 0.0;
    for (int c = 0; c < 8; ++c) {
      const int dx = c & 1, dy = (c >> 1) & 1, dz = c >> 2;
      expect += (dx ? tx : 1 - tx) * (dy ? ty : 1 - ty) * (dz ? tz : 1 - tz) * voxel(i + dx, j + dy, k + dz);
    }
    const bool all_in = i >= 0 && j >= 0 && k >= 0 && i + 1 < g->nx && j + 1 < g->ny && k + 1 < g->nz;
    (all_in ? inside : border) += 1;
    worst = std::max(worst, std::fabs(double(density_at_index(sv, v, q)) - expect));
  }
  std::printf("[ trilinear] %d reads inside, %d across borders: max |error| %.2e\n", inside, border, worst);
  EXPECT_GT(inside, 2000);
  EXPECT_GT(border, 2000);
  EXPECT_LE(worst, 1e-6);
}
