// cdsm.glsl, part 6 of 6 (content/shaders/cdsm/, joined by cmake/CdsmGlsl.cmake): the application's calls.

// ---- the application's calls -------------------------------------------------

int cdsm_light_count() { return int(cdsm_light_total); }
// A spot or point light's position; a directional light has none (0): use
// cdsm_light_direction (or cdsm_direction_to_light) for it.
vec3 cdsm_light_position(int light) { return cdsm_lights[light].position; }
// The way the light travels: a spot's axis, a directional light's
// direction (unit; a point light's is unused).
vec3 cdsm_light_direction(int light) { return cdsm_lights[light].direction; }
// The unit direction from p toward the light, for every light type.
vec3 cdsm_direction_to_light(int light, vec3 p) { return cdsm_to_light(cdsm_lights[light], p); }
vec3 cdsm_light_radiance(int light) { return cdsm_lights[light].radiance; }

// The spot cone's falloff at p (smoothstep between the outer and inner cone), 1 for point and directional lights.
float cdsm_spot_factor(int light, vec3 p) {
  CdsmLight L = cdsm_lights[light];
  if (L.type != CDSM_LIGHT_SPOT) return 1.0;
  float c = cdsm_dot(cdsm_normalize(p - L.position), L.direction);
  if (c <= L.cos_outer) return 0.0;
  if (c >= L.cos_inner) return 1.0;
  float t = (c - L.cos_outer) / (L.cos_inner - L.cos_outer);
  return t * t * (3.0 - 2.0 * t);
}

vec3 cdsm_surface_transmittance(vec3 world_pos, vec3 plane_normal, uint object, int light) {
  if (light < 0 || light >= int(cdsm_light_total)) return vec3(1.0, 0.0, 1.0);
#ifdef CDSM_LAYOUT
  if (cdsm_layout != uint(CDSM_LAYOUT)) return vec3(1.0, 0.0, 1.0);  // compiled for another layout
#endif
  return vec3(1.0) - cdsm_shadow_alpha(cdsm_lights[light], world_pos, plane_normal, object);
}

vec3 cdsm_transmittance(vec3 world_pos, int light) {
  return cdsm_surface_transmittance(world_pos, vec3(0.0), CDSM_NO_OBJECT, light);
}

#endif  // CDSM_GLSL_INCLUDED
