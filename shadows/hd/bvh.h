// Iterative, fixed-stack BVH traversal visiting every triangle hit along a
// ray (fragment generation needs all crossings, not the closest one).
#pragma once

#include "hd/raytri.h"
#include "hd/scene_data.h"

namespace cdsm {

// Slab test: does the ray enter box [lo, hi] within [tmin, tmax]?
CDSM_HD CDSM_INLINE bool ray_box(Vec3 org, Vec3 inv_dir, Vec3 lo, Vec3 hi, float tmin, float tmax) {
  float t0 = (lo.x - org.x) * inv_dir.x, t1 = (hi.x - org.x) * inv_dir.x;
  tmin = fmaxf(tmin, fminf(t0, t1));
  tmax = fminf(tmax, fmaxf(t0, t1));
  t0 = (lo.y - org.y) * inv_dir.y;
  t1 = (hi.y - org.y) * inv_dir.y;
  tmin = fmaxf(tmin, fminf(t0, t1));
  tmax = fminf(tmax, fmaxf(t0, t1));
  t0 = (lo.z - org.z) * inv_dir.z;
  t1 = (hi.z - org.z) * inv_dir.z;
  tmin = fmaxf(tmin, fminf(t0, t1));
  tmax = fminf(tmax, fmaxf(t0, t1));
  return tmin <= tmax;
}

CDSM_HD CDSM_INLINE Vec3 safe_inverse(Vec3 d) {
  // Infinite slopes are fine in the slab test as long as 0 * inf is avoided:
  // nudge exact zeros to a tiny value of the same sign convention.
  const float tiny = 1e-30f;
  return {1.0f / (fabsf(d.x) > tiny ? d.x : tiny), 1.0f / (fabsf(d.y) > tiny ? d.y : tiny),
          1.0f / (fabsf(d.z) > tiny ? d.z : tiny)};
}

// Calls visit(triangle, TriHit) for every triangle of an object in `mask`
// crossed by the ray org + t*dir, t in (tmin, tmax]. `dir` must be unit length
// so t is the radial depth. Returns false if the traversal stack overflowed
// (then some hits may be missing; callers count it).
template <class Visit>
CDSM_HD bool for_each_hit(const SceneView& s, ObjectMask mask, Vec3 org, Vec3 dir, float tmin, float tmax,
                          Visit&& visit) {
  if (s.bvh.empty()) return true;
  WatertightRay wr = make_watertight_ray(org, dir);
  Vec3 inv = safe_inverse(dir);
  // Boxes are padded by a relative epsilon so float rounding in the slab test
  // never culls a triangle the exact test would hit.
  uint32_t stack[kBvhStackSize];
  int sp = 0;
  stack[sp++] = 0;
  bool ok = true;
  while (sp > 0) {
    const BvhNode& n = s.bvh[stack[--sp]];
    if (!ray_box(org, inv, n.lo, n.hi, tmin, tmax)) continue;
    if (n.count > 0) {
      for (uint32_t i = 0; i < n.count; ++i) {
        uint32_t tri = s.bvh_prims[n.first + i];
        if (!mask.contains(s.tri_object[tri])) continue;
        TriHit h;
        if (intersect_triangle(wr, s.tri_vertices[3 * tri], s.tri_vertices[3 * tri + 1], s.tri_vertices[3 * tri + 2],
                               tmin, tmax, h))
          visit(tri, h);
      }
    } else {
      uint32_t self = uint32_t(&n - s.bvh.data());
      if (sp + 2 > kBvhStackSize) {
        ok = false;
        continue;
      }
      stack[sp++] = n.first;
      stack[sp++] = self + 1;
    }
  }
  return ok;
}

}  // namespace cdsm
