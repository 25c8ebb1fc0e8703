#include "cluster/focus.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "cluster/convex.h"
#include "cluster/light_views.h"

namespace cdsm::cluster {
namespace {

constexpr float kPi = 3.14159265358979f;

// A pyramid of directions from the light (planes through it) with its cross
// section at unit distance, or (no planes) all directions.
struct Region {
  std::vector<Plane> planes;
  Polygon cross;  // unit-distance cross section; empty when unbounded
};

Region make_region(Vec3 eye, Vec3 axis, Vec3 up_hint, float tan_half, int sides, std::vector<Plane> planes) {
  // The base polygon circumscribes the circle (sides > 4) or is the square
  // (sides == 4) of radius tan_half around the axis, clipped by the planes.
  Vec3 r, u;
  make_frame(axis, up_hint, r, u);
  Region reg;
  reg.planes = std::move(planes);
  if (sides == 4) {
    reg.cross = {eye + axis + (-r - u) * tan_half, eye + axis + (r - u) * tan_half, eye + axis + (r + u) * tan_half,
                 eye + axis + (-r + u) * tan_half};
  } else {
    const float rad = tan_half / std::cos(kPi / float(sides));
    for (int i = 0; i < sides; ++i) {
      float phi = 2.0f * kPi * (float(i) + 0.5f) / float(sides);
      reg.cross.push_back(eye + axis + (r * std::cos(phi) + u * std::sin(phi)) * rad);
    }
  }
  for (const Plane& pl : reg.planes) reg.cross = clip_polygon(reg.cross, pl, 1e-6f);
  return reg;
}

// Points whose window holds the lit part of a member. A member reaching the
// light contributes the region's whole cross section (every direction of it
// starts inside the member) plus its vertices away from the light; clipped
// vertices near the apex would carry the clipping tolerance into angles.
std::vector<Vec3> member_points(const Box3& box, Vec3 eye, const Region& reg, float min_near, bool& at_light) {
  std::vector<Vec3> out;
  if (reg.planes.empty()) {
    for (int i = 0; i < 8; ++i) out.push_back(box.corner(i));
    return out;
  }
  ConvexBody body = box_body(box);
  body.clip(reg.planes);
  if (body.empty()) return out;
  const float diag = length(box.extent());
  Vec3 q = vmin(vmax(eye, box.lo), box.hi);  // closest point of the box
  if (length(q - eye) > std::max(min_near, 0.01f * diag)) return body.vertices();
  at_light = true;
  const float s = std::max(2.0f * min_near, 0.05f * diag);
  for (Vec3 p : reg.cross) out.push_back(eye + (p - eye) * s);
  for (Vec3 p : body.vertices())
    if (length(p - eye) >= 0.05f * diag) out.push_back(p);
  return out;
}

bool focus_region(Vec3 eye, const std::vector<Box3>& members, const Region& reg, Vec3 up_hint,
                  const FocusParams& params, PinholeView& out, bool& empty) {
  std::vector<Vec3> pts;
  bool at_light = false;
  for (const Box3& b : members) {
    std::vector<Vec3> p = member_points(b, eye, reg, params.min_near, at_light);
    pts.insert(pts.end(), p.begin(), p.end());
  }
  empty = pts.empty();
  if (empty || !focus_points(eye, pts, up_hint, params, out)) return false;
  if (at_light) out.near = params.min_near;  // the member reaches the light
  return true;
}

}  // namespace

bool focus_points(Vec3 eye, const std::vector<Vec3>& points, Vec3 up_hint, const FocusParams& params,
                  PinholeView& out) {
  if (points.empty()) return false;
  Vec3 mean{};
  for (Vec3 p : points) {
    Vec3 d = p - eye;
    if (!(length(d) > params.min_near)) return false;  // at the light: no frustum holds it
    mean += normalize(d);
  }
  if (!(length(mean) > 1e-3f * float(points.size()))) return false;
  const float cos_max = std::cos(params.max_half_angle_deg * (kPi / 180.0f));

  Vec3 f = normalize(mean), r, u;
  float lo_x = 0, hi_x = 0, lo_y = 0, hi_y = 0, z_lo = 0, z_hi = 0;
  for (int iter = 0; iter < 4; ++iter) {
    make_frame(f, up_hint, r, u);
    lo_x = lo_y = z_lo = 1e30f;
    hi_x = hi_y = z_hi = -1e30f;
    for (Vec3 p : points) {
      Vec3 d = p - eye;
      float za = dot(d, f);
      if (!(za > cos_max * length(d))) return false;  // beyond the half-angle limit
      float sx = dot(d, r) / za, sy = dot(d, u) / za;
      lo_x = std::min(lo_x, sx), hi_x = std::max(hi_x, sx);
      lo_y = std::min(lo_y, sy), hi_y = std::max(hi_y, sy);
      z_lo = std::min(z_lo, za), z_hi = std::max(z_hi, za);
    }
    if (iter == 3) break;
    // Re-aim through the window centre; the frame stays orthonormal.
    f = normalize(f + r * (0.5f * (lo_x + hi_x)) + u * (0.5f * (lo_y + hi_y)));
  }

  PinholeView v;
  v.eye = eye;
  v.forward = f;
  v.right = r;
  v.up = u;
  v.center = {0.5f * (lo_x + hi_x), 0.5f * (lo_y + hi_y)};  // the residual offset
  // A little more than the guard band so rounding never eats into it.
  const float guard = params.guard_texels + 0.01f;
  v.tan_half_x = widen_for_guard(std::max(0.5f * (hi_x - lo_x), 1e-6f), params.resolution, guard);
  v.tan_half_y = widen_for_guard(std::max(0.5f * (hi_y - lo_y), 1e-6f), params.resolution, guard);
  v.near = std::max(params.min_near, z_lo * (1.0f - 1e-4f));
  v.far = std::max(v.near * (1.0f + 1e-4f), z_hi * (1.0f + 1e-4f) + 1e-6f);
  v.width = v.height = params.resolution;
  out = v;
  return true;
}

FocusResult focus_cluster(const LightShape& light, const std::vector<Box3>& members, const FocusParams& params) {
  FocusResult res;
  if (light.directional) {  // parallel light reaches every member: one orthographic window
    std::vector<Vec3> pts;
    for (const Box3& b : members)
      for (int i = 0; i < 8; ++i) pts.push_back(b.corner(i));
    if (!pts.empty())
      res.views.push_back(directional_focus(light.direction, pts, params.resolution, params.guard_texels));
    return res;
  }
  const Vec3 eye = light.position;
  // The spot's cone (circumscribed pyramid) and square frustum, all through
  // the light; none for a point light or a cone of 90° or more.
  std::vector<Plane> cone = cone_planes(light);
  const bool coned = !cone.empty();
  PinholeView sv = spot_view(light, params.resolution, params.min_near, 1.0f);
  if (coned && light.outer_cone_deg < 89.0f) {
    std::vector<Plane> sq = frustum_planes(sv, false);
    cone.insert(cone.end(), sq.begin(), sq.end());
  }

  const Vec3 hint = coned ? sv.up : vec3(0, 1, 0);
  Region whole =
      coned ? make_region(eye, sv.forward, sv.up, std::tan(light.outer_cone_deg * (kPi / 180.0f)), 64, cone) : Region{};
  PinholeView v;
  bool empty = false;
  if (focus_region(eye, members, whole, hint, params, v, empty)) {
    res.views.push_back(v);
    return res;
  }
  if (empty) return res;  // nothing of the members is lit

  // Too wide or containing the light: one focused frustum per cube face.
  res.split = true;
  const auto faces = cube_face_views(eye, params.min_near, 1.0f, params.resolution);
  for (const PinholeView& face : faces) {
    PinholeView exact = face;  // the face without its guard band
    exact.tan_half_x = exact.tan_half_y = 1.0f;
    std::vector<Plane> planes = frustum_planes(exact, false);
    planes.insert(planes.end(), cone.begin(), cone.end());
    Region reg = make_region(eye, face.forward, face.up, 1.0f, 4, planes);
    if (reg.cross.size() < 3) continue;  // the cone misses this face
    PinholeView fv;
    bool none = false;
    if (focus_region(eye, members, reg, face.up, params, fv, none)) {
      res.views.push_back(fv);
    } else if (!none) {  // not expected for a 90° piece: keep the plain face
      float z_hi = 2.0f * params.min_near;
      for (const Box3& b : members)
        for (int i = 0; i < 8; ++i) z_hi = std::max(z_hi, dot(b.corner(i) - eye, face.forward));
      PinholeView plain = face;
      plain.far = z_hi * (1.0f + 1e-4f);
      res.views.push_back(plain);
    }
  }
  return res;
}

bool same_view(const PinholeView& a, const PinholeView& b) { return std::memcmp(&a, &b, sizeof(PinholeView)) == 0; }

}  // namespace cdsm::cluster
