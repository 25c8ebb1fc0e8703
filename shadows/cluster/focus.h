// Focusing a light frustum on a cluster (thesis §3.4.2): re-aim the view
// at the members, narrow the field of view in x and y to the smallest
// window holding them plus a guard band, fit near/far to their extent.
// Host code.
#pragma once

#include <vector>

#include "cdsm/math.h"
#include "cluster/light_views.h"
#include "hd/view.h"

namespace cdsm::cluster {

struct FocusParams {
  int resolution = 512;              // DSM texels per side
  float guard_texels = 1.0f;         // kept free on every side (>= 1 for bilinear taps)
  float max_half_angle_deg = 60.0f;  // wider clusters (> ~120°) are split per cube face
  float min_near = 1e-3f;            // near plane clamp, world units
};

struct FocusResult {
  // One focused frustum, or (split) one per cube face the cluster occupies.
  // Empty when nothing of the members is lit (all outside a spot's cone).
  std::vector<PinholeView> views;
  bool split = false;  // the cluster spans more than ~120° around the light or contains it
};

// Smallest off-centre window from `eye` holding every point, re-aimed so the
// window is nearly centred, with the guard band, near/far fitted to the
// points' axial extent. False (out untouched) when a point lies within
// min_near of the eye or further than max_half_angle_deg from the axis.
bool focus_points(Vec3 eye, const std::vector<Vec3>& points, Vec3 up_hint, const FocusParams& params, PinholeView& out);

// Focuses the light on a cluster's member boxes. A spot light's members are
// first cut by its cone (and its square frustum), so the focused window never
// exceeds the spot's. A cluster that fails focus_points() is cut per cube
// face and focused face by face (split = true). A directional light's
// cluster gets one orthographic window over its members (directional_focus).
FocusResult focus_cluster(const LightShape& light, const std::vector<Box3>& members, const FocusParams& params);

// Whether two views are identical (bit for bit in every field).
bool same_view(const PinholeView& a, const PinholeView& b);

}  // namespace cdsm::cluster
