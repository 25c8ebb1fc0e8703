// Binned-SAH BVH over the scene's world-space triangles.
#include <algorithm>
#include <cmath>

#include "scene/scene_buffers.h"

namespace cdsm {
namespace {

constexpr int kBins = 16;
constexpr uint32_t kLeafSize = 4;

// The bin of centroid coordinate c in [lo, hi] (hi > lo): computed as a
// relative position and clamped in float before any conversion, so extreme
// extents (hi - lo below float's range or beyond it: tiny, denormal or huge
// objects) give a bin in [0, kBins) — never int(NaN) or int(inf).
int bin_of(float c, float lo, float hi) {
  float f = (c - lo) / (hi - lo) * float(kBins);
  if (!(f > 0.0f)) return 0;  // also NaN
  if (f >= float(kBins - 1)) return kBins - 1;
  return int(f);
}

struct Builder {
  SceneBuffers& sb;
  std::vector<Box3> tri_box;
  std::vector<Vec3> tri_center;

  static float area(const Box3& b) {
    if (b.empty()) return 0.0f;
    Vec3 e = b.extent();
    return 2.0f * (e.x * e.y + e.y * e.z + e.z * e.x);
  }

  // Pads a box so float rounding in the slab test never culls a hit.
  static Box3 padded(Box3 b) {
    Vec3 e = b.extent();
    float pad = 1e-5f * std::max({e.x, e.y, e.z, std::fabs(b.lo.x), std::fabs(b.lo.y), std::fabs(b.lo.z),
                                  std::fabs(b.hi.x), std::fabs(b.hi.y), std::fabs(b.hi.z), 1e-3f});
    b.lo = b.lo - vec3(pad);
    b.hi = b.hi + vec3(pad);
    return b;
  }

  uint32_t build(uint32_t first, uint32_t count, int depth) {
    uint32_t node = uint32_t(sb.bvh.size());
    sb.bvh.push_back({});
    Box3 bounds, cbounds;
    for (uint32_t i = first; i < first + count; ++i) {
      bounds.grow(tri_box[sb.bvh_prims[i]]);
      cbounds.grow(tri_center[sb.bvh_prims[i]]);
    }
    Box3 pb = padded(bounds);
    auto make_leaf = [&] {
      sb.bvh[node] = BvhNode{pb.lo, first, pb.hi, count};
      return node;
    };
    if (count <= kLeafSize || depth >= kBvhStackSize / 2 - 2) return make_leaf();
    // Best split over the three axes, binned by centroid.
    float best_cost = area(bounds) * float(count);
    int best_axis = -1, best_bin = 0;
    for (int axis = 0; axis < 3; ++axis) {
      float lo = cbounds.lo[axis], hi = cbounds.hi[axis];
      if (!(hi > lo)) continue;
      Box3 bin_box[kBins];
      uint32_t bin_n[kBins] = {};
      for (uint32_t i = first; i < first + count; ++i) {
        uint32_t t = sb.bvh_prims[i];
        int b = bin_of(tri_center[t][axis], lo, hi);
        bin_box[b].grow(tri_box[t]);
        ++bin_n[b];
      }
      float right_area[kBins];
      uint32_t right_n[kBins];
      Box3 acc;
      uint32_t n = 0;
      for (int b = kBins - 1; b > 0; --b) {
        acc.grow(bin_box[b]);
        n += bin_n[b];
        right_area[b] = area(acc);
        right_n[b] = n;
      }
      acc = Box3{};
      n = 0;
      for (int b = 0; b < kBins - 1; ++b) {
        acc.grow(bin_box[b]);
        n += bin_n[b];
        if (n == 0 || right_n[b + 1] == 0) continue;
        float cost = area(acc) * float(n) + right_area[b + 1] * float(right_n[b + 1]);
        if (cost < best_cost) {
          best_cost = cost;
          best_axis = axis;
          best_bin = b;
        }
      }
    }
    uint32_t mid;
    if (best_axis < 0) {
      if (count <= 16) return make_leaf();
      // No useful SAH split (e.g. identical centroids): median split.
      int axis = 0;
      Vec3 e = cbounds.extent();
      if (e.y > e.x) axis = 1;
      if (e.z > e[axis]) axis = 2;
      mid = first + count / 2;
      std::nth_element(sb.bvh_prims.begin() + first, sb.bvh_prims.begin() + mid, sb.bvh_prims.begin() + first + count,
                       [&](uint32_t a, uint32_t b) { return tri_center[a][axis] < tri_center[b][axis]; });
    } else {
      const float lo = cbounds.lo[best_axis], hi = cbounds.hi[best_axis];
      auto it = std::partition(sb.bvh_prims.begin() + first, sb.bvh_prims.begin() + first + count,
                               [&](uint32_t t) { return bin_of(tri_center[t][best_axis], lo, hi) <= best_bin; });
      mid = uint32_t(it - sb.bvh_prims.begin());
      if (mid == first || mid == first + count) mid = first + count / 2;
    }
    build(first, mid - first, depth + 1);  // left child at node + 1
    uint32_t right = build(mid, first + count - mid, depth + 1);
    sb.bvh[node] = BvhNode{pb.lo, right, pb.hi, 0};
    return node;
  }
};

}  // namespace

void build_bvh(SceneBuffers& sb) {
  sb.bvh.clear();
  uint32_t n = uint32_t(sb.tri_object.size());
  sb.bvh_prims.resize(n);
  if (n == 0) return;
  Builder b{sb, std::vector<Box3>(n), std::vector<Vec3>(n)};
  for (uint32_t t = 0; t < n; ++t) {
    sb.bvh_prims[t] = t;
    for (int k = 0; k < 3; ++k) b.tri_box[t].grow(sb.tri_vertices[3 * t + k]);
    b.tri_center[t] = b.tri_box[t].lo * 0.5f + b.tri_box[t].hi * 0.5f;  // no overflow at +-3e38
  }
  sb.bvh.reserve(2 * n / kLeafSize + 1);
  b.build(0, n, 0);
}

}  // namespace cdsm

namespace cdsm {
namespace {

// In double: boxes of 1e19 units and more (a ground scaled by 1e20) have
// areas beyond float.
double half_area(const Box3& b) {
  if (b.empty()) return 0.0;
  const Vec3 e = b.extent();
  return double(e.x) * e.y + double(e.y) * e.z + double(e.z) * e.x;
}

}  // namespace

double refit_bvh(SceneBuffers& sb, std::vector<IndexRange>* changed) {
  // Pre-order layout: both children of node i come after i (left = i + 1,
  // right = first), so one backward sweep sees children before parents.
  if (changed) changed->clear();
  for (size_t i = sb.bvh.size(); i-- > 0;) {
    BvhNode& n = sb.bvh[i];
    Box3 b;
    if (n.count > 0) {
      for (uint32_t k = n.first; k < n.first + n.count; ++k) {
        const uint32_t t = sb.bvh_prims[k];
        for (int v = 0; v < 3; ++v) b.grow(sb.tri_vertices[3 * size_t(t) + v]);
      }
    } else {
      const BvhNode& l = sb.bvh[i + 1];
      const BvhNode& r = sb.bvh[n.first];
      b.grow(l.lo);
      b.grow(l.hi);
      b.grow(r.lo);
      b.grow(r.hi);
    }
    const bool moved = !(n.lo.x == b.lo.x && n.lo.y == b.lo.y && n.lo.z == b.lo.z && n.hi.x == b.hi.x &&
                         n.hi.y == b.hi.y && n.hi.z == b.hi.z);
    n.lo = b.lo;
    n.hi = b.hi;
    if (moved && changed) {  // runs, found backwards: extend the last one down
      if (!changed->empty() && changed->back().first == uint32_t(i) + 1) {
        --changed->back().first;
        ++changed->back().count;
      } else {
        changed->push_back({uint32_t(i), 1u});
      }
    }
  }
  return bvh_cost(sb);
}

double bvh_cost(const SceneBuffers& sb) {
  if (sb.bvh.empty()) return 0.0;
  const double root = half_area(Box3{sb.bvh[0].lo, sb.bvh[0].hi});
  if (!(root > 0.0)) return 0.0;
  double c = 0.0;
  for (const BvhNode& n : sb.bvh) c += half_area(Box3{n.lo, n.hi}) * (n.count > 0 ? double(n.count) : 1.0);
  return c / root;
}

}  // namespace cdsm
