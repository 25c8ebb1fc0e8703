// The forward renderer's resources: programs per node layout, the meshes'
// and grids' GL objects (uploaded once per identity), the volumes' light
// grids.
#define GL_GLEXT_PROTOTYPES 1
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "forward_internal.h"
#include "shaders.h"

namespace forward {

// The programs that look the maps up, compiled for the layout the map
// buffers hold (cdsm.glsl's shader variants): at the first draw, and again
// only when it changes.
void ForwardRenderer::use_layout(uint32_t layout) {
  if (layout == cdsm_layout_) return;
  for (GLuint p : {surface_program_, volume_programs_[0], volume_programs_[1], light_grid_program_}) glDeleteProgram(p);
  const int l = int(layout);
  surface_program_ = mesh_program(kSurfaceFragment, l);
  volume_programs_[0] = mesh_program(kVolumeFragment, l);
  volume_programs_[1] = mesh_program(std::string("#define LIGHT_GRID 1\n") + kVolumeFragment, l);
  light_grid_program_ = link({compile(GL_COMPUTE_SHADER, kLightGridCompute, l)});
  const GLint light_units[LightGrid::kLights] = {4, 5, 6, 7, 8, 9, 10, 11};
  glProgramUniform1iv(volume_programs_[1], glGetUniformLocation(volume_programs_[1], "u_light_vis[0]"),
                      LightGrid::kLights, light_units);
  cdsm_layout_ = layout;
}

ForwardRenderer::ForwardRenderer() {
  pick_program_ = mesh_program(kPickFragment, kNoCdsm);
  solid_program_ = mesh_program(kSolidFragment, kNoCdsm);
  distance_program_ = mesh_program(kDistanceFragment, kNoCdsm);
  display_program_ = link({compile(GL_COMPUTE_SHADER, kDisplayCompute, kNoCdsm)});
  line_program_ =
      link({compile(GL_VERTEX_SHADER, kLineVertex, kNoCdsm), compile(GL_FRAGMENT_SHADER, kLineFragment, kNoCdsm)});
  glCreateVertexArrays(1, &line_vao_);
  for (GLuint a = 0; a < 2; ++a) {
    glEnableVertexArrayAttrib(line_vao_, a);
    glVertexArrayAttribFormat(line_vao_, a, 3, GL_FLOAT, GL_FALSE, a * 12);
    glVertexArrayAttribBinding(line_vao_, a, 0);
  }
  check("programs");
}

ForwardRenderer::~ForwardRenderer() {
  meshes_.clear();
  grids_.clear();
  light_grids_.clear();
  for (GLuint p : {surface_program_, volume_programs_[0], volume_programs_[1], pick_program_, solid_program_,
                   line_program_, distance_program_, display_program_, light_grid_program_})
    glDeleteProgram(p);
  resize(0, 0);
  glDeleteVertexArrays(1, &line_vao_);
  glDeleteBuffers(1, &line_vbo_);
}

void ForwardRenderer::upload(const cdsm::Scene& scene, std::vector<std::string>* notes) {
  for (auto& [k, m] : meshes_) m->used = false;
  for (auto& [k, g] : grids_) g->used = false;
  for (const cdsm::Object& obj : scene.objects) {
    if (!obj.mesh) continue;
    auto [it, fresh] = meshes_.try_emplace(obj.mesh.get());
    if (fresh) {
      // The application's buffers: interleaved position + normal, 32-bit indices.
      auto m = std::make_unique<Mesh>();
      const cdsm::TriangleMesh& tm = *obj.mesh;
      m->keep = obj.mesh;
      m->has_normals = tm.normals.size() == tm.positions.size();
      std::vector<float> interleaved;
      interleaved.reserve(tm.positions.size() * 6);
      for (size_t i = 0; i < tm.positions.size(); ++i) {
        const cdsm::Vec3 p = tm.positions[i], n = m->has_normals ? tm.normals[i] : cdsm::Vec3{0, 0, 1};
        interleaved.insert(interleaved.end(), {p.x, p.y, p.z, n.x, n.y, n.z});
        m->box.grow(p);
      }
      glCreateBuffers(1, &m->vbo);
      glNamedBufferStorage(m->vbo, GLsizeiptr(std::max<size_t>(interleaved.size(), 6) * sizeof(float)),
                           interleaved.empty() ? nullptr : interleaved.data(), 0);
      glCreateBuffers(1, &m->ibo);
      glNamedBufferStorage(m->ibo, GLsizeiptr(std::max<size_t>(tm.indices.size(), 3) * 4),
                           tm.indices.empty() ? nullptr : tm.indices.data(), 0);
      glCreateVertexArrays(1, &m->vao);
      glVertexArrayVertexBuffer(m->vao, 0, m->vbo, 0, 24);
      glVertexArrayElementBuffer(m->vao, m->ibo);
      for (GLuint a = 0; a < 2; ++a) {
        glEnableVertexArrayAttrib(m->vao, a);
        glVertexArrayAttribFormat(m->vao, a, 3, GL_FLOAT, GL_FALSE, a * 12);
        glVertexArrayAttribBinding(m->vao, a, 0);
      }
      m->index_count = GLsizei(tm.indices.size());
      m->vertex_count = uint32_t(tm.positions.size());
      check("mesh upload");
      it->second = std::move(m);
    }
    it->second->used = true;
    if (obj.interior != cdsm::InteriorKind::Volume || obj.volume < 0 || size_t(obj.volume) >= scene.volumes.size())
      continue;
    const cdsm::Volume& v = scene.volumes[size_t(obj.volume)];
    if (!v.grid || v.shading != cdsm::VolumeShading::Scatter) {
      const std::string note = "volume '" + v.name +
                               "': " + (v.grid ? "Phong-shaded volumes" : "sparse (NanoVDB) grids") +
                               " are not drawn by this renderer (their shadows are)";
      if (notes && std::find(noted_.begin(), noted_.end(), note) == noted_.end()) notes->push_back(note);
      noted_.push_back(note);
      continue;
    }
    auto [git, gfresh] = grids_.try_emplace(v.grid.get());
    if (gfresh) {
      auto g = std::make_unique<Grid>();
      g->keep = v.grid;
      g->size = {float(v.grid->nx), float(v.grid->ny), float(v.grid->nz)};
      glCreateTextures(GL_TEXTURE_3D, 1, &g->texture);
      glTextureStorage3D(g->texture, 1, GL_R32F, v.grid->nx, v.grid->ny, v.grid->nz);
      glTextureSubImage3D(g->texture, 0, 0, 0, 0, v.grid->nx, v.grid->ny, v.grid->nz, GL_RED, GL_FLOAT,
                          v.grid->values.data());
      glTextureParameteri(g->texture, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
      glTextureParameteri(g->texture, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      for (GLenum w : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
        glTextureParameteri(g->texture, w, GL_CLAMP_TO_BORDER);
      const float border[4] = {v.grid->background, 0, 0, 0};
      glTextureParameterfv(g->texture, GL_TEXTURE_BORDER_COLOR, border);
      // Empty-space skipping: the largest value over each 8^3 block and its
      // one-voxel apron (trilinear reach), and the background (outside).
      const cdsm::DenseGrid& d = *v.grid;
      g->bx = (d.nx + 7) / 8;
      g->by = (d.ny + 7) / 8;
      g->bz = (d.nz + 7) / 8;
      std::vector<float> mx(size_t(g->bx) * g->by * g->bz, d.background);
      for (int k = 0; k < d.nz; ++k)
        for (int j = 0; j < d.ny; ++j)
          for (int i = 0; i < d.nx; ++i) {
            const float val = d.at(i, j, k);
            for (int c = 0; c < 8; ++c) {  // the blocks whose samples can reach this voxel
              const int bi = (i - (c & 1)) / 8, bj = (j - ((c >> 1) & 1)) / 8, bk = (k - (c >> 2)) / 8;
              if (i - (c & 1) < 0 || j - ((c >> 1) & 1) < 0 || k - (c >> 2) < 0) continue;
              float& m = mx[(size_t(bk) * g->by + bj) * g->bx + bi];
              m = std::max(m, val);
            }
          }
      glCreateTextures(GL_TEXTURE_3D, 1, &g->blocks);
      glTextureStorage3D(g->blocks, 1, GL_R32F, g->bx, g->by, g->bz);
      glTextureSubImage3D(g->blocks, 0, 0, 0, 0, g->bx, g->by, g->bz, GL_RED, GL_FLOAT, mx.data());
      check("volume texture");
      git->second = std::move(g);
    }
    git->second->used = true;
  }
  for (auto it = meshes_.begin(); it != meshes_.end();) it = it->second->used ? std::next(it) : meshes_.erase(it);
  for (auto it = grids_.begin(); it != grids_.end();) it = it->second->used ? std::next(it) : grids_.erase(it);
  for (auto it = light_grids_.begin(); it != light_grids_.end();) {
    const bool volume =
        it->first < scene.objects.size() && scene.objects[it->first].interior == cdsm::InteriorKind::Volume;
    it = volume ? std::next(it) : light_grids_.erase(it);
  }
}

double ForwardRenderer::prepare_light_grid(cdsm::ShadowSystem& system, size_t i, const cdsm::Scene& scene,
                                           const Grid& g, const DrawOptions& opt, int* computed) {
  const cdsm::Object& o = scene.objects[i];
  const cdsm::Volume& v = scene.volumes[size_t(o.volume)];
  const cdsm::Mat4 index_to_world = o.transform * v.index_to_object;
  const int lights = int(std::min<size_t>(scene.lights.size(), LightGrid::kLights));
  const int dims[3] = {v.grid->nx, v.grid->ny, v.grid->nz};
  int size[3];
  const int per = std::max(opt.light_grid_voxels, 1);
  for (int a = 0; a < 3; ++a) size[a] = std::clamp((dims[a] + per - 1) / per, 2, kMaxLightGrid);
  std::unique_ptr<LightGrid>& slot = light_grids_[i];
  if (!slot) slot = std::make_unique<LightGrid>();
  LightGrid& lg = *slot;
  const bool resized = !std::equal(size, size + 3, lg.size);
  const float empty = empty_below(v.transfer);  // which texels get lookups
  const bool stale = !lg.valid || resized || lg.grid != v.grid.get() || lg.version != opt.maps_version ||
                     lg.lights != lights || lg.empty_below != empty ||
                     std::memcmp(&lg.index_to_world, &index_to_world, sizeof index_to_world) != 0;
  double ms = 0.0;
  if (stale) {
    const auto t0 = Clock::now();
    if (resized) {
      glDeleteTextures(LightGrid::kLights, lg.tex);
      for (GLuint& t : lg.tex) t = 0;
      std::copy(size, size + 3, lg.size);
    }
    const GLuint p = light_grid_program_;
    glUseProgram(p);
    system.bind_gl(p);
    set_mat4(p, "u_index_to_world", index_to_world);
    glBindTextureUnit(3, g.blocks);
    glProgramUniform1i(p, glGetUniformLocation(p, "u_blocks"), 3);
    glProgramUniform3i(p, glGetUniformLocation(p, "u_block_count"), g.bx, g.by, g.bz);
    glProgramUniform1f(p, glGetUniformLocation(p, "u_empty_below"), empty);
    glProgramUniform3f(p, glGetUniformLocation(p, "u_scale"), float(dims[0]) / float(size[0]),
                       float(dims[1]) / float(size[1]), float(dims[2]) / float(size[2]));
    for (int l = 0; l < lights; ++l) {
      if (!lg.tex[l]) {
        glCreateTextures(GL_TEXTURE_3D, 1, &lg.tex[l]);
        glTextureStorage3D(lg.tex[l], 1, GL_RGBA32F, size[0], size[1], size[2]);
        glTextureParameteri(lg.tex[l], GL_TEXTURE_MIN_FILTER, GL_LINEAR);
        glTextureParameteri(lg.tex[l], GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        for (GLenum w : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
          glTextureParameteri(lg.tex[l], w, GL_CLAMP_TO_EDGE);
      }
      glBindImageTexture(0, lg.tex[l], 0, GL_TRUE, 0, GL_WRITE_ONLY, GL_RGBA32F);
      glProgramUniform1i(p, glGetUniformLocation(p, "u_light"), l);
      glDispatchCompute(GLuint((size[0] + 3) / 4), GLuint((size[1] + 3) / 4), GLuint((size[2] + 3) / 4));
    }
    glBindImageTexture(0, 0, 0, GL_TRUE, 0, GL_WRITE_ONLY, GL_RGBA32F);
    glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT);
    glFinish();  // (what the stats time)
    check("light grid");
    lg.grid = v.grid.get();
    lg.index_to_world = index_to_world;
    lg.version = opt.maps_version;
    lg.lights = lights;
    lg.empty_below = empty;
    lg.valid = true;
    *computed += lights;
    ms = ms_since(t0);
  }
  for (int l = 0; l < LightGrid::kLights; ++l) glBindTextureUnit(GLuint(4 + l), l < lights ? lg.tex[l] : 0);
  return ms;
}

cdsm::GlMeshSource ForwardRenderer::mesh_source(const cdsm::Scene& scene, size_t object) const {
  const Mesh& m = *meshes_.at(scene.objects.at(object).mesh.get());
  cdsm::GlMeshSource src;
  src.vertex_buffer = m.vbo;
  src.vertex_stride = 24;
  src.vertex_count = m.vertex_count;
  if (m.has_normals) {
    src.normal_buffer = m.vbo;
    src.normal_offset = 12;
    src.normal_stride = 24;
  }
  src.index_buffer = m.ibo;
  src.index_type = GL_UNSIGNED_INT;
  src.index_count = uint32_t(m.index_count);
  return src;
}

}  // namespace forward
