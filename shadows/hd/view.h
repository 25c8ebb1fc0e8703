// Pinhole views (the camera, a spot light, one face of an omni light or a
// focused cluster frustum) and the radial depth convention (DESIGN.md §2.1).
#pragma once

#include "cdsm/math.h"
#include "cdsm/tags.h"

namespace cdsm {

// A view with an orthonormal frame: a pinhole (Projection::Perspective) or
// parallel rays (Projection::Orthographic, directional lights). Pixel
// (px, py) covers [px, px+1) x [py, py+1); py = 0 is the top row. Rays go
// through pixel centres. Perspective: every ray starts at `eye`, the window
// is measured in tangent units (at unit distance) and a point's depth is
// its distance from `eye` (radial, float32). Orthographic: `eye` is the
// centre of the window's plane, the window is measured in world units, each
// pixel's ray starts on that plane (pixel_origin) and runs along `forward`,
// and a point's depth is its distance from that plane (along its own ray,
// so the radial and the axial depth agree). Either way surfaces are seen
// where their view-axis coordinate lies in [near, far]; media absorb from
// the ray's origin up to `far` (clipped fragments, hd/fragment.h). The
// window may be off-centre (focused cluster frusta): `center` shifts it.
struct PinholeView {
  Vec3 eye;                 // world position of the eye / light; orthographic: the window plane's centre
  float near = 0.01f;       // view-axis clip distance, world units
  Vec3 right;               // unit, +x on the image plane
  float far = 1000.0f;      // view-axis clip distance, world units
  Vec3 up;                  // unit, +y on the image plane (image rows go down)
  float tan_half_x = 1.0f;  // half-width of the window at unit distance; orthographic: world units
  Vec3 forward;             // unit, the view axis
  float tan_half_y = 1.0f;  // half-height of the window at unit distance; orthographic: world units
  Vec2 center;              // window centre offset at unit distance (0,0 = on axis); orthographic: world units
  int32_t width = 1;
  int32_t height = 1;
  Projection projection = Projection::Perspective;
  uint32_t pad[3] = {0, 0, 0};
};
static_assert(sizeof(PinholeView) == 96, "PinholeView layout is shared with GPU code");

CDSM_HD CDSM_INLINE bool is_orthographic(const PinholeView& v) { return v.projection == Projection::Orthographic; }

// The window coordinates (tangent units, or world units when orthographic)
// of continuous image position (u, v) in pixels.
CDSM_HD CDSM_INLINE Vec2 window_at(const PinholeView& v, float u, float px_v) {
  return Vec2{v.center.x + (2.0f * u / float(v.width) - 1.0f) * v.tan_half_x,
              v.center.y + (1.0f - 2.0f * px_v / float(v.height)) * v.tan_half_y};
}

// Unnormalized direction through continuous image position (u, v) in pixels
// (orthographic: `forward` everywhere).
CDSM_HD CDSM_INLINE Vec3 view_direction(const PinholeView& v, float u, float px_v) {
  if (is_orthographic(v)) return v.forward;
  const Vec2 s = window_at(v, u, px_v);
  return v.forward + v.right * s.x + v.up * s.y;
}

// Where the ray through continuous image position (u, v) starts: `eye`, or
// its point on the window's plane when orthographic.
CDSM_HD CDSM_INLINE Vec3 view_origin(const PinholeView& v, float u, float px_v) {
  if (!is_orthographic(v)) return v.eye;
  const Vec2 s = window_at(v, u, px_v);
  return v.eye + v.right * s.x + v.up * s.y;
}

// Unit ray direction through the centre of pixel (px, py).
CDSM_HD CDSM_INLINE Vec3 pixel_ray(const PinholeView& v, int px, int py) {
  return normalize(view_direction(v, float(px) + 0.5f, float(py) + 0.5f));
}

// Where the ray through the centre of pixel (px, py) starts.
CDSM_HD CDSM_INLINE Vec3 pixel_origin(const PinholeView& v, int px, int py) {
  return view_origin(v, float(px) + 0.5f, float(py) + 0.5f);
}

// The view-axis distance from which producers keep the clipped fragments of
// media boundaries (hd/scene_data.h bounds_medium): a small fraction of
// `near`, since geometry at the eye itself cannot be projected by GL. Media
// closer than this to the eye plane are lost by both producers alike.
CDSM_HD CDSM_INLINE float media_clip_axial(const PinholeView& v) { return v.near > 0.0f ? 1e-3f * v.near : 1e-6f; }

// Where a world point lands: continuous pixel coordinates (u, v), depth,
// and the view-axis coordinate (<= 0 means behind the eye).
struct ViewProjection {
  float u, v;   // pixels; the pixel containing the point is (floor u, floor v)
  float depth;  // radial distance from the eye; orthographic: from the window's plane
  float axial;  // coordinate along `forward`
};

CDSM_HD CDSM_INLINE ViewProjection project(const PinholeView& v, Vec3 p) {
  Vec3 d = p - v.eye;
  float za = dot(d, v.forward);
  float inv = is_orthographic(v) ? 1.0f : za > 0.0f ? 1.0f / za : 0.0f;
  float sx = dot(d, v.right) * inv - v.center.x;
  float sy = dot(d, v.up) * inv - v.center.y;
  ViewProjection r;
  r.u = (sx / v.tan_half_x + 1.0f) * 0.5f * float(v.width);
  r.v = (1.0f - sy / v.tan_half_y) * 0.5f * float(v.height);
  r.depth = is_orthographic(v) ? za : length(d);
  r.axial = za;
  return r;
}

// Axial coordinate of the point at `depth` along unit ray `dir` (from its origin).
CDSM_HD CDSM_INLINE float axial_of(const PinholeView& v, Vec3 dir, float depth) { return depth * dot(dir, v.forward); }

}  // namespace cdsm
