// The scene model of the public API: what an engine or a scene file
// describes. Plain data; the renderer compiles it into GPU-ready buffers.
// Units are world units (metres in the shipped scenes); angles in degrees.
#pragma once

#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "cdsm/math.h"
#include "cdsm/tags.h"

namespace cdsm {

// An indexed triangle mesh in object space. Counter-clockwise triangles
// (seen from outside) face outwards. `normals` are optional per-vertex
// shading normals (same count as positions).
struct TriangleMesh {
  std::vector<Vec3> positions;
  std::vector<uint32_t> indices;  // 3 per triangle
  std::vector<Vec3> normals;
  size_t triangle_count() const { return indices.size() / 3; }
};

// Surface appearance (thesis eq. 3.8 constants) and how much light the
// boundary passes, per colour channel k:
//
//   T_k = (1 - opacity) * transmission_color_k
//
// Physical reading: `opacity` is the coverage a of the surface, the part
// that reflects (shaded with `color`, composited with weight a); the rest,
// 1 - a, is a filter that passes transmission_color f (linear RGB, in
// [0, 1]). So opacity 1 is opaque whatever f; a white surface (f = 1) of
// opacity a passes 1 - a in every channel (grey: exactly the result before
// colours existed); a clear tinted glass is opacity 0 with f its tint, and
// passes f. A surface that passes everything (opacity 0, f white: a volume's
// proxy) is invisible to the camera, the maps and the reference; a tinted
// one of opacity 0 is not. glTF (the scene reader's gltf meshes):
// alphaMode BLEND gives the coverage a = baseColorFactor alpha (OPAQUE: 1);
// KHR_materials_transmission t makes a fraction t of the covered part pass,
// tinted by the base colour c: opacity = a (1 - t) and
// f = ((1 - a) + a t c) / (1 - a (1 - t)), which is the same light passed.
struct SurfaceMaterial {
  Vec3 color{0.8f, 0.8f, 0.8f};
  float opacity = 1.0f;  // coverage a: 1 = opaque, 0 = a pure filter (or, white, an invisible proxy)
  Vec3 transmission_color{1.0f, 1.0f, 1.0f};  // filter f of the uncovered part, linear RGB in [0, 1]
  float ambient = 0.15f;                      // k_a
  float diffuse = 0.85f;                      // k_d
  float specular = 0.25f;                     // k_s
  float shininess = 32.0f;                    // n_s
};

// A dense scalar grid, x fastest. Voxel (i,j,k) sits at index coordinates
// (i,j,k); trilinear filtering between voxel centres; outside the grid the
// value is `background`.
struct DenseGrid {
  int32_t nx = 0, ny = 0, nz = 0;
  std::vector<float> values;
  float background = 0.0f;
  float at(int i, int j, int k) const { return values[(size_t(k) * ny + j) * nx + i]; }
};

// One control point of a piecewise-linear transfer function.
struct TransferPoint {
  float density = 0.0f;      // input value of the grid
  Vec3 extinction{0, 0, 0};  // sigma_t per colour channel, per world unit (equal channels: grey)
  Vec3 color{1, 1, 1};       // albedo (scatter) or base colour (phong)
};

// A sparse float grid in NanoVDB's layout: the bytes of one
// nanovdb::NanoGrid<float> (position-independent, so the same bytes are
// sampled on the CPU and copied as is to a GPU). Made by load_vdb()
// (cdsm/loaders.h) from an OpenVDB grid. Index coordinates are the VDB's:
// voxel centres at integers, which may be negative. A value that is not
// stored reads as `background`. Every leaf holding a non-background value
// has its 26 neighbour leaves (empty-space skipping relies on it;
// load_vdb() adds them, the scene compile checks). The summary fields repeat
// what the bytes say, for code that does not include NanoVDB.
struct SparseGrid {
  struct alignas(32) Block {
    unsigned char bytes[32];
  };
  std::string name;                   // the grid's name in its file
  std::vector<Block> nanovdb;         // the NanoVDB grid, 32-byte aligned
  uint64_t nanovdb_bytes = 0;         // its size in bytes (<= 32 * nanovdb.size())
  int32_t active_min[3] = {0, 0, 0};  // inclusive index bounds of the active voxels
  int32_t active_max[3] = {-1, -1, -1};
  uint64_t active_voxels = 0;
  float background = 0.0f;
  float min_value = 0.0f, max_value = 0.0f;  // over the active voxels
  const void* data() const { return nanovdb.data(); }
};

// A volume: density grid + placement + transfer function.
struct Volume {
  std::string name;
  std::shared_ptr<const DenseGrid> grid;     // a dense grid (noise, dense, raw) ...
  std::shared_ptr<const SparseGrid> sparse;  // ... or a sparse one (vdb): exactly one is set
  Mat4 index_to_object;                      // voxel index coordinates -> object space
  std::vector<TransferPoint> transfer;       // sorted by density, at least 1 point
  VolumeShading shading = VolumeShading::Scatter;
  float step_voxels = 0.5f;     // march step, in voxels
  float gradient_scale = 1.0f;  // phong: normal from -grad(density)
  // How the grid was described: the JSON text of the scene file's `grid`
  // node as read, compact ({"type":"noise","seed":7,...}; a file found
  // beside the scene made absolute), so save_scene() (cdsm/scene_io.h)
  // writes the description again instead of the voxels. Empty for a grid
  // built in code or given by its values ({"type":"dense","values":...}):
  // a dense one is then written inline, its values. Code that gives the
  // volume another grid must clear it.
  std::string grid_source;
};

// A scene object: a closed (or open) triangle mesh with a surface and an interior.
struct Object {
  std::string name;
  std::shared_ptr<const TriangleMesh> mesh;
  Mat4 transform;  // object -> world
  bool casts_shadows = true;
  SurfaceMaterial surface;
  InteriorKind interior = InteriorKind::None;
  Vec3 sigma{0, 0, 0};  // Constant: extinction per colour channel, per world unit (Beer-Lambert;
                        // glTF KHR_materials_volume: -ln(attenuationColor_k) / attenuationDistance)
  int32_t volume = -1;  // Volume: index into Scene::volumes
  // How the mesh was described: the JSON text of the scene file's `mesh`
  // node as read, compact ({"type":"teapot","subdivisions":8}; a file found
  // beside the scene made absolute; {"type":"volume_box"} for a volume's
  // object without one), so save_scene() writes the description again
  // instead of the triangles. Empty for a mesh built in code, taken from a
  // whole glTF scene or given by its data (all written inline,
  // {"type":"triangles",...}). Code that gives the object another mesh
  // must clear it.
  std::string mesh_source;
};

// A spot, point or directional light. A directional light (the sun) has no
// position: it shines along `direction` from infinitely far away, its
// shadows in orthographic maps over the casters.
struct Light {
  std::string name;
  LightType type = LightType::Spot;
  Vec3 position{0, 5, 0};        // spot, point (directional: unused)
  Vec3 direction{0, -1, 0};      // spot: cone axis; directional: the way the light travels
  float outer_cone_deg = 30.0f;  // spot: half-angle where light ends
  float inner_cone_deg = 25.0f;  // spot: half-angle of full intensity
  Vec3 color{1, 1, 1};
  float intensity = 1.0f;
  // The light's size, for soft shadows: a spot or point light is a sphere of
  // `radius` (0: a point), a directional light a disk of apparent size
  // `angular_diameter_deg` (the sun: 0.53; 0: a point at infinity). The
  // reference renderer samples that area; the maps' lookups estimate the
  // penumbra from the maps' blockers (ShadowSettings::penumbra).
  float radius = 0.0f;
  float angular_diameter_deg = 0.0f;
};

// Clip-space depth of a projection matrix: OpenGL's [-1, 1] (glm's default)
// or [0, 1] (Direct3D, Vulkan, glm with GLM_FORCE_DEPTH_ZERO_TO_ONE).
// Reversed depth (near at the top of the range) is read from the matrix.
enum class ClipDepth : uint32_t { MinusOneToOne, ZeroToOne };

// The camera the shadows are built for: where it is, where it looks, its
// symmetric perspective and its image size. Maps are clustered and focused
// on what it sees; render() shades its view.
struct Camera {
  Vec3 position{0, 2, 6};
  Vec3 target{0, 0.5f, 0};
  Vec3 up{0, 1, 0};
  float fov_y_deg = 45.0f;
  float near = 0.05f;
  float far = 200.0f;
  int32_t width = 720;
  int32_t height = 480;

  // The camera of an engine's own matrices (row-major cdsm::Mat4: m[row][col];
  // transpose a column-major glm::mat4): `view` world -> eye, a rigid motion
  // with the eye looking down -Z and +Y up (OpenGL's convention);
  // `projection` a symmetric perspective with clip depth `depth`, normal or
  // reversed, finite or infinite far plane (far is then kMaxFar). Throws
  // cdsm::Error naming what does not fit (a scaled or sheared view, an
  // off-centre or orthographic projection, an aspect ratio other than
  // width / height beyond 0.1%).
  static Camera from_matrices(const Mat4& view, const Mat4& projection, int32_t width, int32_t height,
                              ClipDepth depth = ClipDepth::MinusOneToOne);
  // The same from column-major float[16] arrays, as an engine holds them:
  // glm::value_ptr(m), GL's glUniformMatrix4fv with transpose GL_FALSE
  // (element [col * 4 + row]). Throws cdsm::Error on a null pointer.
  static Camera from_matrices(const float* view_column_major, const float* projection_column_major, int32_t width,
                              int32_t height, ClipDepth depth = ClipDepth::MinusOneToOne);
  // This camera as matrices (OpenGL's conventions, row-major): world -> eye,
  // and eye -> clip with clip depth `depth`.
  Mat4 view_matrix() const;
  Mat4 projection_matrix(ClipDepth depth = ClipDepth::MinusOneToOne) const;
  // Far planes beyond this are taken as this (an infinite projection).
  static constexpr float kMaxFar = 1e7f;
};

// ShadowSettings::resolution (and the scene file's "resolution": "auto"):
// each map's resolution chosen from the screen.
inline constexpr int32_t kAutoResolution = 0;
// ShadowSettings::max_clusters (the scene file's "clusters": "auto"): each
// light's cluster count chosen from the screen.
inline constexpr int32_t kAutoClusters = 0;

struct ShadowSettings {
  float epsilon = 0.01f;     // compression error bound of the visibility functions
  int32_t resolution = 512;  // DSM texels per side; kAutoResolution: per map, from the screen
  // Auto resolution (resolution == kAutoResolution): each map sized so that
  // about this many texels cross one image pixel where the camera sees its
  // receivers (the median over them), on a ladder of powers of 2^(1/2) up
  // to max_resolution, a rung kept until the wanted one is 3/4 of a step away.
  // 2 by default: at 1 the bilinear taps spread a shadow's edge over about
  // two pixels, and five of the ten shipped scenes stay under 42 dB against
  // the reference at their own size (the project's benchmark report).
  float texels_per_pixel = 2.0f;
  int32_t max_resolution = 2048;
  bool filtering = true;  // bilinear lookup (thesis eq. 4.18-4.19)
  // Casters' own surfaces: each lookup tap stops this far short of the
  // surface's plane along its ray (hd/lights.h Receiver): world units, plus
  // bias_slope texel footprints, plus 2e-5 of the depth. Receive-only
  // surfaces and volume samples take no offset.
  float bias_constant = 0.0002f;
  float bias_slope = 0.05f;
  ReceiverLookup receiver = ReceiverLookup::Plane;
  // Lights with a size: penumbrae estimated from the maps' blockers (the
  // default), a fixed-kernel PCF (baseline), or hard shadows.
  Penumbra penumbra = Penumbra::Estimated;
  // Lights with a size: filter taps across a penumbra's longer axis (a
  // lattice a texel apart, or this many across a wider penumbra): the
  // filter costs about its square of bilinear taps per map; fewer is
  // cheaper and wide penumbrae step more (below 5 too much: refused).
  int32_t penumbra_taps = 11;
  int32_t max_clusters = 1;  // m; kAutoClusters: per light, from the screen
  // Auto clusters (max_clusters == kAutoClusters): each light gets the
  // fewest clusters (1, 2, 4, ... up to cluster_limit) at which every map
  // its receivers see reaches their density (texels_per_pixel) within its
  // size (max_resolution with auto resolution, else resolution) — with auto
  // resolution more, where twice the maps need less than half the texels;
  // where no count reaches it, the fewest within a ladder step of the best.
  // A count is kept until another is clearly better (auto_resolution.h
  // pick_cluster_count).
  int32_t cluster_limit = 8;
  // Baseline arrangement: > 1 replaces a spot light's map (and any clusters)
  // by that many parallel-split maps along the camera's view (Zhang et al.
  // 2006, the cascades clustering competes with); 0 = off.
  int32_t parallel_splits = 0;
  float d0 = 0.25f;  // clustering threshold, normalized map units
  DsmLayout layout = DsmLayout::Packed;
  int32_t fixed_layers = 32;  // fixed layout: L, node slots per texel (thesis §4.2.1)
  int32_t chunk_nodes = 64;   // chunked layout: node slots per chunk (thesis §4.2.2)
  ShadowMethod method = ShadowMethod::Dsm;
  float method_param = 0.0f;     // ShadowMap: opacity threshold; slices / nodes / layers / coefficients / moments count
  float layer_thickness = 0.0f;  // deep opacity maps: world units along the ray (0: the casters' depth extent / N)
  Vec3 ambient_light{1, 1, 1};   // i_a
  // Maps whose casters include a coloured one (a tinted surface, a medium or
  // volume whose extinction differs between channels) store RGB nodes;
  // false keeps every map scalar, coloured casters entering by their channel
  // mean (the benchmark's cost comparison). Grey maps are scalar either way.
  bool rgb_maps = true;
  // Memory a frame may use, MiB: scenes and settings estimated to need more
  // are refused before anything is allocated. 0: half the physical memory.
  int64_t max_memory_mib = 0;

  bool auto_resolution() const { return resolution == kAutoResolution; }
  bool auto_clusters() const { return max_clusters == kAutoClusters; }
  // Whether lights' maps are clustered (m > 1, or auto).
  bool clustering() const { return auto_clusters() || max_clusters > 1; }
  // The resolution maps are planned at (auto: the ladder's start, 512 or its top).
  int32_t planned_resolution() const { return auto_resolution() ? std::min(512, max_resolution) : resolution; }
};

struct Scene {
  std::string source;  // file it came from, for messages
  std::vector<Object> objects;
  std::vector<Volume> volumes;
  std::vector<Light> lights;
  Camera camera;
  ShadowSettings shadows;
  Vec3 background{0.05f, 0.06f, 0.08f};
};

// Whether every edge of the mesh is shared by exactly two triangles with
// opposite orientation (a closed, consistently wound surface), after
// welding vertices at identical positions.
bool is_closed(const TriangleMesh& mesh);

// Bounding box of a mesh under a transform.
Box3 world_bounds(const TriangleMesh& mesh, const Mat4& transform);

// Build transforms: T * R * S with R from Euler angles in degrees (XYZ order).
Mat4 make_transform(Vec3 translate, Vec3 rotate_deg, Vec3 scale);

}  // namespace cdsm
