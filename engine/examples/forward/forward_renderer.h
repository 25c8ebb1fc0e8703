// An application's own forward renderer (OpenGL 4.5) that takes its
// translucent and volumetric shadows from cdsm only through the public API
// (cdsm/shadow_system.h, cdsm/gl.h) and content/shaders/cdsm.glsl:
//   - its meshes live in its own vertex / index buffers; the shadow system
//     reads them back once when they are registered (read_gl_mesh);
//   - opaque meshes first (depth test and write), then translucent meshes
//     and volumes sorted back to front (dual-source blending: colour times
//     coverage, plus what lies behind times the surface's transmission), a
//     volume drawn by its own ray marcher over a 3D density texture;
//   - every shader that shades calls cdsm_surface_transmittance (surfaces,
//     with the triangle's plane from a geometry shader) or
//     cdsm_transmittance (volume samples) after ShadowSystem::bind_gl.
// Limits of the example (not of the library): constant-medium interiors are
// drawn as their translucent surface only, sparse (NanoVDB) volumes and
// Phong-shaded volumes are skipped with a note.
#pragma once

#include <GL/glcorearb.h>

#include <memory>
#include <string>
#include <vector>

#include "cdsm/cdsm.h"
#include "cdsm/gl.h"

namespace forward {

struct FrameTimes {
  double update_ms = 0.0;   // ShadowSystem::update (maps reused when nothing changed)
  double draw_ms = 0.0;     // the three passes, to glFinish
  double total_ms = 0.0;
};

class ForwardRenderer {
 public:
  // Uploads `scene` to GL buffers and textures of its own and registers it
  // with a shadow system created on the current context. Notes on what it
  // cannot draw go to `notes`.
  ForwardRenderer(const cdsm::Scene& scene, std::vector<std::string>& notes);
  ~ForwardRenderer();
  ForwardRenderer(const ForwardRenderer&) = delete;
  ForwardRenderer& operator=(const ForwardRenderer&) = delete;

  // One frame: the shadow system's update, then the passes. `shadows`
  // false draws every light unshadowed (what the maps change).
  FrameTimes render(bool shadows, cdsm::FrameStats* stats);

  // The last frame, linear RGB, row 0 at the top (cdsm::Image's order).
  cdsm::Image read_color() const;
  // Per pixel: 1 where only opaque surfaces were drawn (no translucent
  // surface or volume in front), else 0. Row 0 at the top.
  std::vector<unsigned char> read_opaque_mask() const;

  // Copies the last frame to the window's framebuffer (0).
  void present();

  cdsm::ShadowSystem& shadows() { return *system_; }

 private:
  struct Mesh;
  struct Volume;
  void draw_mesh(const Mesh& m, GLuint program, bool shadows);
  void draw_volume(const Volume& v, bool shadows);

  cdsm::Scene scene_;
  std::unique_ptr<cdsm::ShadowSystem> system_;
  std::vector<Mesh> meshes_;
  std::vector<Volume> volumes_;
  GLuint surface_program_ = 0, volume_program_ = 0;
  GLuint fbo_ = 0, color_ = 0, depth_ = 0, depth_copy_fbo_ = 0, depth_copy_ = 0;
  int width_ = 0, height_ = 0;
};

}  // namespace forward
