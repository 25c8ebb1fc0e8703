// Volume sampling shared by the DSM path and the reference renderer: the
// transfer function, trilinear density lookup with the grid's background,
// gradients, and macro-cell emptiness for empty-space skipping.
#pragma once

#include "hd/scene_data.h"

// NanoVDB is header-only and __hostdev__: sparse grids are sampled through
// it on the CPU and under nvcc. A build without its headers samples dense
// grids only (the scene compile rejects sparse ones there).
#if __has_include(<nanovdb/NanoVDB.h>)
#include <nanovdb/NanoVDB.h>
#define CDSM_HAVE_NANOVDB 1
#else
#define CDSM_HAVE_NANOVDB 0
#endif

namespace cdsm {

// Extinction (per colour channel) and colour of a density value
// (piecewise linear, clamped ends).
struct TransferSample {
  Vec3 extinction;
  Vec3 color;
};

CDSM_HD CDSM_INLINE Vec3 transfer_extinction(const TransferData& tf, int i) {
  return {tf.extinction[0][i], tf.extinction[1][i], tf.extinction[2][i]};
}

CDSM_HD CDSM_INLINE TransferSample apply_transfer(const TransferData& tf, float d) {
  int n = tf.count;
  if (n <= 1 || d <= tf.density[0]) return {transfer_extinction(tf, 0), {tf.r[0], tf.g[0], tf.b[0]}};
  if (d >= tf.density[n - 1]) return {transfer_extinction(tf, n - 1), {tf.r[n - 1], tf.g[n - 1], tf.b[n - 1]}};
  int i = 1;
  while (i < n - 1 && d > tf.density[i]) ++i;
  float span = tf.density[i] - tf.density[i - 1];
  float w = span > 0.0f ? (d - tf.density[i - 1]) / span : 1.0f;
  return {
      {lerpf(tf.extinction[0][i - 1], tf.extinction[0][i], w), lerpf(tf.extinction[1][i - 1], tf.extinction[1][i], w),
       lerpf(tf.extinction[2][i - 1], tf.extinction[2][i], w)},
      {lerpf(tf.r[i - 1], tf.r[i], w), lerpf(tf.g[i - 1], tf.g[i], w), lerpf(tf.b[i - 1], tf.b[i], w)}};
}

CDSM_HD CDSM_INLINE float voxel_at(const SceneView& s, const VolumeData& v, int i, int j, int k) {
  if (i < 0 || j < 0 || k < 0 || i >= v.nx || j >= v.ny || k >= v.nz) return v.background;
  return s.voxels[v.voxel_offset + (uint64_t(k) * uint64_t(v.ny) + uint64_t(j)) * uint64_t(v.nx) + uint64_t(i)];
}

// Index positions beyond this are far outside any grid: clamped so that
// integer conversions stay defined (grids span less than 2^30 voxels).
inline constexpr float kIndexLimit = 1.0e9f;

CDSM_HD CDSM_INLINE float clamp_index(float x) { return fminf(fmaxf(x, -kIndexLimit), kIndexLimit); }

// Trilinear interpolation of the 8 voxels around q; corners(i, j, k, c)
// reads voxels (i..i+1, j..j+1, k..k+1) into c, x fastest, then y, then z.
template <class Corners>
CDSM_HD CDSM_INLINE float trilinear(Vec3 q, Corners&& corners) {
  float fx = floorf(clamp_index(q.x)), fy = floorf(clamp_index(q.y)), fz = floorf(clamp_index(q.z));
  int i = int(fx), j = int(fy), k = int(fz);
  float tx = q.x - fx, ty = q.y - fy, tz = q.z - fz;
  float c[8];
  corners(i, j, k, c);
  float c00 = lerpf(c[0], c[1], tx), c10 = lerpf(c[2], c[3], tx);
  float c01 = lerpf(c[4], c[5], tx), c11 = lerpf(c[6], c[7], tx);
  return lerpf(lerpf(c00, c10, ty), lerpf(c01, c11, ty), tz);
}

// The 8 corners from one voxel at a time.
template <class Fetch>
CDSM_HD CDSM_INLINE void corners_by_voxel(int i, int j, int k, float* c, Fetch&& fetch) {
  for (int n = 0; n < 8; ++n) c[n] = fetch(i + (n & 1), j + ((n >> 1) & 1), k + (n >> 2));
}

#if CDSM_HAVE_NANOVDB
// The NanoVDB grid of a GridKind::Nano volume.
CDSM_HD CDSM_INLINE const nanovdb::FloatGrid* nano_grid(const SceneView& s, const VolumeData& v) {
  return reinterpret_cast<const nanovdb::FloatGrid*>(s.nano_pool.data() + v.voxel_offset);
}
#endif

#if CDSM_HAVE_NANOVDB
// Trilinear density of a sparse (NanoVDB) grid. The accessor caches the
// path to the last leaf: the 8 taps mostly share one leaf. Unstored voxels
// read the tile or background value. Out of line: eight tree walks are
// large code and cost far more than a call (every march and gradient site
// would carry its own copy on a GPU).
CDSM_HD CDSM_NOINLINE inline float nano_density_at_index(const SceneView& s, const VolumeData& v, Vec3 q) {
  auto acc = nano_grid(s, v)->getAccessor();
  return trilinear(q, [&](int i, int j, int k, float* c) {
    corners_by_voxel(i, j, k, c, [&](int x, int y, int z) { return acc.getValue(nanovdb::Coord(x, y, z)); });
  });
}
#endif

// Trilinear density at index-space position q (voxel centres at integers).
// Dense and sparse grids: a closed set, dispatched by a switch (STYLE.md 5).
CDSM_HD CDSM_INLINE float density_at_index(const SceneView& s, const VolumeData& v, Vec3 q) {
  switch (v.grid_kind) {
#if CDSM_HAVE_NANOVDB
    case GridKind::Nano: return nano_density_at_index(s, v, q);
#endif
    case GridKind::Dense:
    default:
      return trilinear(q, [&](int i, int j, int k, float* c) {
        if (i >= 0 && j >= 0 && k >= 0 && i + 1 < v.nx && j + 1 < v.ny && k + 1 < v.nz) {
          // All 8 inside the grid (most samples): two rows of two planes.
          const uint64_t row = uint64_t(v.nx), plane = row * uint64_t(v.ny);
          const float* p = &s.voxels[v.voxel_offset + uint64_t(k) * plane + uint64_t(j) * row + uint64_t(i)];
          c[0] = p[0], c[1] = p[1], c[2] = p[row], c[3] = p[row + 1];
          c[4] = p[plane], c[5] = p[plane + 1], c[6] = p[plane + row], c[7] = p[plane + row + 1];
          return;
        }
        corners_by_voxel(i, j, k, c, [&](int x, int y, int z) { return voxel_at(s, v, x, y, z); });
      });
  }
}

CDSM_HD CDSM_INLINE float density_at(const SceneView& s, const VolumeData& v, Vec3 world) {
  return density_at_index(s, v, v.world_to_index.point(world));
}

// World-space gradient of the density (central differences in index space).
CDSM_HD CDSM_INLINE Vec3 density_gradient(const SceneView& s, const VolumeData& v, Vec3 world) {
  Vec3 q = v.world_to_index.point(world);
  Vec3 g{density_at_index(s, v, q + Vec3{1, 0, 0}) - density_at_index(s, v, q - Vec3{1, 0, 0}),
         density_at_index(s, v, q + Vec3{0, 1, 0}) - density_at_index(s, v, q - Vec3{0, 1, 0}),
         density_at_index(s, v, q + Vec3{0, 0, 1}) - density_at_index(s, v, q - Vec3{0, 0, 1})};
  g = g * 0.5f;
  // d/dworld = (d index / d world)^T * d/dindex
  const Mat4& m = v.world_to_index;
  return {m.m[0][0] * g.x + m.m[1][0] * g.y + m.m[2][0] * g.z, m.m[0][1] * g.x + m.m[1][1] * g.y + m.m[2][1] * g.z,
          m.m[0][2] * g.x + m.m[1][2] * g.y + m.m[2][2] * g.z};
}

#if CDSM_HAVE_NANOVDB
// macro_max_at of a sparse grid at cell (ci, cj, ck). Out of line (tree
// probes, up to 27 of them: see nano_density_at_index).
CDSM_HD CDSM_NOINLINE inline float nano_macro_max_at(const SceneView& s, const VolumeData& v, int ci, int cj, int ck) {
  // Leaves are 8^3 voxels at multiples of 8: leaf (ci, cj, ck) is the cell.
  static_assert(nanovdb::FloatTree::LeafNodeType::DIM == kMacroCell, "a leaf is a macro-cell");
  const nanovdb::FloatGrid* grid = nano_grid(s, v);
  const nanovdb::FloatTree& tree = grid->tree();
  const auto* first = tree.getFirstLeaf();
  const auto* leaf = tree.root().probeLeaf(nanovdb::Coord(ci * kMacroCell, cj * kMacroCell, ck * kMacroCell));
  if (leaf != nullptr) return s.macro_max[v.macro_offset + uint64_t(leaf - first)];
  if (v.skip_mode != NanoSkip::Neighbours) return -1.0f;
  // A cell without a leaf is one value; its apron reaches into the 26
  // neighbours: each a leaf (its stored maximum) or one value.
  float m = 0.0f;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        nanovdb::Coord o((ci + dx) * kMacroCell, (cj + dy) * kMacroCell, (ck + dz) * kMacroCell);
        const auto* n = tree.root().probeLeaf(o);
        m = fmaxf(m, n ? s.macro_max[v.macro_offset + uint64_t(n - first)]
                       : max_channel(apply_transfer(v.tf, tree.root().getValue(o)).extinction));
      }
  return m;
}
#endif

// Maximum extinction in the macro-cell containing index position q, or -1
// where no maximum is stored (beyond a dense grid's outer ring of cells; a
// sparse cell without a leaf whose neighbourhood needs no reading): there
// the background decides emptiness.
CDSM_HD CDSM_INLINE float macro_max_at(const SceneView& s, const VolumeData& v, Vec3 q) {
  // Cell c covers index positions [c*K - 0.5, (c+1)*K - 0.5): the voxels a
  // trilinear sample there touches lie in [c*K - 1, (c+1)*K], which the
  // stored maximum includes (the one-voxel apron).
  int ci = int(floorf((clamp_index(q.x) + 0.5f) / float(kMacroCell)));
  int cj = int(floorf((clamp_index(q.y) + 0.5f) / float(kMacroCell)));
  int ck = int(floorf((clamp_index(q.z) + 0.5f) / float(kMacroCell)));
#if CDSM_HAVE_NANOVDB
  if (v.grid_kind == GridKind::Nano) return nano_macro_max_at(s, v, ci, cj, ck);
#endif
  ci += 1;  // the stored cells start at -1
  cj += 1;
  ck += 1;
  if (ci < 0 || cj < 0 || ck < 0 || ci >= v.mx || cj >= v.my || ck >= v.mz) return -1.0f;
  return s.macro_max[v.macro_offset + (uint64_t(ck) * uint64_t(v.my) + uint64_t(cj)) * uint64_t(v.mx) + uint64_t(ci)];
}

// Ray parameter where the ray leaves the macro-cell that contains the point
// at parameter t (index-space ray: q(t) = qo + t * qd). Rounding may put it
// at or just before t when q(t) lies on the boundary: callers step at least
// a float-resolvable amount on (march_segment).
CDSM_HD CDSM_INLINE float macro_cell_exit(Vec3 qo, Vec3 qd, float t) {
  Vec3 q = qo + qd * t;
  float best = 3.0e38f;
  for (int a = 0; a < 3; ++a) {
    float c = floorf((q[a] + 0.5f) / float(kMacroCell));
    float d = qd[a];
    if (d > 0.0f)
      best = fminf(best, ((c + 1.0f) * kMacroCell - 0.5f - qo[a]) / d);
    else if (d < 0.0f)
      best = fminf(best, (c * kMacroCell - 0.5f - qo[a]) / d);
  }
  return best;
}

}  // namespace cdsm
