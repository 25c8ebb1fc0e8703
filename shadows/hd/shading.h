// Shading models (DESIGN.md §2.5): Phong surfaces (thesis eq. 3.8/3.9) with
// the shadow term on diffuse and specular, volume samples as single
// scattering (isotropic) or Phong with gradient normals.
#pragma once

#include "hd/lights.h"

namespace cdsm {

struct ShadeInput {
  Vec3 p;      // world position
  Vec3 n;      // unit normal facing the viewer (surfaces, phong volumes)
  Vec3 v;      // unit direction to the viewer
  Vec3 color;  // base colour / albedo
  float ka, kd, ks, shininess;
  bool has_normal;  // false: isotropic scattering sample
  // Surfaces: the geometric normal of the triangle (the receiver's plane
  // for shadow lookups, hd/lights.h Receiver); 0 for volume samples, Phong
  // ones too (their gradient normal is for shading only: no plane, no offset).
  Vec3 plane;
  // The surface's object when it is in the shadow maps (a caster's): its
  // lookups leave out its own step (hd/lights.h Receiver). kNoObject for
  // receive-only surfaces and volume samples.
  uint32_t object;
};

// Visibility callback form: Vec3 vis(int light_index, const Receiver& r)
// returns 1 - alpha (the transmittance) per colour channel at r — from DSMs
// or the reference.
template <class Visibility>
CDSM_HD Vec3 shade_point(const ShadeInput& in, Span<const LightData> lights, Vec3 ambient, Visibility&& visibility) {
  Vec3 c = in.color * ambient * in.ka;
  for (uint32_t i = 0; i < lights.size(); ++i) {
    const LightData& L = lights[i];
    float cone = cone_factor(L, in.p);
    if (cone <= 0.0f) continue;
    const ToLight tl = to_light(L, in.p);
    if (tl.distance <= 0.0f) continue;
    const Vec3 l = tl.l;
    const Receiver rc{in.p, in.plane, in.object};
    if (!in.has_normal) {
      const Vec3 vis = visibility(int(i), rc);
      c += in.color * L.radiance * (vis * cone);
      continue;
    }
    float ndl = dot(in.n, l);
    if (ndl <= 0.0f) continue;
    const Vec3 vis = visibility(int(i), rc);
    if (max_channel(vis) <= 0.0f) continue;
    Vec3 r = in.n * (2.0f * ndl) - l;
    float rv = fmaxf(0.0f, dot(r, in.v));
    float spec = in.ks * (rv > 0.0f ? powf(rv, in.shininess) : 0.0f);
    c += (in.color * (in.kd * ndl) + vec3(spec)) * L.radiance * (vis * cone);
  }
  return c;
}

}  // namespace cdsm
