// The example renderer's own GLSL: a conventional forward renderer's
// shaders. Everything about shadows comes from cdsm.glsl (the library's
// include, pasted after each #version line by the renderer) and the buffers
// ShadowSystem::bind_gl() binds; the rest — transforms, Phong shading,
// blending, the volume ray marcher — is the application's.
#pragma once

namespace forward {

// Meshes: world position and normal per vertex (normal matrix applied and
// normalized per vertex, as the library compiles its meshes).
inline const char* const kMeshVertex = R"(
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
uniform mat4 u_model;
uniform mat3 u_normal_matrix;
uniform mat4 u_view_proj;
out vec3 v_world;
out vec3 v_normal;
invariant gl_Position;  // the same depth in the depth-only pass and the shading pass
void main() {
  vec4 w = u_model * vec4(a_position, 1.0);
  v_world = w.xyz;
  v_normal = normalize(u_normal_matrix * a_normal);
  gl_Position = u_view_proj * w;
}
)";

// The triangle's geometric normal, flat: the receiver plane of the shadow
// lookup (not the interpolated shading normal).
inline const char* const kMeshGeometry = R"(
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;
in vec3 v_world[];
in vec3 v_normal[];
out vec3 g_world;
out vec3 g_normal;
flat out vec3 g_plane;
invariant gl_Position;
void main() {
  vec3 n = cross(v_world[1] - v_world[0], v_world[2] - v_world[0]);
  float l = length(n);
  vec3 plane = l > 0.0 ? n / l : vec3(0.0);
  for (int i = 0; i < 3; ++i) {
    g_world = v_world[i];
    g_normal = v_normal[i];
    g_plane = plane;
    gl_Position = gl_in[i].gl_Position;
    EmitVertex();
  }
  EndPrimitive();
}
)";

// What every mesh fragment shader starts with: the geometry shader's
// outputs, and the distance along the camera ray `dir` to the opaque surface
// at pixel px (from the opaque pass's depth; far away where there is none).
inline const char* const kMeshFragmentCommon = R"(
in vec3 g_world;
in vec3 g_normal;
flat in vec3 g_plane;
float opaque_distance(sampler2D depth, ivec2 px, vec3 dir, vec3 forward, vec2 near_far) {
  float zd = texelFetch(depth, px, 0).r;
  if (zd >= 1.0) return 3.0e38;
  float n = near_far.x, f = near_far.y;  // window depth -> view-axis distance -> along the ray
  return 2.0 * f * n / ((f + n) - (zd * 2.0 - 1.0) * (f - n)) / dot(dir, forward);
}
)";

// Phong surfaces (thesis eq. 3.8) lit through the library's transmittance.
// Output 0 is the colour times coverage, output 1 what the surface passes
// of what lies behind it (dual-source blending: dst = src0 + dst * src1).
inline const char* const kSurfaceFragment = R"(
layout(location = 0, index = 0) out vec4 o_color;
layout(location = 0, index = 1) out vec4 o_pass;
uniform vec3 u_eye;
uniform vec3 u_ambient;
uniform vec3 u_color;
uniform vec4 u_tint;         // rgb replaces the colour with weight a (the editor's cluster view)
uniform float u_opacity;
uniform vec3 u_transmission;
uniform vec4 u_phong;        // ka, kd, ks, shininess
uniform uint u_object;       // ShadowSystem::gl_object_id: its own step in the maps (CDSM_NO_OBJECT: receive-only)
uniform bool u_has_normals;  // else the geometric normal shades
uniform bool u_shadows;      // false: every light unshadowed (to see what the maps do)
// A constant medium behind a front face: what it absorbs between this face
// and the nearer of the object's back face and the opaque surface there.
uniform bool u_medium;
uniform vec3 u_sigma;
uniform sampler2D u_back_distance;  // nearest back face of the object, distance from the eye
uniform sampler2D u_scene_depth;    // the opaque pass's depth
uniform vec3 u_forward;
uniform vec2 u_near_far;
void main() {
  vec3 dir = normalize(g_world - u_eye);
  vec3 n = u_has_normals ? g_normal : g_plane;
  n = normalize(n);
  if (dot(n, dir) > 0.0) n = -n;
  vec3 v = -dir;
  vec3 base = mix(u_color, u_tint.rgb, u_tint.a);
  vec3 c = base * u_ambient * u_phong.x;
  for (int i = 0; i < cdsm_light_count(); ++i) {
    float cone = cdsm_spot_factor(i, g_world);
    if (cone <= 0.0) continue;
    vec3 l = cdsm_direction_to_light(i, g_world);  // spot, point and directional lights
    if (dot(l, l) <= 0.0) continue;
    float ndl = dot(n, l);
    if (ndl <= 0.0) continue;
    vec3 vis = u_shadows ? cdsm_surface_transmittance(g_world, g_plane, u_object, i) : vec3(1.0);
    if (max(vis.r, max(vis.g, vis.b)) <= 0.0) continue;
    vec3 r = n * (2.0 * ndl) - l;
    float rv = max(0.0, dot(r, v));
    float spec = u_phong.z * (rv > 0.0 ? pow(rv, u_phong.w) : 0.0);
    c += (base * (u_phong.y * ndl) + vec3(spec)) * cdsm_light_radiance(i) * (vis * cone);
  }
  o_color = vec4(c * u_opacity, 1.0);
  vec3 pass = (1.0 - u_opacity) * u_transmission;
  if (u_medium) {
    ivec2 px = ivec2(gl_FragCoord.xy);
    float t_end = min(texelFetch(u_back_distance, px, 0).r, opaque_distance(u_scene_depth, px, dir, u_forward, u_near_far));
    pass *= exp(-u_sigma * max(t_end - length(g_world - u_eye), 0.0));
  }
  o_pass = vec4(pass, 1.0);
}
)";

// An object's back faces: their distance from the eye (blended with MIN).
inline const char* const kDistanceFragment = R"(
layout(location = 0) out float o_distance;
uniform vec3 u_eye;
void main() { o_distance = length(g_world - u_eye); }
)";

// Volumes: drawn on the back faces of their proxy box; each fragment
// marches its camera ray from where it enters the box to the back face or
// the opaque surface in front of it, with emission-absorption and single
// scattering (isotropic), the light's transmittance from cdsm.glsl at every
// sample.
inline const char* const kVolumeFragment = R"(
layout(location = 0, index = 0) out vec4 o_color;
layout(location = 0, index = 1) out vec4 o_pass;
uniform vec3 u_eye;
uniform vec3 u_ambient;
uniform mat4 u_world_to_index;  // world -> voxel index coordinates (centres at integers)
uniform mat4 u_world_to_box;    // world -> the proxy's object space
uniform vec3 u_box_lo, u_box_hi;
uniform vec3 u_grid_size;
uniform sampler3D u_density;     // trilinear, background outside
uniform sampler3D u_blocks;      // per 8^3 block: the largest value its samples can read
uniform ivec3 u_block_count;
uniform float u_empty_below;     // values below this have no extinction (the transfer function)
uniform int u_lookup_every;      // absorbing samples per shadow lookup (1: every sample)
#ifdef LIGHT_GRID  // the lights' transmittance from u_light_vis (kLightGridCompute)
uniform sampler3D u_light_vis[8];  // per light, over the density grid's box (trilinear)
#endif
uniform sampler2D u_scene_depth; // the opaque pass's depth
uniform vec3 u_forward;          // the camera's view axis
uniform vec2 u_near_far;
uniform float u_step;            // world units
uniform int u_points;
uniform float u_tf_density[16];
uniform vec3 u_tf_extinction[16];
uniform vec3 u_tf_color[16];
uniform bool u_shadows;

void transfer(float d, out vec3 sigma, out vec3 albedo) {
  if (d <= u_tf_density[0]) { sigma = u_tf_extinction[0]; albedo = u_tf_color[0]; return; }
  for (int i = 1; i < u_points; ++i) {
    if (d <= u_tf_density[i]) {
      float t = (d - u_tf_density[i - 1]) / max(u_tf_density[i] - u_tf_density[i - 1], 1e-30);
      sigma = mix(u_tf_extinction[i - 1], u_tf_extinction[i], t);
      albedo = mix(u_tf_color[i - 1], u_tf_color[i], t);
      return;
    }
  }
  sigma = u_tf_extinction[u_points - 1];
  albedo = u_tf_color[u_points - 1];
}

void main() {
  vec3 dir = normalize(g_world - u_eye);
  float t_exit = length(g_world - u_eye);
  // The opaque surface in front of the back face ends the march.
  t_exit = min(t_exit, opaque_distance(u_scene_depth, ivec2(gl_FragCoord.xy), dir, u_forward, u_near_far));
  // Entry: the ray against the proxy's box (slabs in its object space).
  vec3 o = (u_world_to_box * vec4(u_eye, 1.0)).xyz;
  vec3 d = (u_world_to_box * vec4(dir, 0.0)).xyz;
  vec3 inv = 1.0 / d;
  vec3 ta = (u_box_lo - o) * inv, tb = (u_box_hi - o) * inv;
  float t_enter = max(max(min(ta.x, tb.x), min(ta.y, tb.y)), min(ta.z, tb.z));
  t_enter = max(t_enter, 0.0);
  vec3 color = vec3(0.0), T = vec3(1.0);
  // The ray in index space (affine), for skipping blocks of 8^3 voxels whose
  // largest value (apron included) the transfer function maps to nothing.
  vec3 oi = (u_world_to_index * vec4(u_eye, 1.0)).xyz;
  vec3 di = (u_world_to_index * vec4(dir, 0.0)).xyz;
  float t = t_enter;
  vec3 vis_cache[8];
  int lookup_age = 1 << 20;
  for (int s = 0; s < 16384 && t < t_exit; ++s) {
    vec3 here = oi + di * t;
    ivec3 b = ivec3(floor(here / 8.0));
    if (all(greaterThanEqual(b, ivec3(0))) && all(lessThan(b, u_block_count)) &&
        texelFetch(u_blocks, b, 0).r < u_empty_below) {
      vec3 lo = vec3(b) * 8.0, hi = lo + 8.0;
      vec3 te = (mix(lo, hi, step(vec3(0.0), di)) - oi) / di;  // where the ray leaves the block, per axis
      t = max(min(te.x, min(te.y, te.z)) + 1e-3 * u_step, t + 1e-4 * u_step);
      continue;
    }
    float t0 = t, t1 = min(t + u_step, t_exit);
    t = t1;
    vec3 p = u_eye + dir * (0.5 * (t0 + t1));
    vec3 idx = (u_world_to_index * vec4(p, 1.0)).xyz;
    float dens = texture(u_density, (idx + 0.5) / u_grid_size).r;
    vec3 sigma, albedo;
    transfer(dens, sigma, albedo);
    vec3 a = vec3(1.0) - exp(-sigma * (t1 - t0));
    if (max(a.r, max(a.g, a.b)) <= 0.0) continue;
    // The lights' transmittance, looked up at every u_lookup_every-th
    // absorbing sample (it varies slowly inside a medium; the lookup is the
    // march's main cost).
#ifdef LIGHT_GRID
    vec3 uvw = (idx + 0.5) / u_grid_size;
    for (int i = 0; i < cdsm_light_count(); ++i)
      vis_cache[i] = u_shadows ? texture(u_light_vis[i], uvw).rgb : vec3(1.0);
#else
    if (lookup_age >= u_lookup_every) {
      for (int i = 0; i < cdsm_light_count(); ++i)
        vis_cache[i] = u_shadows ? cdsm_transmittance(p, i) : vec3(1.0);
      lookup_age = 0;
    }
    ++lookup_age;
#endif
    vec3 c = albedo * u_ambient;
    for (int i = 0; i < cdsm_light_count(); ++i) {
      float cone = cdsm_spot_factor(i, p);
      if (cone <= 0.0) continue;
      c += albedo * cdsm_light_radiance(i) * (vis_cache[i] * cone);
    }
    color += c * T * a;
    T *= vec3(1.0) - a;
    if (max(T.r, max(T.g, T.b)) < 0.005) break;
  }
  if (T == vec3(1.0)) discard;  // nothing absorbed: leave the pixel (and its stencil) alone
  o_color = vec4(color, 1.0);
  o_pass = vec4(T, 1.0);
}
)";

// The lights' transmittance over a volume (DrawOptions::volume_shadows =
// LightGrid): one cdsm_transmittance per texel of a grid over the density
// grid's box, texel centres where the march's texture coordinates put
// them, so the march samples it with the density's coordinates.
inline const char* const kLightGridCompute = R"(
layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;
layout(rgba32f, binding = 0) writeonly uniform image3D u_out;
uniform mat4 u_index_to_world;
uniform vec3 u_scale;  // density voxels per light-grid texel, per axis
uniform int u_light;
uniform sampler3D u_blocks;  // the march's 8^3 block maxima
uniform ivec3 u_block_count;
uniform float u_empty_below;
// Whether a march sample that reads this texel (trilinear: within one
// texel spacing) can absorb: some block around it holds extinction. Texels
// only empty space reads get no lookup (the march shades no sample there).
bool needed(vec3 idx) {
  for (int c = 0; c < 8; ++c) {
    vec3 corner = idx + vec3((c & 1) != 0 ? 1.0 : -1.0, (c & 2) != 0 ? 1.0 : -1.0, (c & 4) != 0 ? 1.0 : -1.0) * u_scale;
    ivec3 b = ivec3(floor(corner / 8.0));
    if (any(lessThan(b, ivec3(0))) || any(greaterThanEqual(b, u_block_count))) return true;  // outside: the background
    if (texelFetch(u_blocks, b, 0).r >= u_empty_below) return true;
  }
  return false;
}
void main() {
  ivec3 j = ivec3(gl_GlobalInvocationID);
  if (any(greaterThanEqual(j, imageSize(u_out)))) return;
  vec3 idx = (vec3(j) + 0.5) * u_scale - 0.5;
  vec3 p = (u_index_to_world * vec4(idx, 1.0)).xyz;
  imageStore(u_out, j, needed(idx) ? vec4(cdsm_transmittance(p, u_light), 1.0) : vec4(1.0));
}
)";

// Picking: the object's id + 1, the world position and the triangle's plane.
inline const char* const kPickFragment = R"(
layout(location = 0) out uint o_id;
layout(location = 1) out vec4 o_position;
layout(location = 2) out vec4 o_plane;
uniform uint u_id;
void main() {
  o_id = u_id;
  o_position = vec4(g_world, 1.0);
  o_plane = vec4(g_plane, 0.0);
}
)";

// One colour (the selection's outline).
inline const char* const kSolidFragment = R"(
layout(location = 0, index = 0) out vec4 o_color;
layout(location = 0, index = 1) out vec4 o_pass;
uniform vec4 u_solid;
void main() {
  o_color = vec4(u_solid.rgb, 1.0);
  o_pass = vec4(0.0);
}
)";

// Overlay lines: world positions with a colour each.
inline const char* const kLineVertex = R"(
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_color;
uniform mat4 u_view_proj;
out vec3 v_color;
void main() {
  v_color = a_color;
  gl_Position = u_view_proj * vec4(a_position, 1.0);
}
)";
inline const char* const kLineFragment = R"(
in vec3 v_color;
layout(location = 0, index = 0) out vec4 o_color;
layout(location = 0, index = 1) out vec4 o_pass;
void main() {
  o_color = vec4(v_color, 1.0);
  o_pass = vec4(0.0);
}
)";

// The frame for display: linear float to sRGB-encoded 8-bit (what a PNG of
// cdsm render holds), for windows that show the frame as a texture.
inline const char* const kDisplayCompute = R"(
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) readonly uniform image2D u_src;
layout(rgba8, binding = 1) writeonly uniform image2D u_dst;
float srgb(float c) {
  c = clamp(c, 0.0, 1.0);
  return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}
void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(p, imageSize(u_src)))) return;
  vec4 c = imageLoad(u_src, p);
  imageStore(u_dst, p, vec4(srgb(c.r), srgb(c.g), srgb(c.b), 1.0));
}
)";

}  // namespace forward
