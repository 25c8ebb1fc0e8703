// cdsm.glsl — clustered deep shadow map lookups for an application's own
// shaders (README.md, "Use it in your engine"). Include it after the application's `#version 450`
// (or later) line, in any stage that may use shader storage blocks
// (fragment and compute shaders always can), then bind the buffers with
// cdsm::ShadowSystem::bind_gl(program) after each update().
//
//   vec3 cdsm_surface_transmittance(vec3 world_pos, vec3 plane_normal, uint object, int light)
//   vec3 cdsm_transmittance(vec3 world_pos, int light)
//
// return the light's transmittance to the point per colour channel (1 - α of
// the light's deep shadow maps), exactly as the library's own camera pass
// computes it (shadows/hd/lights.h: the same projection, bilinear taps,
// node search, offsets and cluster combination, thesis eq. 3.12, 4.18-4.19):
//   - surfaces pass their triangle's geometric normal (unit, either side;
//     not the interpolated shading normal) as `plane_normal`: each tap reads
//     its texel where its own light ray crosses that plane; `object` is the
//     object's id when it casts shadows (cdsm::ShadowSystem::gl_object_id:
//     its own surface is in the maps, and the lookup leaves out exactly its
//     own step, found by identity), CDSM_NO_OBJECT for receive-only surfaces
//     (every surface in front of the point counts; one coplanar with it, a
//     decal, is in front of it);
//   - volume samples (and any point without a surface) use
//     cdsm_transmittance: every tap at the point's own depth.
// `light` is the light's index (cdsm::ShadowSystem::gl_light_index). An
// index outside [0, cdsm_light_count()) returns vec3(1, 0, 1): a magenta
// tint that shows the mistake instead of hiding it.
//
// For shading, the light itself: cdsm_light_count(), cdsm_light_position(i)
// (spot and point lights), cdsm_light_direction(i) (a spot's axis, a
// directional light's direction of travel), cdsm_direction_to_light(i, p)
// (unit, toward the light from p, for every type), cdsm_light_radiance(i)
// (colour x intensity) and cdsm_spot_factor(i, p) (the spot cone's smooth
// falloff, 1 for point and directional lights) — the Phong model of
// shadows/hd/shading.h multiplies radiance, spot factor and transmittance.
//
// Shader variants: `#define CDSM_LAYOUT n` before the include (0 packed,
// 1 fixed, 2 chunked: cdsm::GlMapBuffers::layout) compiles the lookups of
// that node layout only; recompile when the buffers' layout changes. A
// variant reading buffers of another layout returns the magenta tint.
// Without it every layout's code is compiled and the frame block picks one
// at run time, which is right everywhere but costs a GPU that runs both
// sides of a branch under a mask (Mesa's llvmpipe) every layout's code at
// every tap (the forward example's frame there, four clusters at 620x757:
// 448 ms with every layout's code, 410 ms with the packed variant).
//
// Bindings: nine shader storage blocks at CDSM_BINDING_BASE .. +8 (default
// 8; #define it before the include to move them). bind_gl() reads the
// bindings back from the linked program, so any base below
// GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS - 8 works. The including stage needs
// GL_MAX_FRAGMENT_SHADER_STORAGE_BLOCKS (or _COMPUTE_) of at least 9 plus
// its own blocks; GL 4.5 guarantees 8, and a ShadowSystem on a context with
// fewer than 9 refuses to start, naming the limit.
//
// Layout (std430, the bytes the CDSM_HD code reads, static_asserted there):
// CdsmFrame holds the lookup settings, the lights and the map headers
// (engine/gl/map_buffers.h FrameBlockHeader, shadows/hd/dsm.h DsmMap); the
// other eight are DsmStorage's arrays: texel headers {offset, count}, scalar
// nodes {z, α}, chunk slots {z, α, next}, the same for RGB maps
// ({z, r, g, b}), then each pool's surface tags (16 bits per node or chunk
// slot, two to a uint, the lower half first). Depths are radial distances
// from the light (orthographic maps: distances from the map's plane).

#ifndef CDSM_GLSL_INCLUDED
#define CDSM_GLSL_INCLUDED

#ifndef CDSM_BINDING_BASE
#define CDSM_BINDING_BASE 8
#endif

// shadows/hd/view.h PinholeView (96 bytes). Orthographic views (directional
// lights): `eye` is the centre of the window's plane, the window
// (tan_half_*, center) is in world units, rays run along `forward` from
// their point on that plane, depths are distances from it.
struct CdsmView {
  vec3 eye;
  float near_z;
  vec3 right;
  float far_z;
  vec3 up;
  float tan_half_x;
  vec3 forward;
  float tan_half_y;
  vec2 center;
  int width;
  int height;
  uint projection;  // CDSM_PROJECTION_PERSPECTIVE / CDSM_PROJECTION_ORTHOGRAPHIC
  uint view_pad0;
  uint view_pad1;
  uint view_pad2;
};

// shadows/hd/dsm.h DsmMap (112 bytes); texel_offset is a uint64 there.
struct CdsmMap {
  CdsmView view;
  uint texel_offset;
  uint texel_offset_high;  // always 0 (checked on upload)
  uint res;
  uint rgb;  // 1: RGB nodes (the Rgb blocks), 0: scalar nodes
};

// shadows/hd/lights.h LightData (64 bytes).
struct CdsmLight {
  vec3 position;
  uint type;  // CDSM_LIGHT_SPOT / CDSM_LIGHT_POINT / CDSM_LIGHT_DIRECTIONAL (position unused, direction of travel)
  vec3 direction;
  float cos_outer;
  vec3 radiance;
  float cos_inner;
  uint first_map;
  uint map_count;
  uint map_mode;  // CDSM_MAPS_COMBINE (clusters), _CUBE_FACES (six), _FIRST_CONTAINING (parallel splits)
  float size;     // spot, point: the sphere's radius; directional: tan of half the angular diameter (0: a point)
};

struct CdsmChunk {
  float z;
  float alpha;
  uint next;
};

struct CdsmChunkRgb {
  float z;
  float r;
  float g;
  float b;
  uint next;
};

layout(std430, binding = CDSM_BINDING_BASE + 0) readonly buffer CdsmFrame {
  uint cdsm_layout;  // 0 packed, 1 fixed, 2 chunked
  uint cdsm_layers;  // fixed: node slots per texel
  uint cdsm_filtering;
  uint cdsm_receiver;  // CDSM_RECEIVER_PLANE / CDSM_RECEIVER_SLOPE_BIAS
  float cdsm_bias_constant;
  float cdsm_bias_slope;
  uint cdsm_light_total;
  uint cdsm_map_total;
  uint cdsm_penumbra;  // CDSM_PENUMBRA_ESTIMATED / _FIXED_KERNEL / _HARD (lights with a size)
  uint cdsm_pad0, cdsm_pad1, cdsm_pad2;
  CdsmLight cdsm_lights[8];
  CdsmMap cdsm_maps[];
};
layout(std430, binding = CDSM_BINDING_BASE + 1) readonly buffer CdsmTexels { uvec2 cdsm_texels[]; };
layout(std430, binding = CDSM_BINDING_BASE + 2) readonly buffer CdsmNodes { vec2 cdsm_nodes[]; };
layout(std430, binding = CDSM_BINDING_BASE + 3) readonly buffer CdsmChunks { CdsmChunk cdsm_chunks[]; };
layout(std430, binding = CDSM_BINDING_BASE + 4) readonly buffer CdsmRgbTexels { uvec2 cdsm_rgb_texels[]; };
layout(std430, binding = CDSM_BINDING_BASE + 5) readonly buffer CdsmRgbNodes { vec4 cdsm_rgb_nodes[]; };
layout(std430, binding = CDSM_BINDING_BASE + 6) readonly buffer CdsmRgbChunks { CdsmChunkRgb cdsm_rgb_chunks[]; };
layout(std430, binding = CDSM_BINDING_BASE + 7) readonly buffer CdsmTags { uint cdsm_tags[]; };
layout(std430, binding = CDSM_BINDING_BASE + 8) readonly buffer CdsmRgbTags { uint cdsm_rgb_tags[]; };

// The object id of a receive-only surface (and of no surface).
const uint CDSM_NO_OBJECT = 0xffffffffu;

// The tags of cdsm/tags.h, value for value (tests/unit/test_tags.cpp
// reads them from this file and checks them).
#define CDSM_LAYOUT_PACKED 0
#define CDSM_LAYOUT_FIXED 1
#define CDSM_LAYOUT_CHUNKED 2
const uint CDSM_LIGHT_SPOT = 0u;
const uint CDSM_LIGHT_POINT = 1u;
const uint CDSM_LIGHT_DIRECTIONAL = 2u;
const uint CDSM_PROJECTION_PERSPECTIVE = 0u;
const uint CDSM_PROJECTION_ORTHOGRAPHIC = 1u;
const uint CDSM_MAPS_COMBINE = 0u;
const uint CDSM_MAPS_CUBE_FACES = 1u;
const uint CDSM_MAPS_FIRST_CONTAINING = 2u;
const uint CDSM_RECEIVER_PLANE = 0u;
const uint CDSM_RECEIVER_SLOPE_BIAS = 1u;
const uint CDSM_PENUMBRA_ESTIMATED = 0u;
const uint CDSM_PENUMBRA_FIXED_KERNEL = 1u;
const uint CDSM_PENUMBRA_HARD = 2u;

#ifdef CDSM_LAYOUT
#if CDSM_LAYOUT < 0 || CDSM_LAYOUT > 2
#error "CDSM_LAYOUT: 0 packed, 1 fixed or 2 chunked"
#endif
#define CDSM_LAYOUT_IS(n) (CDSM_LAYOUT == n)
#else
#define CDSM_LAYOUT_IS(n) (cdsm_layout == uint(n))
#endif

// shadows/hd/lights.h constants.
const float CDSM_PLANE_REACH_TEXELS = 50.0;
const float CDSM_RELATIVE_DEPTH_OFFSET = 2e-5;
const float CDSM_SLOPE_BIAS_CONSTANT = 0.0005;
const float CDSM_SLOPE_BIAS_TEXELS = 1.5;
const int CDSM_PENUMBRA_SEARCH_RINGS = 7;
const int CDSM_PENUMBRA_MAX_SIDE = 12;
const float CDSM_PENUMBRA_SEARCH_TEXELS = 32.0;
const float CDSM_PENUMBRA_MIN_ALPHA = 1.0e-3;
// hd/lights.h penumbra_direction: every 22.5 degrees.
const vec2 CDSM_PENUMBRA_DIRECTIONS[16] = vec2[16](
    vec2(1.00000000, 0.00000000),
    vec2(0.92387953, 0.38268343),
    vec2(0.70710678, 0.70710678),
    vec2(0.38268343, 0.92387953),
    vec2(0.00000000, 1.00000000),
    vec2(-0.38268343, 0.92387953),
    vec2(-0.70710678, 0.70710678),
    vec2(-0.92387953, 0.38268343),
    vec2(-1.00000000, 0.00000000),
    vec2(-0.92387953, -0.38268343),
    vec2(-0.70710678, -0.70710678),
    vec2(-0.38268343, -0.92387953),
    vec2(-0.00000000, -1.00000000),
    vec2(0.38268343, -0.92387953),
    vec2(0.70710678, -0.70710678),
    vec2(0.92387953, -0.38268343));

// ---- the math of cdsm/math.h, in its order of operations -------------------
// (GLSL's dot/length/normalize/mix may associate differently; these match
// the C++ to the last bit where the compiler does not contract.)

float cdsm_dot(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
float cdsm_length(vec3 a) { return sqrt(cdsm_dot(a, a)); }
vec3 cdsm_normalize(vec3 a) {
  float l = cdsm_length(a);
  return l > 0.0 ? a * (1.0 / l) : a;
}
float cdsm_lerp(float a, float b, float t) { return a + (b - a) * t; }
vec3 cdsm_over(vec3 alpha, vec3 a) { return alpha + a * (vec3(1.0) - alpha); }

// ---- views (shadows/hd/view.h) ----------------------------------------------

struct CdsmProjection {
  float u, v;    // texels
  float depth;   // radial distance from the eye; orthographic: from the window's plane
  float axial;   // along the view axis
};

CdsmProjection cdsm_project(CdsmView view, vec3 p) {
  vec3 d = p - view.eye;
  float za = cdsm_dot(d, view.forward);
  bool ortho = view.projection == CDSM_PROJECTION_ORTHOGRAPHIC;
  float inv = ortho ? 1.0 : za > 0.0 ? 1.0 / za : 0.0;
  float sx = cdsm_dot(d, view.right) * inv - view.center.x;
  float sy = cdsm_dot(d, view.up) * inv - view.center.y;
  CdsmProjection r;
  r.u = (sx / view.tan_half_x + 1.0) * 0.5 * float(view.width);
  r.v = (1.0 - sy / view.tan_half_y) * 0.5 * float(view.height);
  r.depth = ortho ? za : cdsm_length(d);
  r.axial = za;
  return r;
}

vec2 cdsm_window_at(CdsmView view, float u, float v) {
  return vec2(view.center.x + (2.0 * u / float(view.width) - 1.0) * view.tan_half_x,
              view.center.y + (1.0 - 2.0 * v / float(view.height)) * view.tan_half_y);
}

vec3 cdsm_view_direction(CdsmView view, float u, float v) {
  if (view.projection == CDSM_PROJECTION_ORTHOGRAPHIC) return view.forward;
  vec2 s = cdsm_window_at(view, u, v);
  return view.forward + view.right * s.x + view.up * s.y;
}

// Where the ray through image position (u, v) starts (hd/view.h view_origin).
vec3 cdsm_view_origin(CdsmView view, float u, float v) {
  if (view.projection != CDSM_PROJECTION_ORTHOGRAPHIC) return view.eye;
  vec2 s = cdsm_window_at(view, u, v);
  return view.eye + view.right * s.x + view.up * s.y;
}

// ---- one texel's visibility function (shadows/hd/dsm.h) ----------------------

// Slot i's surface tag in the grey or the RGB pool.
uint cdsm_tag(bool rgb, uint i) {
  uint w = rgb ? cdsm_rgb_tags[i >> 1u] : cdsm_tags[i >> 1u];
  return (w >> ((i & 1u) * 16u)) & 0xffffu;
}

// Slot i of the grey or RGB pool of the current layout: depth, alpha per
// channel (grey: its one value in each), the chunked layout's link.
void cdsm_slot(bool rgb, uint i, out float z, out vec3 a, out uint next) {
  next = 0u;
  if (CDSM_LAYOUT_IS(CDSM_LAYOUT_CHUNKED)) {
    if (rgb) {
      CdsmChunkRgb c = cdsm_rgb_chunks[i];
      z = c.z;
      a = vec3(c.r, c.g, c.b);
      next = c.next;
    } else {
      CdsmChunk c = cdsm_chunks[i];
      z = c.z;
      a = vec3(c.alpha);
      next = c.next;
    }
  } else if (rgb) {
    vec4 n = cdsm_rgb_nodes[i];
    z = n.x;
    a = n.yzw;
  } else {
    vec2 n = cdsm_nodes[i];
    z = n.x;
    a = vec3(n.y);
  }
}

vec3 cdsm_lerp3(vec3 a, vec3 b, float t) { return vec3(cdsm_lerp(a.x, b.x, t), cdsm_lerp(a.y, b.y, t), cdsm_lerp(a.z, b.z, t)); }

// α(z) of texel (tx, ty) of map m per channel (a grey map: its value in
// every channel), either node kind through cdsm_slot (one search, as
// hd/dsm.h alpha_at_index and lookup_alpha_chunked are one over N). The
// packed and fixed layouts share one binary search: a texel's nodes start
// at its header's offset, or at a fixed stride; chunked texels are walked
// along their links.
vec3 cdsm_texel_alpha(CdsmMap m, int tx, int ty, float z) {
  uint t = m.texel_offset + uint(ty) * m.res + uint(tx);
  bool rgb = m.rgb != 0u;
  float nz;
  vec3 na;
  uint next;
  if (CDSM_LAYOUT_IS(CDSM_LAYOUT_CHUNKED)) {
    uvec2 head = rgb ? cdsm_rgb_texels[t] : cdsm_texels[t];
    float pz = 0.0;
    vec3 pa = vec3(0.0);
    uint slot = head.x;
    for (uint i = 0u; i < head.y; ++i) {
      cdsm_slot(rgb, slot, nz, na, next);
      if (nz >= z) {
        if (nz == z) return na;
        if (i == 0u) return vec3(0.0);
        return cdsm_lerp3(pa, na, (z - pz) / (nz - pz));
      }
      pz = nz;
      pa = na;
      slot = next;
    }
    return pa;
  }
  uvec2 span = CDSM_LAYOUT_IS(CDSM_LAYOUT_FIXED) ? uvec2(t * cdsm_layers, cdsm_layers) : rgb ? cdsm_rgb_texels[t] : cdsm_texels[t];
  uint lo = 0u, hi = span.y;
  while (lo < hi) {
    uint mid = (lo + hi) >> 1;
    cdsm_slot(rgb, span.x + mid, nz, na, next);
    if (nz < z) lo = mid + 1u;
    else hi = mid;
  }
  if (lo >= span.y) {
    if (span.y == 0u) return vec3(0.0);
    cdsm_slot(rgb, span.x + span.y - 1u, nz, na, next);
    return na;
  }
  cdsm_slot(rgb, span.x + lo, nz, na, next);
  if (nz == z) return na;
  if (lo == 0u) return vec3(0.0);
  float bz = nz;
  vec3 ba = na;
  cdsm_slot(rgb, span.x + lo - 1u, nz, na, next);
  return cdsm_lerp3(na, ba, (z - nz) / (bz - nz));
}

// ---- receivers (shadows/hd/lights.h) ----------------------------------------

float cdsm_texel_footprint(CdsmMap m, float axial) {
  return 2.0 * m.view.tan_half_x * (m.view.projection == CDSM_PROJECTION_ORTHOGRAPHIC ? 1.0 : axial) / float(m.res);
}

// The depth at which tap (tx, ty) reads its texel: where its texel-centre ray
// crosses the receiver's plane (within a reach of the point's depth), or
// the point's own depth (volume samples, the slope-bias baseline).
float cdsm_tap_depth(CdsmMap m, CdsmProjection pr, vec3 p, vec3 plane, int tx, int ty) {
  if (cdsm_receiver == CDSM_RECEIVER_SLOPE_BIAS || !(cdsm_dot(plane, plane) > 0.0)) return pr.depth;
  float reach = CDSM_PLANE_REACH_TEXELS * cdsm_texel_footprint(m, pr.axial);
  vec3 d = cdsm_normalize(cdsm_view_direction(m.view, float(tx) + 0.5, float(ty) + 0.5));
  float dn = cdsm_dot(d, plane);
  vec3 origin = cdsm_view_origin(m.view, float(tx) + 0.5, float(ty) + 0.5);
  float t = dn != 0.0 ? cdsm_dot(p - origin, plane) / dn : pr.depth + reach;
  if (!(t > pr.depth - reach)) t = pr.depth - reach;
  if (!(t < pr.depth + reach)) t = pr.depth + reach;
  return t;
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

// ---- lights with a size: penumbrae from the maps (hd/lights.h) ---------------

float cdsm_grey(vec3 a) { return a.x == a.y && a.y == a.z ? a.x : (a.x + a.y + a.z) * (1.0 / 3.0); }

// The radius (window units) within which shadow rays to the light's area
// cross depth zb (hd/lights.h penumbra_radius).
float cdsm_penumbra_radius(CdsmLight L, CdsmMap m, float z, float zb) {
  float d = max(z - zb, 0.0);
  return m.view.projection == CDSM_PROJECTION_ORTHOGRAPHIC ? L.size * d : L.size * d / (z * max(zb, 1e-6));
}

bool cdsm_disk_grid_point(int i, int j, int side, out float x, out float y) {
  x = (2.0 * float(i) + 1.0) / float(side) - 1.0;
  y = (2.0 * float(j) + 1.0) / float(side) - 1.0;
  return x * x + y * y <= 1.0;
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
  float texel = 2.0 * max(m.view.tan_half_x, m.view.tan_half_y) / float(m.res);
  float search = min(cdsm_penumbra_radius(L, m, z, max(m.view.near_z, 1e-6)), CDSM_PENUMBRA_SEARCH_TEXELS * texel);
  float to_u = float(m.res) / (2.0 * m.view.tan_half_x), to_v = float(m.res) / (2.0 * m.view.tan_half_y);
  int res = int(m.res);
  float weight = 0.0, moment = 0.0;
  // The texel under the receiver, then rings of 8 at 1, 2, 4, ... texels
  // out to the search radius (every other ring turned by 22.5 degrees).
  float ring = 0.0;
  for (int k = 0; k < 2 + 8 * CDSM_PENUMBRA_SEARCH_RINGS; ++k) {
    if (k > 0 && (k - 1) % 8 == 0) {
      if (ring >= search) break;
      ring = min(k == 1 ? texel : 2.0 * ring, search);
    }
    int d = k == 0 ? 0 : ((k - 1) % 8) * 2 + (((k - 1) / 8) & 1);
    float x = k == 0 ? 0.0 : ring * CDSM_PENUMBRA_DIRECTIONS[d].x;
    float y = k == 0 ? 0.0 : ring * CDSM_PENUMBRA_DIRECTIONS[d].y;
    int tx = int(floor(pr.u + x * to_u)), ty = int(floor(pr.v + y * to_v));
    if (tx < 0 || ty < 0 || tx >= res || ty >= res) continue;
    vec2 b = cdsm_texel_blockers(m, m.texel_offset + uint(ty) * m.res + uint(tx),
                                 cdsm_blocker_limit(L, m, pr, p, plane, tx, ty));
    if (!(b.x > CDSM_PENUMBRA_MIN_ALPHA)) continue;
    float dx = (float(tx) + 0.5 - pr.u) / to_u, dy = (float(ty) + 0.5 - pr.v) / to_v;
    if (sqrt(dx * dx + dy * dy) > 2.0 * cdsm_penumbra_radius(L, m, z, b.y) + texel) continue;
    weight += b.x;
    moment += b.x * b.y;
  }
  return weight > CDSM_PENUMBRA_MIN_ALPHA ? cdsm_penumbra_radius(L, m, z, moment / weight) : 0.0;
}

// Whether a filter tap at `at` may shadow the receiver (hd/lights.h
// blocks_receiver): its texel's blockers within their own reach of it (plus
// a texel), or none.
bool cdsm_blocks_receiver(CdsmLight L, CdsmMap m, CdsmProjection pr, vec3 p, vec3 plane, CdsmProjection at) {
  int tx = int(floor(at.u)), ty = int(floor(at.v)), res = int(m.res);
  if (tx < 0 || ty < 0 || tx >= res || ty >= res) return true;
  float to_u = float(m.res) / (2.0 * m.view.tan_half_x), to_v = float(m.res) / (2.0 * m.view.tan_half_y);
  float texel = 2.0 * max(m.view.tan_half_x, m.view.tan_half_y) / float(m.res);
  vec2 b = cdsm_texel_blockers(m, m.texel_offset + uint(ty) * m.res + uint(tx),
                               cdsm_blocker_limit(L, m, pr, p, plane, tx, ty));
  if (!(b.x > CDSM_PENUMBRA_MIN_ALPHA)) return true;
  float dx = (at.u - pr.u) / to_u, dy = (at.v - pr.v) / to_v;
  return sqrt(dx * dx + dy * dy) <= cdsm_penumbra_radius(L, m, pr.depth, b.y) + texel;
}

// One map's α for a light with a size: the hard lookup filtered over the
// penumbra's disk (hd/lights.h soft_map_alpha_in_colour); else the hard one.
vec3 cdsm_light_map_alpha(CdsmLight L, CdsmMap m, CdsmProjection pr, vec3 p, vec3 plane, uint object) {
  if (!(L.size > 0.0) || cdsm_penumbra == CDSM_PENUMBRA_HARD) return cdsm_map_alpha(L, m, pr, p, plane, object);
  float radius = cdsm_penumbra_filter_radius(L, m, pr, p, plane);
  float to_u = float(m.res) / (2.0 * m.view.tan_half_x), to_v = float(m.res) / (2.0 * m.view.tan_half_y);
  float texels = radius * max(to_u, to_v);
  if (!(texels >= 0.5)) return cdsm_map_alpha(L, m, pr, p, plane, object);
  int side = int(min(ceil(2.0 * texels), float(CDSM_PENUMBRA_MAX_SIDE)));
  vec3 sum = vec3(0.0);
  int taps = 0;
  for (int j = 0; j < side; ++j)
    for (int i = 0; i < side; ++i) {
      float x, y;
      if (!cdsm_disk_grid_point(i, j, side, x, y)) continue;
      CdsmProjection at = pr;
      at.u = pr.u + x * radius * to_u;
      at.v = pr.v + y * radius * to_v;
      ++taps;
      if (cdsm_penumbra == CDSM_PENUMBRA_ESTIMATED && !cdsm_blocks_receiver(L, m, pr, p, plane, at)) continue;
      sum = sum + cdsm_map_alpha(L, m, at, p, plane, object);
    }
  return sum * (1.0 / float(taps));
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
