// Watertight ray-triangle intersection (Woop, Benthin, Wald 2013) with a tie
// rule, so a ray through a shared edge or vertex hits exactly one of the
// triangles sharing it (DESIGN.md §2.1).
#pragma once

#include "cdsm/math.h"

namespace cdsm {

// Per-ray constants of the watertight test: the axis permutation and shear
// that map the ray onto +z through the origin.
struct WatertightRay {
  Vec3 org;
  int kx, ky, kz;
  float sx, sy, sz;
};

CDSM_HD CDSM_INLINE WatertightRay make_watertight_ray(Vec3 org, Vec3 dir) {
  WatertightRay r;
  r.org = org;
  float ax = fabsf(dir.x), ay = fabsf(dir.y), az = fabsf(dir.z);
  r.kz = (ax > ay) ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2);
  r.kx = r.kz == 2 ? 0 : r.kz + 1;
  r.ky = r.kx == 2 ? 0 : r.kx + 1;
  if (dir[r.kz] < 0.0f) {  // keep winding: swap kx, ky
    int t = r.kx;
    r.kx = r.ky;
    r.ky = t;
  }
  r.sx = dir[r.kx] / dir[r.kz];
  r.sy = dir[r.ky] / dir[r.kz];
  r.sz = 1.0f / dir[r.kz];
  return r;
}

struct TriHit {
  float t;     // ray parameter (distance along a unit direction)
  bool front;  // the ray sees the counter-clockwise side
};

// The tie rule: an edge function that is exactly zero counts as inside iff
// moving the ray by an infinitesimal (+x, then +y) in sheared space moves it
// inside that edge, with edges oriented so the interior has positive values.
// Each point then belongs to exactly one triangle of a consistently wound fan.
CDSM_HD CDSM_INLINE bool tie_accepts(double gx, double gy, double orient) {
  gx *= orient;
  gy *= orient;
  return gx > 0.0 || (gx == 0.0 && gy > 0.0);
}

// Intersects ray `r` with triangle (a, b, c) for t in (tmin, tmax].
// Edge functions are evaluated in double: products of floats are exact there,
// so the sign (and exact zero) of each edge function is exact, and shared
// edges evaluate to exactly opposite values in the two triangles.
CDSM_HD inline bool intersect_triangle(const WatertightRay& r, Vec3 a, Vec3 b, Vec3 c, float tmin, float tmax,
                                       TriHit& hit) {
  Vec3 A = a - r.org, B = b - r.org, C = c - r.org;
  float Ax = A[r.kx] - r.sx * A[r.kz];
  float Ay = A[r.ky] - r.sy * A[r.kz];
  float Bx = B[r.kx] - r.sx * B[r.kz];
  float By = B[r.ky] - r.sy * B[r.kz];
  float Cx = C[r.kx] - r.sx * C[r.kz];
  float Cy = C[r.ky] - r.sy * C[r.kz];
  double U = double(Cx) * double(By) - double(Cy) * double(Bx);
  double V = double(Ax) * double(Cy) - double(Ay) * double(Cx);
  double W = double(Bx) * double(Ay) - double(By) * double(Ax);
  if ((U < 0.0 || V < 0.0 || W < 0.0) && (U > 0.0 || V > 0.0 || W > 0.0)) return false;
  double det = U + V + W;
  if (det == 0.0) return false;  // edge-on or degenerate
  double orient = det > 0.0 ? 1.0 : -1.0;
  // Gradients of U, V, W with respect to the ray's (x, y) position.
  if (U == 0.0 && !tie_accepts(double(Cy) - By, double(Bx) - Cx, orient)) return false;
  if (V == 0.0 && !tie_accepts(double(Ay) - Cy, double(Cx) - Ax, orient)) return false;
  if (W == 0.0 && !tie_accepts(double(By) - Ay, double(Ax) - Bx, orient)) return false;
  float Az = r.sz * A[r.kz], Bz = r.sz * B[r.kz], Cz = r.sz * C[r.kz];
  double T = U * Az + V * Bz + W * Cz;
  double t = T / det;
  if (!(t > double(tmin) && t <= double(tmax))) return false;
  hit.t = float(t);
  // det > 0 <=> the ray sees the counter-clockwise side (front face); the
  // axis swap in make_watertight_ray keeps this independent of the ray.
  hit.front = det > 0.0;
  return true;
}

}  // namespace cdsm
