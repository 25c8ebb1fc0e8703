// Plain light views (a spot's frustum, the six cube faces of a point light)
// and the camera's view, as PinholeViews (DESIGN.md §4). Host code.
#pragma once

#include <array>
#include <vector>

#include "cdsm/math.h"
#include "cluster/convex.h"
#include "hd/view.h"

namespace cdsm::cluster {

// A light as clustering and focusing see it (the engine makes it from its
// scene model's light).
struct LightShape {
  bool spot = true;          // false: a point (omni) or directional light
  bool directional = false;  // true: parallel light along `direction` (the sun), no position
  Vec3 position{0, 0, 0};
  Vec3 direction{0, -1, 0};      // spot: the cone's axis; directional: the way the light travels (unit)
  float outer_cone_deg = 30.0f;  // spot: half-angle where the light ends
};

// The nearest a focused light frustum may begin, world units: a millionth
// of the scene's reach from the light (its box's diagonal plus the light's
// distance from it), at most 1 mm — a fixed 1 mm clipped the casters of a
// scene modelled in micrometres (a light 0.1 mm over 1 um pebbles) while
// any scene a metre across or more keeps 1 mm.
float near_clamp(const LightShape& light, const Box3& scene);

// Spot cones wider than this half-angle use cube faces with the cone mask
// (a single frustum beyond ~120° wastes most of its texels).
inline constexpr float kMaxSpotFrustumHalfAngleDeg = 60.0f;

// The half-size of a window that holds content of half-size `half`
// (tangent units) with `guard` texels to spare on each side at `res` texels.
float widen_for_guard(float half, int res, float guard);

// Orthonormal frame around `forward`: right = forward x up_hint (normalized),
// up = right x forward. `up_hint` is replaced when nearly parallel.
void make_frame(Vec3 forward, Vec3 up_hint, Vec3& right, Vec3& up);

// A spot light's frustum: square, on the cone axis, the cone (half-angle
// outer_cone_deg, at most 89°) inside it with one texel of guard band.
PinholeView spot_view(const LightShape& light, int res, float near, float far);

// The six 90° faces of a point light at `position`, in the order +X, -X,
// +Y, -Y, +Z, -Z, each widened by one texel of guard band at `res`.
std::array<PinholeView, 6> cube_face_views(Vec3 position, float near, float far, int res);

// Planes of a pyramid from the spot's position circumscribing its cone
// (half-angle outer_cone_deg < 90°), `sides` faces. Empty for a cone of 90°
// or more (not convex) and for a point light.
std::vector<Plane> cone_planes(const LightShape& light, int sides = 32);

// A directional light's orthographic view along `direction` over `box`: a
// square window round the box's bounding sphere (its size independent of the
// light's roll and of the box's orientation), one texel of guard band, the
// centre snapped to the texel grid, the eye a margin behind the sphere and
// [near, far] across it.
PinholeView directional_view(Vec3 direction, const Box3& box, int res);

// A directional light's orthographic view focused on `points`: the smallest
// window holding their projections plus `guard` texels, each half size
// rounded up to a power of 2^(1/4) and the centre snapped to that texel
// grid (the same points always give the same view, bit for bit, and a
// small change of them leaves the view as it is more often than not), the
// eye a margin in front of the nearest point, [near, far] over the points.
PinholeView directional_focus(Vec3 direction, const std::vector<Vec3>& points, int res, float guard);

// Whether the light's cone (spot) is narrow enough for one frustum.
bool spot_fits_one_frustum(const LightShape& light);

}  // namespace cdsm::cluster
