// Convex polygon clipping and convex bodies in 3D (host code). Used to
// build the body B of light-space perspective shadow maps (thesis Alg. 4.3)
// and to cut caster boxes by B, by a spot cone or by a cube face.
#pragma once

#include <vector>

#include "cdsm/math.h"
#include "hd/view.h"

namespace cdsm::cluster {

// The plane dot(n, p) + d = 0. The kept ("inner") side is dot(n, p) + d >= 0.
// `n` need not be unit length; signed distances are then scaled by |n|.
struct Plane {
  Vec3 n;
  float d = 0.0f;
};

inline float signed_distance(const Plane& pl, Vec3 p) { return dot(pl.n, p) + pl.d; }

// The plane through `point` whose inner side is the one `inward` points to
// (normalized).
Plane plane_through(Vec3 point, Vec3 inward);

// A planar convex polygon, vertices in order.
using Polygon = std::vector<Vec3>;

// Sutherland-Hodgman against one plane: the part of `poly` on the inner side
// (possibly empty). Every vertex of the result that lies on the plane
// (created by the cut, or an original vertex within `tol`) is appended to
// `cut` when it is given. Zero-length edges of the result are removed.
Polygon clip_polygon(const Polygon& poly, const Plane& plane, float tol, std::vector<Vec3>* cut = nullptr);

// Newell normal of a polygon (length = twice its area); with counter-clockwise
// vertices seen from outside it points outwards.
Vec3 polygon_normal(const Polygon& poly);

// A closed convex body given by its boundary polygons, each counter-clockwise
// seen from outside (outward Newell normals). Empty when it has no polygons.
struct ConvexBody {
  std::vector<Polygon> polygons;

  bool empty() const { return polygons.empty(); }

  // Keeps the part on the inner side of `plane` and closes the hole with a
  // cap: the convex hull of the new vertices on the plane, ordered so that
  // its normal points outwards (-plane.n).
  void clip(const Plane& plane);
  void clip(const std::vector<Plane>& planes);

  // The planes of the boundary polygons, inner side inside the body
  // (degenerate polygons skipped).
  std::vector<Plane> planes() const;
  // Distinct vertices (welded within a tolerance relative to the body size).
  std::vector<Vec3> vertices() const;
  Box3 bounds() const;
  // Whether `p` is on the inner side of every polygon's plane within `tol`
  // (world units). An empty body contains nothing.
  bool contains(Vec3 p, float tol = 1e-4f) const;
  // Tolerance used by clipping and welding: a small fraction of the size.
  float tolerance() const;
};

ConvexBody box_body(const Box3& box);

// The six planes bounding a box, inner side inside.
std::vector<Plane> box_planes(const Box3& box);

// The 8 corners of a view's clipping volume: window corners (center offset
// included) at the axial distances near and far (orthographic views: a box). Index bit 0: +x, bit 1: +y,
// bit 2: far.
void frustum_corners(const PinholeView& v, Vec3 out[8]);
ConvexBody frustum_body(const PinholeView& v);

// The planes of a view's clipping volume: left, right, bottom, top (all
// through the eye; parallel to the view axis when orthographic), then near
// and far when `with_depth`.
std::vector<Plane> frustum_planes(const PinholeView& v, bool with_depth = true);

// The convex hull of `body` and one more point: the faces the point sees
// are replaced by triangles from the point to the horizon edges.
ConvexBody hull_with_point(const ConvexBody& body, Vec3 point);

// The body B of light-space perspective shadow maps (thesis Alg. 4.3):
// hull(camera frustum U light position) clipped by the scene box and, when
// `light_frustum` is given, by that light frustum (a spot's frustum or one
// cube face of an omni light; pass nullptr for a point light as a whole).
ConvexBody lispsm_body(const PinholeView& camera, Vec3 light_position, const Box3& scene,
                       const PinholeView* light_frustum);

// The same for a directional light travelling along `direction`: the camera
// frustum swept toward the light (its hull with the frustum's corners moved
// up the beam past the scene box), clipped by the scene box and the light's
// orthographic view when given.
ConvexBody lispsm_body_directional(const PinholeView& camera, Vec3 direction, const Box3& scene,
                                   const PinholeView* light_frustum);

}  // namespace cdsm::cluster
