#version 450 core
// Per-pixel fragment lists (DESIGN.md 2.1), engine/gl/fragment_raster.cpp.
// One program for both passes, so both rasterize identically:
//   u_pass 0 (count): atomicAdd(counts[pixel], 1)
//   u_pass 1 (fill):  counts[pixel] runs back down to 0 as a cursor and each
//                     fragment {radial depth, primitive | front bit} lands in
//                     fragments[offsets[pixel] - u_frag_base + cursor].
// No depth test, no culling, depth clamp on (so GL never clips at its own
// near/far), and the view's [near, far] on the view axis is applied here per
// fragment, as the CPU ray caster does. Compiled once per stage with
// VERTEX_STAGE or FRAGMENT_STAGE defined.
//
// Projection = PinholeView (shadows/hd/view.h): with d = p - eye,
//   x_clip = (dot(d,right) - center.x * z) / tan_half_x,
//   y_clip = (dot(d,up)    - center.y * z) / tan_half_y,   w = z = dot(d,forward),
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
layout(location = 8) uniform uint u_frag_base; // band offset of the fill tile's first pixel
layout(location = 9) uniform int u_pass;       // 0 count, 1 fill
layout(location = 10) uniform uint u_tri_base; // first triangle of the bound normal range
layout(location = 11) uniform float u_clip_z;  // user clip plane z >= u_clip_z (< near), drops geometry behind the eye

#if defined(VERTEX_STAGE)

layout(location = 0) in vec3 a_position;  // world space

// Per triangle: cross(B - A, C - A), computed on the host exactly as the
// CPU ray caster does. 3 floats each (std430 float array, no vec3 padding).
layout(std430, binding = 3) readonly buffer TriNormals { float tri_normals[]; };

out vec3 v_rel;              // p - eye; perspective-correct, so exact at the pixel centre
flat out uint v_prim;        // global triangle index
flat out vec3 v_normal;      // unnormalized geometric normal
out float gl_ClipDistance[1];

void main() {
  vec3 d = a_position - u_eye;
  float z = dot(d, u_forward);
  gl_Position = vec4((dot(d, u_right) - u_window.x * z) / u_window.z,
                     (dot(d, u_up) - u_window.y * z) / u_window.w, 0.0, z);
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
  uint bits;        // bits 0..29 primitive, bit 31 front-facing
};

layout(std430, binding = 0) buffer Counts { uint counts[]; };          // per band pixel
layout(std430, binding = 1) readonly buffer Offsets { uint offsets[]; }; // exclusive sums of counts
layout(std430, binding = 2) writeonly buffer Fragments { Fragment fragments[]; };

in vec3 v_rel;
flat in uint v_prim;
flat in vec3 v_normal;

void main() {
  float axial = dot(v_rel, u_forward);
  if (axial < u_near_far.x || axial > u_near_far.y) return;
  int px = int(gl_FragCoord.x);
  int py = u_size.y - 1 - int(gl_FragCoord.y);  // image rows go down
  uint pixel = uint(py - u_row0) * uint(u_size.x) + uint(px);
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
  vec3 dir = u_forward + u_right * s.x + u_up * s.y;
  bool front = dot(v_normal, dir) < 0.0;
  Fragment f;
  f.depth = length(v_rel);
  f.bits = (v_prim & 0x3fffffffu) | (front ? 0x80000000u : 0u);
  fragments[offsets[pixel] - u_frag_base + left - 1u] = f;
}

#else
#error define VERTEX_STAGE or FRAGMENT_STAGE
#endif
