#version 450 core
// Per-pixel fragment lists, engine/gl/fragment_raster.cpp.
// One program for both passes, so both rasterize identically:
//   u_pass 0 (count): atomicAdd(counts[pixel], 1)
//   u_pass 1 (fill):  counts[pixel] runs back down to 0 as a cursor and each
//                     fragment {radial depth, primitive | front bit} lands in
//                     fragments[offsets[pixel] - u_frag_base + cursor], when
//                     that is within the pool's u_pool_size fragments.
// No depth test, no culling, depth clamp on (so GL never clips at its own
// near/far), and the view's [near, far] on the view axis is applied here per
// fragment, as the CPU ray caster does: outside it, only the fragments of
// media boundaries are kept, flagged clipped (shadows/hd/fragment.h), down to
// u_clip_z (hd/view.h media_clip_axial). Compiled once per stage with
// VERTEX_STAGE or FRAGMENT_STAGE defined.
//
// Projection = PinholeView (shadows/hd/view.h): with d = p - eye,
//   x_clip = (dot(d,right) - center.x * z) / tan_half_x,
//   y_clip = (dot(d,up)    - center.y * z) / tan_half_y,   w = z = dot(d,forward),
// and when orthographic (u_ortho, directional lights) the same without the
// divide: x_clip = (dot(d,right) - center.x) / tan_half_x, w = 1, depth along
// forward from the pixel's own origin on the eye's plane;
// so the GL window position equals the image position (u, H - v): image row
// py is GL row H-1-py (the flip happens in the pixel index, not in the
// projection, so it never changes rasterization or winding).

layout(location = 0) uniform vec3 u_eye;
layout(location = 1) uniform vec3 u_right;
layout(location = 2) uniform vec3 u_up;
layout(location = 3) uniform vec3 u_forward;
layout(location = 4) uniform vec4 u_window;    // center.x, center.y, tan_half_x, tan_half_y
layout(location = 5) uniform vec2 u_near_far;  // view-axis clip range, world units
layout(location = 6) uniform ivec2 u_size;     // view width, height in pixels
layout(location = 7) uniform int u_row0;       // first image row of the counted band
layout(location = 8) uniform uint u_frag_base; // batch offset of the pool's first fragment
layout(location = 9) uniform int u_pass;       // 0 count, 1 fill
layout(location = 10) uniform uint u_tri_base; // first triangle of the bound normal range
layout(location = 11) uniform float u_clip_z;  // user clip plane z >= u_clip_z (< near), drops geometry behind the eye
layout(location = 12) uniform float u_x_shift; // NDC shift of the geometry: half a snapping step (see below)
layout(location = 13) uniform int u_ortho;     // 1: orthographic (parallel rays along u_forward), 0: pinhole
layout(location = 14) uniform uint u_count_base; // the band's first counter in its batch (views counted together)
layout(location = 15) uniform uint u_pool_size;  // fragments the pool holds: a fill writes none past them

#if defined(VERTEX_STAGE)

layout(location = 0) in vec3 a_position;  // world space

// Per triangle: cross(B - A, C - A), computed on the host exactly as the
// CPU ray caster does. 3 floats each (std430 float array, no vec3 padding).
layout(std430, binding = 3) readonly buffer TriNormals { float tri_normals[]; };

out vec3 v_rel;              // p - eye; perspective-correct: a point of the triangle's plane at the sample
flat out uint v_prim;        // global triangle index
flat out vec3 v_normal;      // unnormalized geometric normal
out float gl_ClipDistance[1];

void main() {
  vec3 d = a_position - u_eye;
  float z = dot(d, u_forward);
  // GL snaps vertices to 2^-subpixel_bits of a pixel, and pixel centres lie
  // on that grid: a snapped vertex exactly at a centre is covered by a
  // tie-rule-dependent subset of its triangles, which at a silhouette
  // vertex can be an exit without its entry. Shifting the geometry by half a
  // snapping step in x keeps every sample off every snapped vertex (samples
  // on edges are resolved consistently by the tie rule).
  float w = u_ortho != 0 ? 1.0 : z;
  gl_Position = vec4((dot(d, u_right) - u_window.x * w) / u_window.z + u_x_shift * w,
                     (dot(d, u_up) - u_window.y * w) / u_window.w, 0.0, w);
  gl_ClipDistance[0] = z - u_clip_z;
  v_rel = d;
  // glDrawArrays/glMultiDrawArrays: gl_VertexID = first + i, so this is the
  // triangle's index in the uploaded array even when a mask skips ranges.
  uint prim = uint(gl_VertexID) / 3u;
  v_prim = prim;
  uint k = 3u * (prim - u_tri_base);
  v_normal = vec3(tri_normals[k], tri_normals[k + 1u], tri_normals[k + 2u]);
}

#elif defined(FRAGMENT_STAGE)

struct Fragment {   // cdsm::Fragment (shadows/hd/fragment.h), 8 bytes
  float depth;      // radial distance from the eye
  uint bits;        // bits 0..28 primitive, bit 29 clipped, bit 31 front-facing
};

layout(std430, binding = 0) buffer Counts { uint counts[]; };          // per pixel of the batch's bands
layout(std430, binding = 1) readonly buffer Offsets { uint offsets[]; }; // exclusive sums of counts
layout(std430, binding = 2) writeonly buffer Fragments { Fragment fragments[]; };
// Bit t set: triangle t bounds a medium (hd/scene_data.h bounds_medium).
layout(std430, binding = 4) readonly buffer TriMedia { uint tri_media[]; };

in vec3 v_rel;
flat in uint v_prim;
flat in vec3 v_normal;

void main() {
  float axial = dot(v_rel, u_forward);
  bool clipped = axial < u_near_far.x || axial > u_near_far.y;
  if (clipped && (axial < u_clip_z || ((tri_media[v_prim >> 5u] >> (v_prim & 31u)) & 1u) == 0u)) return;
  int px = int(gl_FragCoord.x);
  int py = u_size.y - 1 - int(gl_FragCoord.y);  // image rows go down
  uint pixel = u_count_base + uint(py - u_row0) * uint(u_size.x) + uint(px);
  if (u_pass == 0) {
    atomicAdd(counts[pixel], 1u);
    return;
  }
  uint left = atomicAdd(counts[pixel], 0xffffffffu);  // returns the count before the decrement
  if (left == 0u) return;  // cannot happen: both passes rasterize identically
  // The pixel-centre ray of view_direction() (view.h): front iff the ray
  // sees the counter-clockwise side, dot(cross(B-A, C-A), dir) < 0.
  vec2 s = u_window.xy + vec2((2.0 * (float(px) + 0.5) / float(u_size.x) - 1.0) * u_window.z,
                              (1.0 - 2.0 * (float(py) + 0.5) / float(u_size.y)) * u_window.w);
  bool ortho = u_ortho != 0;
  vec3 dir = ortho ? u_forward : u_forward + u_right * s.x + u_up * s.y;
  // Where the pixel's ray starts, relative to the eye (0 through a pinhole).
  vec3 origin = ortho ? u_right * s.x + u_up * s.y : vec3(0.0);
  float facing = dot(v_normal, dir);
  bool front = facing < 0.0;
  Fragment f;
  // Radial depth along the pixel-centre ray (the CPU's ray), not the
  // sample's (shifted by u_x_shift): the ray meets the triangle's plane,
  // through the interpolated point v_rel, at dot(n, v_rel - origin) / dot(n, unit dir).
  float hit = facing != 0.0 ? dot(v_normal, v_rel - origin) / facing * length(dir) : 0.0;
  f.depth = hit > 0.0 ? hit : (ortho ? axial : length(v_rel));
  f.bits = (v_prim & 0x1fffffffu) | (clipped ? 0x20000000u : 0u) | (front ? 0x80000000u : 0u);
  uint at = offsets[pixel] - u_frag_base + left - 1u;
  if (at < u_pool_size) fragments[at] = f;  // a batch larger than the pool (unchecked fill) loses the rest
}

#else
#error define VERTEX_STAGE or FRAGMENT_STAGE
#endif
