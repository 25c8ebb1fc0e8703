// cdsm.glsl, part 4 of 6 (content/shaders/cdsm/, joined by cmake/CdsmGlsl.cmake): receivers and the hard lookup.

// ---- receivers (shadows/hd/lights.h) ----------------------------------------

float cdsm_texel_footprint(CdsmMap m, float axial) {
  return 2.0 * m.view.tan_half_x * (m.view.projection == CDSM_PROJECTION_ORTHOGRAPHIC ? 1.0 : axial) / float(m.res);
}

// A map's texel-centre rays against the plane through p with normal n
// (hd/lights.h PlaneRays): texel (tx, ty) at window coordinates
// sx = x0 + dx tx, sy = y0 + dy ty crosses it at num / dn.
struct CdsmPlaneRays {
  float x0, dx, y0, dy;
  float num, fn, rn, un;
  bool pinhole;
};
CdsmPlaneRays cdsm_plane_rays(CdsmView v, vec3 p, vec3 n) {
  CdsmPlaneRays r;
  float iw = 1.0 / float(v.width), ih = 1.0 / float(v.height);
  r.dx = 2.0 * v.tan_half_x * iw;
  r.x0 = v.center.x + (iw - 1.0) * v.tan_half_x;
  r.dy = -2.0 * v.tan_half_y * ih;
  r.y0 = v.center.y + (1.0 - ih) * v.tan_half_y;
  r.num = cdsm_dot(p - v.eye, n);
  r.fn = cdsm_dot(v.forward, n);
  r.rn = cdsm_dot(v.right, n);
  r.un = cdsm_dot(v.up, n);
  r.pinhole = v.projection != CDSM_PROJECTION_ORTHOGRAPHIC;
  return r;
}
// The plane's depth along texel (tx, ty)'s ray, within `reach` of `depth`.
float cdsm_plane_depth_of(CdsmPlaneRays r, int tx, int ty, float depth, float reach) {
  float sx = r.x0 + r.dx * float(tx), sy = r.y0 + r.dy * float(ty);
  float num = r.pinhole ? r.num * sqrt(1.0 + sx * sx + sy * sy) : r.num - sx * r.rn - sy * r.un;
  float dn = r.pinhole ? r.fn + sx * r.rn + sy * r.un : r.fn;
  float t = dn != 0.0 ? num / dn : depth + reach;
  if (!(t > depth - reach)) t = depth - reach;
  if (!(t < depth + reach)) t = depth + reach;
  return t;
}

// The depth at which tap (tx, ty) reads its texel: where its texel-centre ray
// crosses the receiver's plane (within a reach of the point's depth), or
// the point's own depth (volume samples, the slope-bias baseline).
float cdsm_tap_depth(CdsmMap m, CdsmProjection pr, vec3 p, vec3 plane, int tx, int ty) {
  if (cdsm_receiver == CDSM_RECEIVER_SLOPE_BIAS || !(cdsm_dot(plane, plane) > 0.0)) return pr.depth;
  float reach = CDSM_PLANE_REACH_TEXELS * cdsm_texel_footprint(m, pr.axial);
  return cdsm_plane_depth_of(cdsm_plane_rays(m.view, p, plane), tx, ty, pr.depth, reach);
}

// ---- what a surface receives: its own step left out (shadows/hd/dsm.h) ------

vec3 cdsm_layer_between(vec3 prev, vec3 a) {
  vec3 r;
  for (int k = 0; k < 3; ++k) r[k] = 1.0 - prev[k] > 0.0 ? 1.0 - (1.0 - a[k]) / (1.0 - prev[k]) : 0.0;
  return r;
}
vec3 cdsm_over_layer(vec3 alpha, vec3 a) {
  return vec3(alpha.x + a.x * (1.0 - alpha.x), alpha.y + a.y * (1.0 - alpha.y), alpha.z + a.z * (1.0 - alpha.z));
}

// The first node a read visits (packed, fixed: one before the first at or
// after `from_z`; chunked: the head), the texel's node count, and whether
// the nodes are linked (chunked) or consecutive.
void cdsm_read_start(CdsmMap m, uint t, float from_z, out uint slot, out uint i, out uint count) {
  bool rgb = m.rgb != 0u;
  i = 0u;
  if (CDSM_LAYOUT_IS(CDSM_LAYOUT_CHUNKED)) {
    uvec2 head = rgb ? cdsm_rgb_texels[t] : cdsm_texels[t];
    slot = head.x;
    count = head.y;
    return;
  }
  uvec2 span = CDSM_LAYOUT_IS(CDSM_LAYOUT_FIXED) ? uvec2(t * cdsm_layers, cdsm_layers) : rgb ? cdsm_rgb_texels[t] : cdsm_texels[t];
  uint lo = 0u, hi = span.y;
  while (lo < hi) {
    uint mid = (lo + hi) >> 1;
    float z;
    vec3 a;
    uint nx;
    cdsm_slot(rgb, span.x + mid, z, a, nx);
    if (z < from_z) lo = mid + 1u;
    else hi = mid;
  }
  i = lo > 0u ? lo - 1u : 0u;
  slot = span.x + i;
  count = span.y;
}

// What a receiver reads from texel t of map m (hd/dsm.h TexelRead,
// OwnStepSearch and ReceiverScan): its own step (object bits `own`, 0:
// none) nearest to `depth` within +-window left out, every node before
// depth - coplanar counted, steps within +-coplanar by rank, nothing behind.
vec3 cdsm_texel_receive(CdsmMap m, uint t, float depth, float window, float coplanar, uint own) {
  bool rgb = m.rgb != 0u;
  float from_z = min(depth - window, depth - coplanar);
  uint slot0, i0, count;
  cdsm_read_start(m, t, from_z, slot0, i0, count);
  // Pass 1: the own step.
  uint own_index = 0xffffffffu, own_rank = 2u, seen = 0u;
  float own_z = 0.0, best = 0.0;
  if (own != 0u) {
    uint slot = slot0;
    for (uint i = i0; i < count; ++i) {
      float z;
      vec3 a;
      uint next;
      cdsm_slot(rgb, slot, z, a, next);
      if (z > depth + window) break;
      uint tag = cdsm_tag(rgb, slot);
      if ((tag & 0x3fffu) == own && z >= depth - window && (own_index == 0xffffffffu || abs(z - depth) < best)) {
        own_index = seen;
        own_z = z;
        best = abs(z - depth);
        own_rank = tag >> 14;
      }
      ++seen;
      slot = CDSM_LAYOUT_IS(CDSM_LAYOUT_CHUNKED) ? next : slot + 1u;
    }
  }
  // Pass 2: what counts.
  float lo = depth - coplanar, hi = depth + coplanar;
  float prefix_end = own_index != 0xffffffffu ? min(lo, own_z) : lo;
  float pz = 0.0;
  vec3 pa = vec3(0.0), alpha = vec3(0.0);
  bool have_prev = false;
  uint slot = slot0;
  seen = 0u;
  for (uint i = i0; i < count; ++i) {
    float z;
    vec3 a;
    uint next;
    cdsm_slot(rgb, slot, z, a, next);
    uint tag = cdsm_tag(rgb, slot);
    uint idx = seen++;
    if (z > hi) {
      if (have_prev && pz < hi) {
        float w = (hi - pz) / (z - pz);
        vec3 at_hi = cdsm_lerp3(pa, a, w);
        alpha = cdsm_over_layer(alpha, cdsm_layer_between(pa, at_hi));
      }
      break;
    }
    if (z < prefix_end) {
      alpha = a;
    } else {
      bool counts;
      if (idx == own_index) counts = false;
      else if (tag != 0u && z >= lo) counts = (tag & 0x3fffu) != own && (tag >> 14) < own_rank;
      else counts = true;
      if (counts) alpha = cdsm_over_layer(alpha, cdsm_layer_between(have_prev ? pa : vec3(0.0), a));
    }
    pz = z;
    pa = a;
    have_prev = true;
    slot = CDSM_LAYOUT_IS(CDSM_LAYOUT_CHUNKED) ? next : slot + 1u;
  }
  return alpha;
}

// hd/compress.h tag_object: the object bits of a receiver's tags (0: none).
uint cdsm_tag_object(uint object) { return object == CDSM_NO_OBJECT ? 0u : object % 16383u + 1u; }

// The unit direction from p toward light L (hd/lights.h to_light).
vec3 cdsm_to_light(CdsmLight L, vec3 p) {
  if (L.type == CDSM_LIGHT_DIRECTIONAL) return L.direction * -1.0;
  return cdsm_normalize(L.position - p);
}

// The slope-bias baseline's offset (hd/lights.h slope_bias_offset).
float cdsm_slope_bias_offset(CdsmLight L, CdsmMap m, CdsmProjection pr, vec3 p, vec3 plane) {
  if (!(cdsm_dot(plane, plane) > 0.0)) return 0.0;
  float ndl = abs(cdsm_dot(plane, cdsm_to_light(L, p)));
  float tan_inc = sqrt(max(0.0, 1.0 - ndl * ndl)) / max(ndl, 0.02);
  return CDSM_SLOPE_BIAS_CONSTANT + CDSM_SLOPE_BIAS_TEXELS * cdsm_texel_footprint(m, pr.axial) * tan_inc;
}

// One map's α at the receiver (hd/lights.h map_alpha): its bilinear taps
// (thesis eq. 4.18-4.19), volume samples each at the point's depth, surfaces
// each at its plane depth with their own step left out; taps outside the map
// count as 0.
vec3 cdsm_map_alpha(CdsmLight L, CdsmMap m, CdsmProjection pr, vec3 p, vec3 plane, uint object) {
  bool surface = cdsm_dot(plane, plane) > 0.0;
  bool at_point = cdsm_receiver == CDSM_RECEIVER_SLOPE_BIAS || !surface;
  float point_z = pr.depth - (cdsm_receiver == CDSM_RECEIVER_SLOPE_BIAS ? cdsm_slope_bias_offset(L, m, pr, p, plane) : 0.0);
  uint own = cdsm_tag_object(object);
  float footprint = cdsm_texel_footprint(m, pr.axial);
  int res = int(m.res);
  // Without filtering the first tap is the texel holding the point, with
  // weight 1, and the other three weigh 0 (one copy of the tap code).
  bool filtered = cdsm_filtering != 0u;
  float lx = filtered ? pr.u - 0.5 : pr.u, ly = filtered ? pr.v - 0.5 : pr.v;
  float fx = floor(lx), fy = floor(ly);
  float wx = filtered ? lx - fx : 0.0, wy = filtered ? ly - fy : 0.0;
  int x0 = int(fx), y0 = int(fy);
  vec3 a = vec3(0.0);
  for (int k = 0; k < 4; ++k) {
    int tx = x0 + (k & 1), ty = y0 + (k >> 1);
    float w = ((k & 1) != 0 ? wx : 1.0 - wx) * ((k >> 1) != 0 ? wy : 1.0 - wy);
    if (w <= 0.0 || tx < 0 || ty < 0 || tx >= res || ty >= res) continue;
    vec3 t;
    if (at_point) {
      t = cdsm_texel_alpha(m, tx, ty, point_z);
    } else {
      float depth = cdsm_tap_depth(m, pr, p, plane, tx, ty);
      float coplanar = CDSM_RELATIVE_DEPTH_OFFSET * depth;
      float window = cdsm_bias_constant + cdsm_bias_slope * footprint + coplanar;
      t = cdsm_texel_receive(m, m.texel_offset + uint(ty) * m.res + uint(tx), depth, window, coplanar, own);
    }
    if (m.rgb == 0u) a.x += w * t.x;  // grey maps accumulate one scalar, as the C++ does
    else a = a + t * w;
  }
  return m.rgb == 0u ? vec3(a.x) : a;
}

