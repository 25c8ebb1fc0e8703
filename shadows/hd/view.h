// Pinhole views (the camera, a spot light, one face of an omni light or a
// focused cluster frustum) and the radial depth convention (DESIGN.md §2.1).
#pragma once

#include "cdsm/math.h"
#include "cdsm/tags.h"

namespace cdsm {

// A pinhole view with an orthonormal frame. Pixel (px, py) covers
// [px, px+1) x [py, py+1); py = 0 is the top row. Rays go through pixel
// centres. A point's depth is its distance from `eye` (radial, float32);
// surfaces are seen where their view-axis coordinate lies in [near, far];
// media absorb from the eye up to `far` (clipped fragments, hd/fragment.h).
// The window may be off-centre (focused cluster frusta): `center` shifts
// it in tangent units.
struct PinholeView {
  Vec3 eye;                 // world position of the eye / light
  float near = 0.01f;       // view-axis clip distance, world units
  Vec3 right;               // unit, +x on the image plane
  float far = 1000.0f;      // view-axis clip distance, world units
  Vec3 up;                  // unit, +y on the image plane (image rows go down)
  float tan_half_x = 1.0f;  // half-width of the window at unit distance
  Vec3 forward;             // unit, the view axis
  float tan_half_y = 1.0f;  // half-height of the window at unit distance
  Vec2 center;              // window centre offset at unit distance (0,0 = on axis)
  int32_t width = 1;
  int32_t height = 1;
};
static_assert(sizeof(PinholeView) == 80, "PinholeView layout is shared with GPU code");

// The view-axis distance from which producers keep the clipped fragments of
// media boundaries (hd/scene_data.h bounds_medium): a small fraction of
// `near`, since geometry at the eye itself cannot be projected by GL. Media
// closer than this to the eye plane are lost by both producers alike.
CDSM_HD CDSM_INLINE float media_clip_axial(const PinholeView& v) { return v.near > 0.0f ? 1e-3f * v.near : 1e-6f; }

// Unnormalized direction through continuous image position (u, v) in pixels.
CDSM_HD CDSM_INLINE Vec3 view_direction(const PinholeView& v, float u, float px_v) {
  float sx = v.center.x + (2.0f * u / float(v.width) - 1.0f) * v.tan_half_x;
  float sy = v.center.y + (1.0f - 2.0f * px_v / float(v.height)) * v.tan_half_y;
  return v.forward + v.right * sx + v.up * sy;
}

// Unit ray direction through the centre of pixel (px, py).
CDSM_HD CDSM_INLINE Vec3 pixel_ray(const PinholeView& v, int px, int py) {
  return normalize(view_direction(v, float(px) + 0.5f, float(py) + 0.5f));
}

// Where a world point lands: continuous pixel coordinates (u, v), radial depth,
// and the view-axis coordinate (<= 0 means behind the eye).
struct ViewProjection {
  float u, v;   // pixels; the pixel containing the point is (floor u, floor v)
  float depth;  // radial distance from the eye
  float axial;  // coordinate along `forward`
};

CDSM_HD CDSM_INLINE ViewProjection project(const PinholeView& v, Vec3 p) {
  Vec3 d = p - v.eye;
  float za = dot(d, v.forward);
  float inv = za > 0.0f ? 1.0f / za : 0.0f;
  float sx = dot(d, v.right) * inv - v.center.x;
  float sy = dot(d, v.up) * inv - v.center.y;
  ViewProjection r;
  r.u = (sx / v.tan_half_x + 1.0f) * 0.5f * float(v.width);
  r.v = (1.0f - sy / v.tan_half_y) * 0.5f * float(v.height);
  r.depth = length(d);
  r.axial = za;
  return r;
}

// Axial coordinate of the point at radial `depth` along unit ray `dir`.
CDSM_HD CDSM_INLINE float axial_of(const PinholeView& v, Vec3 dir, float depth) { return depth * dot(dir, v.forward); }

}  // namespace cdsm
