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
  int cdsm_penumbra_taps;  // their filter's taps across a penumbra (ShadowSettings::penumbra_taps)
  uint cdsm_pad1, cdsm_pad2;
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
const float CDSM_PENUMBRA_SEARCH_TEXELS = 64.0;
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

