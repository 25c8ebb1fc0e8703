#version 450 core
// A mesh in the application's own GL buffers (cdsm::GlMeshSource, a mesh
// that stays on the GPU), read where it is: one invocation per triangle.
//   u_mode 0 (gather): the triangle's world positions and its facing
//     normal cross(B - A, C - A) into the fragment rasterizer's scene
//     buffers (engine/gl/fragment_raster.cpp) at triangle u_first_tri + t,
//     so the rasterizer draws it like any uploaded triangle;
//   u_mode 1 (bounds): the world box of the triangles' vertices, as
//     order-preserving uints (min xyz, max xyz), for clustering.
// Positions are transformed as Mat4::point does it on the host (row by row,
// left to right, no fused multiply-add: `precise`), and the winding flipped
// for a mirroring transform as compile_object() flips it, so a mesh gathered
// here rasterizes exactly as the same floats given on the host would. A
// triangle with an index past the vertices or a non-finite position is made
// degenerate (all three vertices at one point: no fragment, no bound).
layout(local_size_x = 64) in;

layout(location = 0) uniform uint u_tris;           // triangles of the mesh
layout(location = 1) uniform uint u_first_tri;      // its first triangle in the rasterizer's buffers
layout(location = 2) uniform uint u_vertex_first;   // float index of the first position
layout(location = 3) uniform uint u_vertex_stride;  // floats between positions
layout(location = 4) uniform uint u_vertex_count;
layout(location = 5) uniform uint u_index_size;     // bytes per index: 4, 2, 1; 0: not indexed
layout(location = 6) uniform uint u_index_first;    // byte offset of the first index (in the copy: 0..3)
layout(location = 7) uniform vec4 u_model[3];       // the object's transform, rows
layout(location = 10) uniform uint u_mirrored;      // 1: winding flipped (negative determinant)
layout(location = 11) uniform uint u_mode;          // 0 gather, 1 bounds

layout(std430, binding = 0) readonly buffer Positions { float positions[]; };  // the application's
layout(std430, binding = 1) readonly buffer Indices { uint indices[]; };       // a copy of the application's, whole words
layout(std430, binding = 2) writeonly buffer Vertices { float vertices[]; };   // 9 floats per triangle
layout(std430, binding = 3) writeonly buffer Normals { float normals[]; };     // 3 floats per triangle
layout(std430, binding = 4) buffer Bounds { uint bounds[6]; };

uint index_at(uint i) {
  if (u_index_size == 0u) return i;
  uint byte_at = u_index_first + i * u_index_size;
  uint word = indices[byte_at >> 2u];
  uint shift = (byte_at & 3u) * 8u;
  if (u_index_size == 4u) return word;
  if (u_index_size == 2u) return (word >> shift) & 0xffffu;
  return (word >> shift) & 0xffu;
}

// A float as a uint that orders as the float does.
uint ordered(float f) {
  uint u = floatBitsToUint(f);
  return (u & 0x80000000u) != 0u ? ~u : u | 0x80000000u;
}

void main() {
  uint t = gl_GlobalInvocationID.x;
  if (t >= u_tris) return;
  uint k[3] = uint[3](index_at(3u * t), index_at(3u * t + (u_mirrored != 0u ? 2u : 1u)),
                      index_at(3u * t + (u_mirrored != 0u ? 1u : 2u)));
  precise vec3 p[3];
  bool ok = true;
  for (int c = 0; c < 3; ++c) {
    if (k[c] >= u_vertex_count) {
      ok = false;
      p[c] = vec3(0.0);
      continue;
    }
    uint f = u_vertex_first + k[c] * u_vertex_stride;
    vec3 q = vec3(positions[f], positions[f + 1u], positions[f + 2u]);
    precise float x = u_model[0].x * q.x + u_model[0].y * q.y + u_model[0].z * q.z + u_model[0].w;
    precise float y = u_model[1].x * q.x + u_model[1].y * q.y + u_model[1].z * q.z + u_model[1].w;
    precise float z = u_model[2].x * q.x + u_model[2].y * q.y + u_model[2].z * q.z + u_model[2].w;
    p[c] = vec3(x, y, z);
    ok = ok && !any(isnan(p[c])) && !any(isinf(p[c]));
  }
  if (!ok) p[0] = p[1] = p[2] = vec3(0.0);
  if (u_mode == 1u) {
    if (!ok) return;
    for (int c = 0; c < 3; ++c)
      for (int a = 0; a < 3; ++a) {
        atomicMin(bounds[a], ordered(p[c][a]));
        atomicMax(bounds[3 + a], ordered(p[c][a]));
      }
    return;
  }
  uint o = 9u * (u_first_tri + t);
  for (int c = 0; c < 3; ++c) {
    vertices[o + 3u * uint(c)] = p[c].x;
    vertices[o + 3u * uint(c) + 1u] = p[c].y;
    vertices[o + 3u * uint(c) + 2u] = p[c].z;
  }
  precise vec3 u = p[1] - p[0];
  precise vec3 v = p[2] - p[0];
  precise vec3 n = vec3(u.y * v.z - u.z * v.y, u.z * v.x - u.x * v.z, u.x * v.y - u.y * v.x);
  uint m = 3u * (u_first_tri + t);
  normals[m] = n.x;
  normals[m + 1u] = n.y;
  normals[m + 2u] = n.z;
}
