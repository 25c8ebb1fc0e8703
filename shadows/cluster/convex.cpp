#include "cluster/convex.h"

#include <algorithm>
#include <cmath>

namespace cdsm::cluster {
namespace {

float max_abs(Vec3 p) { return std::max(std::fabs(p.x), std::max(std::fabs(p.y), std::fabs(p.z))); }

// Drops vertices within `tol` of their predecessor (cyclically) and vertices
// that lie on the segment between their neighbours within `tol`.
void tidy(Polygon& poly, float tol) {
  Polygon out;
  out.reserve(poly.size());
  for (Vec3 p : poly)
    if (out.empty() || length(p - out.back()) > tol) out.push_back(p);
  while (out.size() > 1 && length(out.front() - out.back()) <= tol) out.pop_back();
  bool removed = true;
  while (removed && out.size() >= 3) {
    removed = false;
    for (size_t i = 0; i < out.size(); ++i) {
      Vec3 a = out[(i + out.size() - 1) % out.size()], b = out[i], c = out[(i + 1) % out.size()];
      Vec3 ac = c - a;
      float l = length(ac);
      if (l <= tol) continue;
      if (length(cross(b - a, ac)) / l <= tol && dot(b - a, ac) >= 0.0f && dot(c - b, ac) >= 0.0f) {
        out.erase(out.begin() + long(i));
        removed = true;
        break;
      }
    }
  }
  poly = out.size() >= 3 ? std::move(out) : Polygon{};
}

// Points welded within `tol` (first occurrence kept).
std::vector<Vec3> weld(const std::vector<Vec3>& pts, float tol) {
  std::vector<Vec3> out;
  for (Vec3 p : pts) {
    bool dup = false;
    for (Vec3 q : out)
      if (length(p - q) <= tol) {
        dup = true;
        break;
      }
    if (!dup) out.push_back(p);
  }
  return out;
}

// Convex hull of coplanar points on `plane`, ordered counter-clockwise seen
// from the outer side (normal -plane.n). Andrew's monotone chain in a 2D
// basis of the plane.
Polygon cap_polygon(const std::vector<Vec3>& cut, const Plane& plane, float tol) {
  std::vector<Vec3> pts = weld(cut, tol);
  if (pts.size() < 3) return {};
  Vec3 n = normalize(plane.n);
  Vec3 u = normalize(std::fabs(n.x) < 0.9f ? cross(n, vec3(1, 0, 0)) : cross(n, vec3(0, 1, 0)));
  Vec3 v = cross(u, n);  // cross(u, v) = -n: counter-clockwise in (u, v) faces -n
  struct P2 {
    float x, y;
    Vec3 p;
  };
  std::vector<P2> q;
  q.reserve(pts.size());
  for (Vec3 p : pts) q.push_back({dot(p, u), dot(p, v), p});
  std::sort(q.begin(), q.end(), [](const P2& a, const P2& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
  auto turn = [](const P2& o, const P2& a, const P2& b) {
    return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
  };
  std::vector<P2> h(2 * q.size());
  size_t k = 0;
  for (size_t i = 0; i < q.size(); ++i) {  // lower chain
    while (k >= 2 && turn(h[k - 2], h[k - 1], q[i]) <= 0.0f) --k;
    h[k++] = q[i];
  }
  for (size_t i = q.size() - 1, lo = k + 1; i-- > 0;) {  // upper chain
    while (k >= lo && turn(h[k - 2], h[k - 1], q[i]) <= 0.0f) --k;
    h[k++] = q[i];
  }
  Polygon out;
  for (size_t i = 0; i + 1 < k; ++i) out.push_back(h[i].p);
  tidy(out, tol);
  return out;
}

// Fixes the winding of `poly` so that its normal points away from `inside`.
void orient_outwards(Polygon& poly, Vec3 inside) {
  Vec3 c{};
  for (Vec3 p : poly) c += p;
  c = c / float(poly.size());
  if (dot(polygon_normal(poly), c - inside) < 0.0f) std::reverse(poly.begin(), poly.end());
}

}  // namespace

Plane plane_through(Vec3 point, Vec3 inward) {
  Vec3 n = normalize(inward);
  return {n, -dot(n, point)};
}

Polygon clip_polygon(const Polygon& poly, const Plane& plane, float tol, std::vector<Vec3>* cut) {
  Polygon out;
  const size_t n = poly.size();
  if (n == 0) return out;
  const float t = tol * length(plane.n);  // tolerance in signed-distance units
  for (size_t i = 0; i < n; ++i) {
    Vec3 a = poly[i], b = poly[(i + 1) % n];
    float da = signed_distance(plane, a), db = signed_distance(plane, b);
    if (da >= -t) {
      out.push_back(a);
      if (cut && da <= t) cut->push_back(a);
    }
    if ((da > t && db < -t) || (da < -t && db > t)) {
      Vec3 p = a + (b - a) * (da / (da - db));
      out.push_back(p);
      if (cut) cut->push_back(p);
    }
  }
  tidy(out, tol);
  return out;
}

Vec3 polygon_normal(const Polygon& poly) {
  Vec3 n{};
  const size_t k = poly.size();
  for (size_t i = 0; i < k; ++i) {
    Vec3 a = poly[i], b = poly[(i + 1) % k];
    n.x += (a.y - b.y) * (a.z + b.z);
    n.y += (a.z - b.z) * (a.x + b.x);
    n.z += (a.x - b.x) * (a.y + b.y);
  }
  return n;
}

float ConvexBody::tolerance() const {
  Box3 b = bounds();
  if (b.empty()) return 1e-6f;
  return 1e-5f * length(b.extent()) + 4e-7f * std::max(max_abs(b.lo), max_abs(b.hi)) + 1e-9f;
}

void ConvexBody::clip(const Plane& plane) {
  if (polygons.empty()) return;
  const float tol = tolerance();
  const float t = tol * length(plane.n);
  bool any_out = false, any_in = false;
  for (const Polygon& poly : polygons)
    for (Vec3 p : poly) {
      float d = signed_distance(plane, p);
      any_out |= d < -t;
      any_in |= d > t;
    }
  if (!any_out) return;  // entirely inside: unchanged
  if (!any_in) {         // entirely outside, or flattened onto the plane
    polygons.clear();
    return;
  }
  std::vector<Vec3> cut;
  std::vector<Polygon> kept;
  kept.reserve(polygons.size() + 1);
  for (const Polygon& poly : polygons) {
    Polygon c = clip_polygon(poly, plane, tol, &cut);
    if (c.size() >= 3) kept.push_back(std::move(c));
  }
  Polygon cap = cap_polygon(cut, plane, tol);
  if (cap.size() >= 3) kept.push_back(std::move(cap));
  polygons = std::move(kept);
  if (polygons.size() < 4) polygons.clear();  // no volume left
}

void ConvexBody::clip(const std::vector<Plane>& planes) {
  for (const Plane& pl : planes) clip(pl);
}

std::vector<Plane> ConvexBody::planes() const {
  std::vector<Plane> out;
  out.reserve(polygons.size());
  for (const Polygon& poly : polygons) {
    Vec3 n = polygon_normal(poly);
    if (length(n) > 0.0f) out.push_back(plane_through(poly[0], -n));
  }
  return out;
}

std::vector<Vec3> ConvexBody::vertices() const {
  std::vector<Vec3> all;
  for (const Polygon& poly : polygons) all.insert(all.end(), poly.begin(), poly.end());
  return weld(all, tolerance());
}

Box3 ConvexBody::bounds() const {
  Box3 b;
  for (const Polygon& poly : polygons)
    for (Vec3 p : poly) b.grow(p);
  return b;
}

bool ConvexBody::contains(Vec3 p, float tol) const {
  if (polygons.empty()) return false;
  for (const Polygon& poly : polygons) {
    Vec3 n = polygon_normal(poly);
    float l = length(n);
    if (!(l > 0.0f)) continue;
    if (dot(n, p - poly[0]) / l > tol) return false;
  }
  return true;
}

ConvexBody box_body(const Box3& box) {
  ConvexBody body;
  if (box.empty()) return body;
  // Faces as corner indices (bit 0: x, bit 1: y, bit 2: z), oriented below.
  static const int faces[6][4] = {{0, 2, 6, 4}, {1, 5, 7, 3}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 6, 7, 5}};
  Vec3 c = box.center();
  for (const auto& f : faces) {
    Polygon poly{box.corner(f[0]), box.corner(f[1]), box.corner(f[2]), box.corner(f[3])};
    orient_outwards(poly, c);
    body.polygons.push_back(std::move(poly));
  }
  return body;
}

std::vector<Plane> box_planes(const Box3& box) {
  return {plane_through(box.lo, vec3(1, 0, 0)), plane_through(box.hi, vec3(-1, 0, 0)),
          plane_through(box.lo, vec3(0, 1, 0)), plane_through(box.hi, vec3(0, -1, 0)),
          plane_through(box.lo, vec3(0, 0, 1)), plane_through(box.hi, vec3(0, 0, -1))};
}

void frustum_corners(const PinholeView& v, Vec3 out[8]) {
  for (int i = 0; i < 8; ++i) {
    float sx = v.center.x + ((i & 1) ? v.tan_half_x : -v.tan_half_x);
    float sy = v.center.y + ((i & 2) ? v.tan_half_y : -v.tan_half_y);
    float z = (i & 4) ? v.far : v.near;
    out[i] = is_orthographic(v) ? v.eye + v.right * sx + v.up * sy + v.forward * z
                                : v.eye + (v.forward + v.right * sx + v.up * sy) * z;
  }
}

ConvexBody frustum_body(const PinholeView& v) {
  Vec3 c[8];
  frustum_corners(v, c);
  static const int faces[6][4] = {{0, 2, 6, 4}, {1, 5, 7, 3}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 6, 7, 5}};
  Vec3 inside{};
  for (Vec3 p : c) inside += p;
  inside = inside / 8.0f;
  ConvexBody body;
  for (const auto& f : faces) {
    Polygon poly{c[f[0]], c[f[1]], c[f[2]], c[f[3]]};
    orient_outwards(poly, inside);
    body.polygons.push_back(std::move(poly));
  }
  return body;
}

std::vector<Plane> frustum_planes(const PinholeView& v, bool with_depth) {
  const Vec3 F = v.forward, R = v.right, U = v.up;
  if (is_orthographic(v)) {                                                                    // parallel sides
    std::vector<Plane> planes = {plane_through(v.eye + R * (v.center.x - v.tan_half_x), R),    // left
                                 plane_through(v.eye + R * (v.center.x + v.tan_half_x), -R),   // right
                                 plane_through(v.eye + U * (v.center.y - v.tan_half_y), U),    // bottom
                                 plane_through(v.eye + U * (v.center.y + v.tan_half_y), -U)};  // top
    if (with_depth) {
      planes.push_back(plane_through(v.eye + F * v.near, F));
      planes.push_back(plane_through(v.eye + F * v.far, -F));
    }
    return planes;
  }
  std::vector<Plane> planes = {plane_through(v.eye, R - F * (v.center.x - v.tan_half_x)),   // left
                               plane_through(v.eye, F * (v.center.x + v.tan_half_x) - R),   // right
                               plane_through(v.eye, U - F * (v.center.y - v.tan_half_y)),   // bottom
                               plane_through(v.eye, F * (v.center.y + v.tan_half_y) - U)};  // top
  if (with_depth) {
    planes.push_back(plane_through(v.eye + F * v.near, F));
    planes.push_back(plane_through(v.eye + F * v.far, -F));
  }
  return planes;
}

ConvexBody hull_with_point(const ConvexBody& body, Vec3 point) {
  if (body.empty()) return body;
  const float tol = body.tolerance();
  const size_t nf = body.polygons.size();
  std::vector<char> visible(nf, 0);
  bool any = false;
  for (size_t i = 0; i < nf; ++i) {
    const Polygon& poly = body.polygons[i];
    Vec3 n = polygon_normal(poly);
    float l = length(n);
    visible[i] = l > 0.0f && dot(n, point - poly[0]) / l > tol;
    any |= visible[i] != 0;
  }
  if (!any) return body;  // the point is inside
  ConvexBody out;
  for (size_t i = 0; i < nf; ++i)
    if (!visible[i]) out.polygons.push_back(body.polygons[i]);
  // Horizon: directed edges a->b of visible faces whose reverse b->a belongs
  // to no visible face. The new triangle (a, b, point) keeps the winding.
  auto same = [tol](Vec3 p, Vec3 q) { return length(p - q) <= tol; };
  for (size_t i = 0; i < nf; ++i) {
    if (!visible[i]) continue;
    const Polygon& poly = body.polygons[i];
    for (size_t e = 0; e < poly.size(); ++e) {
      Vec3 a = poly[e], b = poly[(e + 1) % poly.size()];
      bool shared = false;
      for (size_t j = 0; j < nf && !shared; ++j) {
        if (j == i || !visible[j]) continue;
        const Polygon& other = body.polygons[j];
        for (size_t k = 0; k < other.size(); ++k)
          if (same(other[k], b) && same(other[(k + 1) % other.size()], a)) {
            shared = true;
            break;
          }
      }
      if (!shared) out.polygons.push_back({a, b, point});
    }
  }
  return out;
}

ConvexBody lispsm_body_directional(const PinholeView& camera, Vec3 direction, const Box3& scene,
                                   const PinholeView* light_frustum) {
  // F = the camera frustum inside the box; B = F swept up the beam (the
  // Minkowski sum of F and the segment [0, s]) inside the box. Its planes:
  // F's faces turned away from s where they are, those facing s moved by s,
  // and through each silhouette edge (between one of each) a plane along s.
  ConvexBody f = frustum_body(camera);
  f.clip(box_planes(scene));
  if (f.empty()) return f;
  const Vec3 s = normalize(direction) * -(2.0f * length(scene.extent()) + 1.0f);
  const float tol = f.tolerance();
  Vec3 inside{};
  const std::vector<Vec3> verts = f.vertices();
  for (Vec3 p : verts) inside += p;
  inside = inside / float(std::max<size_t>(verts.size(), 1));
  std::vector<Vec3> normal(f.polygons.size());
  std::vector<char> facing(f.polygons.size(), 0), valid(f.polygons.size(), 0);
  for (size_t i = 0; i < f.polygons.size(); ++i) {
    const Vec3 n = polygon_normal(f.polygons[i]);
    const float l = length(n);
    if (!(l > 0.0f)) continue;
    normal[i] = n / l;
    valid[i] = 1;
    facing[i] = dot(normal[i], s) > 0.0f;
  }
  auto same = [tol](Vec3 p, Vec3 q) { return length(p - q) <= tol; };
  std::vector<Plane> planes = box_planes(scene);
  for (size_t i = 0; i < f.polygons.size(); ++i) {
    if (!valid[i]) continue;
    const Polygon& poly = f.polygons[i];
    planes.push_back(plane_through(facing[i] ? poly[0] + s : poly[0], -normal[i]));
    if (!facing[i]) continue;
    for (size_t e = 0; e < poly.size(); ++e) {
      const Vec3 a = poly[e], b = poly[(e + 1) % poly.size()];
      bool silhouette = true;  // the neighbour across a->b faces away (or there is none)
      for (size_t j = 0; j < f.polygons.size() && silhouette; ++j) {
        if (j == i || !valid[j]) continue;
        const Polygon& other = f.polygons[j];
        for (size_t k = 0; k < other.size(); ++k)
          if (same(other[k], b) && same(other[(k + 1) % other.size()], a)) {
            if (facing[j]) silhouette = false;
            break;
          }
      }
      if (!silhouette) continue;
      Vec3 m = cross(b - a, s);
      if (!(length(m) > 0.0f)) continue;
      if (dot(m, inside - a) < 0.0f) m = m * -1.0f;
      planes.push_back(plane_through(a, m));
    }
  }
  ConvexBody body = box_body(scene);
  body.clip(planes);
  if (light_frustum) body.clip(frustum_planes(*light_frustum));
  return body;
}

ConvexBody lispsm_body(const PinholeView& camera, Vec3 light_position, const Box3& scene,
                       const PinholeView* light_frustum) {
  ConvexBody b = hull_with_point(frustum_body(camera), light_position);
  b.clip(box_planes(scene));
  if (light_frustum) b.clip(frustum_planes(*light_frustum));
  return b;
}

}  // namespace cdsm::cluster
