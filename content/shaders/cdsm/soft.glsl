// cdsm.glsl, part 5 of 6 (content/shaders/cdsm/, joined by cmake/CdsmGlsl.cmake): lights with a size.

// ---- lights with a size: penumbrae from the maps (hd/lights.h) ---------------

float cdsm_grey(vec3 a) { return a.x == a.y && a.y == a.z ? a.x : (a.x + a.y + a.z) * (1.0 / 3.0); }

// The radius (radians across the receiver's ray; world units orthographic)
// within which shadow rays to the light's area cross depth zb (hd/lights.h
// penumbra_radius).
float cdsm_penumbra_radius(CdsmLight L, CdsmMap m, float z, float zb) {
  float d = max(z - zb, 0.0);
  return m.view.projection == CDSM_PROJECTION_ORTHOGRAPHIC ? L.size * d : L.size * d / (z * max(zb, 1e-6));
}

// The map's window around the receiver's ray (hd/lights.h PenumbraFrame):
// an angle g across the ray lands as L g tangentially and L^2 g radially,
// L = sqrt(1 + |w|^2), w the ray's window coordinates (orthographic: L = 1).
struct CdsmPenumbraFrame {
  float to_u, to_v;
  vec2 w;
  float l;
  float texel;
  float inv_u, inv_v, inv_l, inv_l1, inv_ll1;  // reciprocals (hd/lights.h PenumbraFrame)
};

CdsmPenumbraFrame cdsm_penumbra_frame(CdsmMap m, CdsmProjection pr) {
  CdsmPenumbraFrame f;
  f.to_u = float(m.res) / (2.0 * m.view.tan_half_x);
  f.to_v = float(m.res) / (2.0 * m.view.tan_half_y);
  f.w = m.view.projection == CDSM_PROJECTION_ORTHOGRAPHIC ? vec2(0.0) : cdsm_window_at(m.view, pr.u, pr.v);
  f.l = sqrt(1.0 + f.w.x * f.w.x + f.w.y * f.w.y);
  f.texel = 2.0 * max(m.view.tan_half_x, m.view.tan_half_y) / (float(m.res) * f.l);
  f.inv_u = 1.0 / f.to_u;
  f.inv_v = 1.0 / f.to_v;
  f.inv_l = 1.0 / f.l;
  f.inv_l1 = 1.0 / (f.l + 1.0);
  f.inv_ll1 = 1.0 / (f.l * (f.l + 1.0));
  return f;
}

// The pixel offset of angle (gx, gy) across the ray (hd/lights.h to_pixels).
vec2 cdsm_to_pixels(CdsmPenumbraFrame f, float gx, float gy) {
  float k = (gx * f.w.x + gy * f.w.y) * f.inv_l1;
  return vec2(f.l * (gx + k * f.w.x) * f.to_u, -f.l * (gy + k * f.w.y) * f.to_v);
}

// The angle across the ray of pixel offset (du, dv) (hd/lights.h angle_of).
float cdsm_angle_of(CdsmPenumbraFrame f, float du, float dv) {
  float x = du * f.inv_u, y = -dv * f.inv_v;
  float k = (x * f.w.x + y * f.w.y) * f.inv_ll1;
  float ax = x - k * f.w.x, ay = y - k * f.w.y;
  return sqrt(ax * ax + ay * ay) * f.inv_l;
}

// Texel t's opacity in front of z_lim and its opacity-weighted mean depth
// (hd/lights.h texel_blockers): vec2(alpha, depth), 0 for none.
vec2 cdsm_texel_blockers(CdsmMap m, uint t, float z_lim) {
  bool rgb = m.rgb != 0u;
  uint slot, i0, count;
  cdsm_read_start(m, t, -3.0e38, slot, i0, count);
  float pz = 0.0, pa = 0.0, moment = 0.0;
  bool have_prev = false;
  for (uint i = i0; i < count; ++i) {
    float z;
    vec3 a3;
    uint next;
    cdsm_slot(rgb, slot, z, a3, next);
    float a = cdsm_grey(a3);
    if (z >= z_lim) {
      if (have_prev && z > pz) {
        float at = pa + (a - pa) * ((z_lim - pz) / (z - pz));
        moment += (at - pa) * 0.5 * (pz + z_lim);
        pa = at;
      }
      break;
    }
    moment += (a - pa) * (have_prev ? 0.5 * (pz + z) : z);
    pz = z;
    pa = a;
    have_prev = true;
    slot = CDSM_LAYOUT_IS(CDSM_LAYOUT_CHUNKED) ? next : slot + 1u;
  }
  return pa > 0.0 ? vec2(pa, moment / pa) : vec2(0.0);
}

// The depth of texel t's first node (hd/dsm.h texel_first_depth): a
// fixed layout's pad (3.4e38) when it has none.
float cdsm_texel_first_depth(CdsmMap m, uint t) {
  bool rgb = m.rgb != 0u;
  uvec2 span = CDSM_LAYOUT_IS(CDSM_LAYOUT_FIXED) ? uvec2(t * cdsm_layers, cdsm_layers)
               : rgb                            ? cdsm_rgb_texels[t]
                                                : cdsm_texels[t];
  if (span.y == 0u) return 3.402823466e+38;
  float z;
  vec3 a;
  uint next;
  cdsm_slot(rgb, span.x, z, a, next);
  return z;
}

// The depth in front of which texel (tx, ty) holds the receiver's blockers.
float cdsm_blocker_limit(CdsmLight L, CdsmMap m, CdsmProjection pr, vec3 p, vec3 plane, int tx, int ty) {
  if (cdsm_receiver == CDSM_RECEIVER_SLOPE_BIAS) return pr.depth - cdsm_slope_bias_offset(L, m, pr, p, plane);
  if (!(cdsm_dot(plane, plane) > 0.0)) return pr.depth;
  float depth = cdsm_tap_depth(m, pr, p, plane, tx, ty);
  float coplanar = CDSM_RELATIVE_DEPTH_OFFSET * depth;
  float window = cdsm_bias_constant + cdsm_bias_slope * cdsm_texel_footprint(m, pr.axial) + coplanar;
  return depth - window;
}

// The penumbra's filter radius in window units (0: hard): blockers searched
// around the receiver, each counted within its own reach of it.
float cdsm_penumbra_filter_radius(CdsmLight L, CdsmMap m, CdsmProjection pr, vec3 p, vec3 plane) {
  float z = pr.depth;
  if (cdsm_penumbra == CDSM_PENUMBRA_FIXED_KERNEL) return cdsm_penumbra_radius(L, m, z, 0.5 * z);
  CdsmPenumbraFrame f = cdsm_penumbra_frame(m, pr);
  float search = min(cdsm_penumbra_radius(L, m, z, max(m.view.near_z, 1e-6)), CDSM_PENUMBRA_SEARCH_TEXELS * f.texel);
  int res = int(m.res);
  float weight = 0.0, moment = 0.0;
  // The texel under the receiver, then rings of 8 at 1, 2, 4, ... texels
  // out to the search radius (every other ring turned by 22.5 degrees).
  float ring = 0.0;
  for (int k = 0; k < 2 + 8 * CDSM_PENUMBRA_SEARCH_RINGS; ++k) {
    if (k > 0 && (k - 1) % 8 == 0) {
      if (ring >= search) break;
      ring = min(k == 1 ? f.texel : 2.0 * ring, search);
    }
    int d = k == 0 ? 0 : ((k - 1) % 8) * 2 + (((k - 1) / 8) & 1);
    vec2 at = k == 0 ? vec2(0.0)
                     : cdsm_to_pixels(f, ring * CDSM_PENUMBRA_DIRECTIONS[d].x, ring * CDSM_PENUMBRA_DIRECTIONS[d].y);
    int tx = int(floor(pr.u + at.x)), ty = int(floor(pr.v + at.y));
    if (tx < 0 || ty < 0 || tx >= res || ty >= res) continue;
    // Blockers reach no farther than from the texel's first node: a texel
    // too far for that (or empty) is passed without its walk.
    uint t = m.texel_offset + uint(ty) * m.res + uint(tx);
    float first = cdsm_texel_first_depth(m, t);
    if (!(first < 3.402823466e+38)) continue;
    float off = cdsm_angle_of(f, float(tx) + 0.5 - pr.u, float(ty) + 0.5 - pr.v);
    if (off > (2.0 * cdsm_penumbra_radius(L, m, z, first) + f.texel) * (1.0 + 1.0e-5)) continue;
    vec2 b = cdsm_texel_blockers(m, t, cdsm_blocker_limit(L, m, pr, p, plane, tx, ty));
    if (!(b.x > CDSM_PENUMBRA_MIN_ALPHA)) continue;
    if (off > 2.0 * cdsm_penumbra_radius(L, m, z, b.y) + f.texel) continue;
    weight += b.x;
    moment += b.x * b.y;
  }
  return weight > CDSM_PENUMBRA_MIN_ALPHA ? cdsm_penumbra_radius(L, m, z, moment / weight) : 0.0;
}

// Whether a filter tap at `at` may shadow the receiver (hd/lights.h
// blocks_receiver): its texel's blockers within their own reach of it (plus
// a texel), or none.
bool cdsm_blocks_receiver(CdsmLight L, CdsmMap m, CdsmProjection pr, CdsmPenumbraFrame f, vec3 p, vec3 plane,
                          CdsmProjection at) {
  int tx = int(floor(at.u)), ty = int(floor(at.v)), res = int(m.res);
  if (tx < 0 || ty < 0 || tx >= res || ty >= res) return true;
  vec2 b = cdsm_texel_blockers(m, m.texel_offset + uint(ty) * m.res + uint(tx),
                               cdsm_blocker_limit(L, m, pr, p, plane, tx, ty));
  if (!(b.x > CDSM_PENUMBRA_MIN_ALPHA)) return true;
  return cdsm_angle_of(f, at.u - pr.u, at.v - pr.v) <= cdsm_penumbra_radius(L, m, pr.depth, b.y) + f.texel;
}

// A lattice tap's weight across the ellipse's rim (hd/lights.h rim_weight).
float cdsm_rim_weight(float du, float dv, float angle, float radius, float spacing) {
  if (!(angle > 0.0)) return 1.0;
  float w = (radius / angle - 1.0) * sqrt(du * du + dv * dv) / spacing + 0.5;
  return min(max(w, 0.0), 1.0);
}

// One map's α for a light with a size: the hard lookup filtered over the
// penumbra's ellipse on a lattice fixed in the map (hd/lights.h
// soft_map_alpha_in_colour); else the hard one.
vec3 cdsm_light_map_alpha(CdsmLight L, CdsmMap m, CdsmProjection pr, vec3 p, vec3 plane, uint object) {
  if (!(L.size > 0.0) || cdsm_penumbra == CDSM_PENUMBRA_HARD) return cdsm_map_alpha(L, m, pr, p, plane, object);
  float radius = cdsm_penumbra_filter_radius(L, m, pr, p, plane);
  CdsmPenumbraFrame f = cdsm_penumbra_frame(m, pr);
  float reach = radius * f.l * f.l * max(f.to_u, f.to_v);
  if (!(reach >= 0.5)) return cdsm_map_alpha(L, m, pr, p, plane, object);
  float spacing = max(1.0, 2.0 * reach / float(cdsm_penumbra_taps));
  float inv = 1.0 / spacing, out_r = reach + 0.5 * spacing;
  int i0 = int(ceil((pr.u - out_r) * inv)), i1 = int(floor((pr.u + out_r) * inv));
  int j0 = int(ceil((pr.v - out_r) * inv)), j1 = int(floor((pr.v + out_r) * inv));
  vec3 sum = vec3(0.0);
  float weight = 0.0;
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i) {
      CdsmProjection at = pr;
      at.u = float(i) * spacing;
      at.v = float(j) * spacing;
      float du = at.u - pr.u, dv = at.v - pr.v;
      if (du * du + dv * dv > out_r * out_r) continue;
      float w = cdsm_rim_weight(du, dv, cdsm_angle_of(f, du, dv), radius, spacing);
      if (!(w > 0.0)) continue;
      weight += w;
      if (cdsm_penumbra == CDSM_PENUMBRA_ESTIMATED && !cdsm_blocks_receiver(L, m, pr, f, p, plane, at)) continue;
      sum = sum + cdsm_map_alpha(L, m, at, p, plane, object) * w;
    }
  vec3 soft = sum * (1.0 / weight);
  if (reach >= 1.5) return soft;
  float t = reach - 0.5;
  return cdsm_map_alpha(L, m, pr, p, plane, object) * (1.0 - t) + soft * t;
}

int cdsm_cube_face(vec3 d) {
  float ax = abs(d.x), ay = abs(d.y), az = abs(d.z);
  if (ax >= ay && ax >= az) return d.x >= 0.0 ? 0 : 1;
  if (ay >= az) return d.y >= 0.0 ? 2 : 3;
  return d.z >= 0.0 ? 4 : 5;
}

// α per channel between light L and the receiver over the light's maps:
// clusters combined (eq. 3.12), the one cube face, or the first split holding it.
vec3 cdsm_shadow_alpha(CdsmLight L, vec3 p, vec3 plane, uint object) {
  vec3 alpha = vec3(0.0);
  uint first = L.first_map, count = L.map_count;
  if (L.map_mode == CDSM_MAPS_CUBE_FACES && count == 6u) {
    first += uint(cdsm_cube_face(p - L.position));
    count = 1u;
  }
  for (uint k = 0u; k < count; ++k) {
    CdsmMap m = cdsm_maps[first + k];
    CdsmProjection pr = cdsm_project(m.view, p);
    if (pr.axial <= 0.0) continue;
    // Every tap outside the map: it adds nothing (alpha + 0 (1 - alpha) is
    // alpha exactly), skipped before its offsets and taps are computed (a
    // soft lookup's taps reach farther: never skipped).
    float res_f = float(m.res);
    bool hard = !(L.size > 0.0) || cdsm_penumbra == CDSM_PENUMBRA_HARD;
    if (hard && L.map_mode == CDSM_MAPS_COMBINE && (pr.u < -0.5 || pr.v < -0.5 || pr.u > res_f + 0.5 || pr.v > res_f + 0.5)) continue;
    if (L.map_mode == CDSM_MAPS_FIRST_CONTAINING) {
      float lo = 1.0, hi = float(m.res) - 1.0;
      if (k + 1u < count && (pr.u < lo || pr.v < lo || pr.u > hi || pr.v > hi)) continue;
      count = k + 1u;
    }
    alpha = cdsm_over(alpha, cdsm_light_map_alpha(L, m, pr, p, plane, object));
  }
  return alpha;
}

