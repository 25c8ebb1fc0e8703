// Light-space perspective transform (Wimmer et al. 2004, thesis §2.4.2) of
// one light direction, used to measure caster distances for clustering
// (thesis §3.4.1). Host code.
//
// The light (a spot frustum or one cube face) is a perspective view, so the
// transform is built in the light's post-perspective space, where its rays
// are parallel (thesis §2.4.2: "a point light can be treated as a
// directional light source"). There, the light-space axes are
//   y: towards the light (the post-perspective depth axis),
//   z: the camera's view direction projected perpendicular to the light,
//   x: completing the frame,
// so x and z span the light's image plane, and the depth axis y never enters
// the shadow map's 2D coordinates. The frustum P looks along z with its
// apex n before B's near extent; the map coordinates are P's x after the
// divide and P's normalized depth, both scaled to [-1, 1] over B.
#pragma once

#include "cdsm/math.h"
#include "cluster/convex.h"
#include "hd/view.h"

namespace cdsm::cluster {

struct LispsmParams {
  // Below this sin(gamma) (gamma = angle between the view direction and the
  // light direction) the warp degenerates: use the uniform light space.
  float min_sin_gamma = 0.1f;
};

// World point -> normalized 2D shadow-map coordinates of one light direction.
struct LispsmMap {
  bool valid = false;        // false: B was empty, nothing maps
  bool perspective = false;  // true: LiSPSM warp; false: uniform light space
  float sin_gamma = 0.0f;    // of the view direction against the light ray through B
  float n = 0.0f;            // P's near distance (light image-plane tangent units)
  float f = 0.0f;            // P's far distance (same units)

  PinholeView light;  // the light direction's frustum (window = image plane)
  // Image-plane frame: a = dot(s, ex), b = dot(s, ez), where s are the
  // window-normalized image coordinates ([-1, 1] across the window).
  Vec2 ex{1, 0}, ez{0, 1};
  float apex_a = 0.0f;  // P's apex, image-plane a coordinate
  float apex_b = 0.0f;  // P's apex, image-plane b coordinate (= b_min - n)
  // Final affine scale to [-1, 1] over B: out = (raw - mid) / half.
  Vec2 mid{0, 0}, half{1, 1};

  // Maps a world point; false (out untouched) when it lies behind the light
  // or behind P's apex. Points of B map into [-1, 1]^2.
  bool map(Vec3 world, Vec2& out) const;
};

// The uniform map of a light frustum: window-normalized image coordinates
// ([-1, 1] across the window), no warp, no fit to a body.
LispsmMap uniform_light_map(const PinholeView& light);

// Builds the map of one light direction from the camera view and the body B
// of that direction (lispsm_body()). n = (z_n + sqrt(z_f z_n)) / sin(gamma)
// (Wimmer et al.), with z_n, z_f the camera's near/far restricted to B's
// extent along the view axis, converted to image-plane units by the ratio
// of B's extent on the image plane to its world extent across the light.
LispsmMap build_lispsm(const PinholeView& camera, const PinholeView& light, const ConvexBody& body,
                       const LispsmParams& params = {});

}  // namespace cdsm::cluster
