// An application's own forward renderer (OpenGL 4.5) that takes its
// translucent and volumetric shadows from cdsm only through the public API
// (cdsm/shadow_system.h, cdsm/gl.h) and cdsm.glsl (content/shaders/cdsm/):
//   - its meshes live in its own vertex / index buffers (mesh_source() hands
//     them to ShadowSystem::read_gl_mesh, which reads them back once);
//   - opaque meshes first (depth test and write), then translucent meshes
//     and volumes sorted back to front (dual-source blending: colour times
//     coverage, plus what lies behind times the surface's transmission), a
//     volume drawn by its own ray marcher over a 3D density texture;
//   - every shader that shades calls cdsm_surface_transmittance (surfaces,
//     with the triangle's plane from a geometry shader) or
//     cdsm_transmittance (volume samples) after ShadowSystem::bind_gl.
// The scene is read every frame (transforms, materials, lights, transfer
// functions: uniforms); meshes and grids are uploaded once per mesh / grid
// (by identity), so a live editor can draw the document it edits. Used by
// the example (cdsm_forward) and the editor's viewport (cdsm edit).
// Constant-medium interiors absorb between an object's front face and the
// nearer of its back face and the opaque surface behind (exact for convex
// objects). Limits (of this renderer, not of the library): sparse (NanoVDB)
// and Phong-shaded volumes are not drawn (upload() says so once).
#pragma once

#include <GL/glcorearb.h>

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "cdsm/cdsm.h"
#include "cdsm/gl.h"

namespace forward {

struct FrameTimes {
  double update_ms = 0.0;      // ShadowSystem::update (callers that update themselves leave it 0)
  double draw_ms = 0.0;        // the passes, to glFinish
  double light_grid_ms = 0.0;  // of draw_ms: the volumes' light grids recomputed (VolumeShadows::LightGrid)
  int light_grids = 0;         // grids (volume x light) recomputed this frame
  double total_ms = 0.0;
};

// A world-space line segment of an overlay (frusta, light gizmos).
struct Line {
  cdsm::Vec3 a, b, color;
};

enum class VolumeShadows { PerSample, LightGrid };
inline constexpr int kMaxLightGrid = 128;

struct DrawOptions {
  int width = 0, height = 0;       // the frame's size (0: the scene camera's)
  bool shadows = true;             // false: every light unshadowed (what the maps change)
  float volume_step_scale = 1.0f;  // > 1: coarser volume marching (the editor while interacting)
  int volume_lookup_every = 1;     // volume samples per shadow lookup (1: every sample, as cdsm render)
  // How volume samples get the lights' transmittance: a lookup in the maps
  // per sample (or per volume_lookup_every samples), or a trilinear fetch
  // from a grid per volume and light (a texel per light_grid_voxels density
  // voxels along each axis, at most kMaxLightGrid texels per axis) computed
  // with cdsm_transmittance when `maps_version` or the volume's placement
  // changed since it was.
  VolumeShadows volume_shadows = VolumeShadows::PerSample;
  int light_grid_voxels = 2;
  // LightGrid: the caller changes this whenever the maps or the lights
  // changed (an update() or publish() that built or uploaded anything).
  uint64_t maps_version = 0;
  // Per object (may be empty): a colour that replaces the surface colour
  // with weight w (the editor's cluster view); w = 0: none.
  std::vector<cdsm::Vec3> tint;
  std::vector<float> tint_weight;
  int selected = -1;        // drawn with an outline
  std::vector<Line> lines;  // drawn over the scene, depth-tested
};

// What a pixel shows (pick()).
struct Pick {
  int object = -1;      // -1: background
  cdsm::Vec3 position;  // the nearest surface's world position
  cdsm::Vec3 plane;     // its triangle's unit normal
};

class ForwardRenderer {
 public:
  // Compiles the programs on the current context.
  ForwardRenderer();
  ~ForwardRenderer();
  ForwardRenderer(const ForwardRenderer&) = delete;
  ForwardRenderer& operator=(const ForwardRenderer&) = delete;

  // Uploads the meshes and dense grids of `scene` not uploaded yet (by
  // identity) and releases those no object uses any more. Notes on what
  // it cannot draw go to `notes` (once per grid).
  void upload(const cdsm::Scene& scene, std::vector<std::string>* notes = nullptr);
  // The GL buffers holding object i's mesh, for ShadowSystem::read_gl_mesh.
  cdsm::GlMeshSource mesh_source(const cdsm::Scene& scene, size_t object) const;

  // One frame of `scene` seen by `camera` with the maps of `system`'s last
  // update / publish (bind_gl: the only call into the system, so it may run
  // while the system builds on another thread).
  FrameTimes draw(cdsm::ShadowSystem& system, const cdsm::Scene& scene, const cdsm::Camera& camera,
                  const DrawOptions& options);

  // The last frame, linear RGB, row 0 at the top (cdsm::Image's order).
  cdsm::Image read_color() const;
  // Per pixel: 1 where only opaque surfaces were drawn (no translucent
  // surface or volume in front), else 0. Row 0 at the top.
  std::vector<unsigned char> read_opaque_mask() const;
  // The colour texture of the last frame (linear float, bottom row first,
  // GL's order), and the same sRGB-encoded in 8 bits for display.
  GLuint color_texture() const { return color_; }
  GLuint display_texture() const { return display_; }
  int width() const { return width_; }
  int height() const { return height_; }
  // The object and surface point at pixel (x, y) (row 0 at the top) of the
  // last frame's view: one extra pass of object ids and positions.
  Pick pick(const cdsm::Scene& scene, const cdsm::Camera& camera, int x, int y);
  // Copies the last frame to the framebuffer that is bound (a window's).
  void present(int x, int y, int width, int height);

 private:
  struct Mesh;
  struct Grid;
  struct LightGrid;
  // Object i's light grids, recomputed when stale; binds them for the march.
  double prepare_light_grid(cdsm::ShadowSystem& system, size_t i, const cdsm::Scene& scene, const Grid& g,
                            const DrawOptions& opt, int* computed);
  void resize(int width, int height);
  // (Re)compiles the programs that include cdsm.glsl for the map buffers'
  // node layout (GlMapBuffers::layout) when it differs from theirs.
  void use_layout(uint32_t layout);
  void draw_object(size_t i, const cdsm::Object& o, GLuint program, const DrawOptions& opt, bool medium = false);

  std::map<const cdsm::TriangleMesh*, std::unique_ptr<Mesh>> meshes_;
  std::map<const cdsm::DenseGrid*, std::unique_ptr<Grid>> grids_;
  std::map<size_t, std::unique_ptr<LightGrid>> light_grids_;  // by object index
  GLuint light_grid_program_ = 0;
  std::vector<std::string> noted_;
  GLuint surface_program_ = 0, pick_program_ = 0, solid_program_ = 0, line_program_ = 0;
  // The volume march compiled twice: [0] a shadow lookup per sample, [1]
  // the light grids. Two programs, not a uniform branch: a GPU that runs
  // every branch under a mask (llvmpipe) would pay for the lookup code at
  // every sample even when the grid answers.
  GLuint volume_programs_[2] = {0, 0};
  uint32_t cdsm_layout_ = ~0u;  // the layout those programs, the surface's and the light grid's, read
  GLuint distance_program_ = 0, back_fbo_ = 0, back_distance_ = 0;
  GLuint display_program_ = 0, display_ = 0;
  GLuint fbo_ = 0, color_ = 0, depth_ = 0, depth_copy_fbo_ = 0, depth_copy_ = 0;
  GLuint pick_fbo_ = 0, pick_id_ = 0, pick_pos_ = 0, pick_plane_ = 0, pick_depth_ = 0;
  GLuint line_vao_ = 0, line_vbo_ = 0;
  uint64_t line_capacity_ = 0;
  int width_ = 0, height_ = 0;
};

}  // namespace forward
