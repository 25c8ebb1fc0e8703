// The forward renderer's own pieces shared by its files (forward_renderer.h
// is the interface): GL helpers, and the GL objects it keeps per mesh,
// grid and volume.
#pragma once

#include <chrono>
#include <initializer_list>
#include <memory>
#include <string>
#include <vector>

#include "forward_renderer.h"

namespace forward {

using Clock = std::chrono::steady_clock;
inline double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// Throws naming `what` when GL has an error pending.
void check(const char* what);
// A shader stage; with cdsm.glsl's lookups compiled for node layout
// `cdsm_layout` (GlMapBuffers::layout) when that is not kNoCdsm.
constexpr int kNoCdsm = -1;
GLuint compile(GLenum stage, const std::string& body, int cdsm_layout);
GLuint link(std::initializer_list<GLuint> shaders);
// The vertex and geometry stages every mesh program shares, and `fragment`.
GLuint mesh_program(const std::string& fragment, int cdsm_layout);
// cdsm::Mat4 is row-major: GL takes it with transpose = GL_TRUE.
void set_mat4(GLuint p, const char* name, const cdsm::Mat4& m);
void set_vec3(GLuint p, const char* name, cdsm::Vec3 v);
cdsm::Mat4 inverse(const cdsm::Mat4& m);
// The camera as GL sees it (OpenGL's clip depth).
cdsm::Mat4 view_projection(const cdsm::Camera& c);
// A surface that passes all light (drawn for its medium only).
bool passes_all(const cdsm::SurfaceMaterial& s);
// The largest density below which the transfer function has no extinction
// (-inf when even the lowest has some).
float empty_below(const std::vector<cdsm::TransferPoint>& tf);

struct ForwardRenderer::Mesh {
  std::shared_ptr<const cdsm::TriangleMesh> keep;  // identity: kept alive while uploaded
  GLuint vao = 0, vbo = 0, ibo = 0;
  GLsizei index_count = 0;
  uint32_t vertex_count = 0;
  bool has_normals = false;
  cdsm::Box3 box;  // object space
  bool used = false;
  ~Mesh() {
    glDeleteVertexArrays(1, &vao);
    glDeleteBuffers(1, &vbo);
    glDeleteBuffers(1, &ibo);
  }
};

struct ForwardRenderer::Grid {
  std::shared_ptr<const cdsm::DenseGrid> keep;
  GLuint texture = 0;
  GLuint blocks = 0;  // per 8^3 block the largest value a sample in it can read (apron of one voxel)
  int bx = 0, by = 0, bz = 0;
  cdsm::Vec3 size;
  bool used = false;
  ~Grid() {
    glDeleteTextures(1, &texture);
    glDeleteTextures(1, &blocks);
  }
};

// A volume object's light grids: one RGBA32F 3D texture per light.
struct ForwardRenderer::LightGrid {
  static constexpr int kLights = 8;  // u_light_vis[8] in the march
  const cdsm::DenseGrid* grid = nullptr;
  cdsm::Mat4 index_to_world;
  uint64_t version = 0;
  int lights = 0;
  float empty_below = 0.0f;
  bool valid = false;
  int size[3] = {0, 0, 0};
  GLuint tex[kLights] = {};
  ~LightGrid() { glDeleteTextures(kLights, tex); }
};

}  // namespace forward
