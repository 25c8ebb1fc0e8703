// Camera pass (DESIGN.md §2.5): one pixel — walk the camera ray, shade
// surfaces and volume samples with DSM shadows, composite front to back
// (thesis eq. 3.10-3.11), stop at kCompositeStop.
#pragma once

#include "hd/segments.h"
#include "hd/shading.h"

namespace cdsm {

struct CameraPassParams {
  PinholeView view;
  Span<const uint32_t> inside;  // objects containing the camera
  Vec3 ambient;                 // i_a
  Vec3 background;
};

struct PixelResult {
  Vec3 color;
  float alpha;  // accumulated opacity of the pixel (grey: its one value; coloured: the channel mean)
};

// A triangle of ~1e9 units or more has an edge cross product whose squared
// length overflows float (a ground scaled by 1e20 shaded NaN; by 1e12 it
// lost its normal): such a triangle is taken relative to `p` in units of
// its largest edge coordinate, which changes none of the ratios used
// below. Others are left as they are, bit for bit.
CDSM_HD CDSM_INLINE void rescale_huge_triangle(Vec3& a, Vec3& b, Vec3& c, Vec3& p) {
  const Vec3 e1 = b - a, e2 = c - a;
  const float s = 1.0f / fmaxf(max_channel(vmax(e1, -e1)), max_channel(vmax(e2, -e2)));
  a = (a - p) * s;
  b = (b - p) * s;
  c = (c - p) * s;
  p = Vec3{0, 0, 0};
}

// Unit geometric normal of triangle `tri` (0 for a degenerate one).
CDSM_HD CDSM_INLINE Vec3 geometric_normal(const SceneView& s, uint32_t tri) {
  Vec3 a = s.tri_vertices[3 * tri], b = s.tri_vertices[3 * tri + 1], c = s.tri_vertices[3 * tri + 2];
  Vec3 ng = cross(b - a, c - a);
  float l = length(ng);
  if (!(l <= 3.0e38f)) {  // (NaN too: an infinite cross product)
    Vec3 o = a;
    rescale_huge_triangle(a, b, c, o);
    ng = cross(b - a, c - a);
    l = length(ng);
  }
  return l > 0.0f ? ng * (1.0f / l) : Vec3{0, 0, 0};
}

// Interpolated shading normal of triangle `tri` at p, facing the viewer.
CDSM_HD CDSM_INLINE Vec3 surface_normal(const SceneView& s, uint32_t tri, Vec3 p, Vec3 dir) {
  Vec3 a = s.tri_vertices[3 * tri], b = s.tri_vertices[3 * tri + 1], c = s.tri_vertices[3 * tri + 2];
  Vec3 ng = cross(b - a, c - a);
  float area2 = dot(ng, ng);
  if (!(area2 <= 3.0e38f)) {
    rescale_huge_triangle(a, b, c, p);
    ng = cross(b - a, c - a);
    area2 = dot(ng, ng);
  }
  Vec3 n = ng;
  if (area2 > 0.0f && !s.tri_normals.empty()) {
    float wa = dot(cross(b - p, c - p), ng) / area2;
    float wb = dot(cross(c - p, a - p), ng) / area2;
    float wc = 1.0f - wa - wb;
    Vec3 ni = s.tri_normals[3 * tri] * wa + s.tri_normals[3 * tri + 1] * wb + s.tri_normals[3 * tri + 2] * wc;
    if (dot(ni, ni) > 0.0f) n = ni;
  }
  n = normalize(n);
  return dot(n, dir) > 0.0f ? -n : n;
}

// The shading input of a volume sample at p seen along dir, base colour
// `color`: isotropic scattering (VolumeShading::Scatter, or a flat density),
// or Phong with the density gradient as its normal. The camera pass and the
// reference shade volume samples with this one definition.
CDSM_HD CDSM_INLINE ShadeInput volume_sample_shading(const SceneView& s, const VolumeData& v, Vec3 p, Vec3 dir,
                                                     Vec3 color) {
  ShadeInput in;
  in.p = p;
  in.v = -dir;
  in.color = color;
  in.ka = 1.0f;
  in.kd = 1.0f;
  in.ks = 0.0f;
  in.shininess = 1.0f;
  in.has_normal = false;
  in.plane = Vec3{0, 0, 0};
  in.object = kNoObject;
  in.n = Vec3{0, 0, 0};
  if (v.shading == VolumeShading::Phong) {
    const Vec3 g = density_gradient(s, v, p) * v.gradient_scale;
    const float gl = length(g);
    if (gl > 1e-6f) {
      in.n = g * (-1.0f / gl);
      if (dot(in.n, dir) > 0.0f) in.n = -in.n;
      in.has_normal = true;
      in.ka = 0.3f;
      in.kd = 0.7f;
      in.ks = 0.2f;
      in.shininess = 16.0f;
    }
  }
  return in;
}

// A recorder sees every shaded point with its compositing weight (the
// largest channel's):
//   void shaded(Vec3 p, Vec3 normal, bool is_surface, float weight)
struct NoRecorder {
  CDSM_HD void shaded(Vec3, Vec3, bool, float) {}
};

// Visibility = DSM lookups at the receiver (hd/lights.h): surfaces by their
// plane (casters leave out their own step), volume samples at their depth.
struct DsmVisibility {
  const ShadowView& sv;
  CDSM_HD Vec3 operator()(int light, const Receiver& r) const {
    return one_minus(shadow_alpha(sv, sv.lights[uint32_t(light)], r));
  }
};

template <class Visibility, class Recorder>
struct CameraVisitor {
  const SceneView& s;
  Span<const LightData> lights;
  const Visibility& visibility;
  Recorder& rec;
  Vec3 org, dir, ambient;
  Vec3 color{0, 0, 0};
  Vec3 T{1.0f, 1.0f, 1.0f};  // transmittance to the eye, per channel

  // Every channel past the stop (a ray behind red glass goes on in green and blue).
  CDSM_HD bool done() const { return 1.0f - max_channel(T) >= kCompositeStop; }

  CDSM_HD bool surface(float t, uint32_t tri, bool /*front*/) {
    const ObjectData& o = s.objects[s.tri_object[tri]];
    if (passes_all(o)) return true;
    if (o.opacity <= 0.0f) {  // a pure filter: reflects nothing, tints what lies behind
      T = T * one_minus(o.absorb);
      return !done();
    }
    ShadeInput in;
    in.p = org + dir * t;
    in.n = surface_normal(s, tri, in.p, dir);
    in.v = -dir;
    in.color = o.color;
    in.ka = o.ka;
    in.kd = o.kd;
    in.ks = o.ks;
    in.shininess = o.shininess;
    in.has_normal = true;
    in.plane = geometric_normal(s, tri);
    in.object = (o.flags & kObjCastsShadows) != 0u ? s.tri_object[tri] : kNoObject;
    Vec3 c = shade_point(in, lights, ambient, visibility);
    const Vec3 w = T * o.opacity;
    rec.shaded(in.p, in.n, true, max_channel(w));
    color += c * w;
    T = T * one_minus(o.absorb);
    return !done();
  }

  CDSM_HD bool segment(float t0, float t1, const SegmentMedia& m) {
    if (m.volume_count == 0) {  // a pure absorber: exact Beer-Lambert per channel
      const float d = t1 - t0;
      T = T * Vec3{expf_hd(-m.sigma.x * d), expf_hd(-m.sigma.y * d), expf_hd(-m.sigma.z * d)};
      return !done();
    }
    return march_segment(
        s, m, org, dir, t0, t1,
        [&](const MarchSample& ms) {
          const Vec3 a = sample_alpha(ms);
          if (max_channel(a) <= 0.0f) return true;
          // The volumes' share of each channel's absorption (constant media add none).
          Vec3 vol_a{0, 0, 0};
          for (int k = 0; k < 3; ++k)
            vol_a[k] = ms.extinction[k] > 0.0f ? a[k] * (ms.extinction[k] - m.sigma[k]) / ms.extinction[k] : 0.0f;
          if (max_channel(vol_a) > 0.0f && ms.dominant >= 0) {
            const VolumeData& v = s.volumes[m.volume[ms.dominant]];
            const ShadeInput in = volume_sample_shading(s, v, org + dir * (0.5f * (ms.t0 + ms.t1)), dir, ms.color);
            Vec3 c = shade_point(in, lights, ambient, visibility);
            const Vec3 w = T * vol_a;
            rec.shaded(in.p, in.n, false, max_channel(w));
            color += c * w;
          }
          T = T * one_minus(a);
          return !done();
        },
        [](float, float) {});
  }
};

template <class Visibility, class Recorder>
CDSM_HD PixelResult shade_pixel(const SceneView& s, Span<const LightData> lights, const Visibility& visibility,
                                const CameraPassParams& p, Span<Fragment> frags, int px, int py, Recorder& rec,
                                WalkStats& st) {
  Vec3 dir = pixel_ray(p.view, px, py);
  CameraVisitor<Visibility, Recorder> vis{s, lights, visibility, rec, pixel_origin(p.view, px, py), dir, p.ambient};
  float t_end = p.view.far / fmaxf(dot(dir, p.view.forward), 1e-6f);
  walk_ray(s, frags, p.inside, 0.0f, t_end, vis, st);
  PixelResult r;
  r.color = vis.color + p.background * vis.T;
  r.alpha = 1.0f - grey_of(vis.T);
  return r;
}

}  // namespace cdsm
