#define GL_GLEXT_PROTOTYPES 1
#include "forward_renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "shaders.h"

namespace forward {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

void check(const char* what) {
  if (GLenum e = glGetError(); e != GL_NO_ERROR) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "%s: GL error 0x%04x", what, e);
    throw std::runtime_error(buf);
  }
}

// A shader stage; with cdsm.glsl's lookups compiled for node layout
// `cdsm_layout` (GlMapBuffers::layout) when that is not kNoCdsm.
constexpr int kNoCdsm = -1;
GLuint compile(GLenum stage, const std::string& body, int cdsm_layout) {
  std::string src = "#version 450\n";
  if (cdsm_layout != kNoCdsm) src += "#define CDSM_LAYOUT " + std::to_string(cdsm_layout) + "\n" + cdsm::glsl_include();
  src += body;
  GLuint sh = glCreateShader(stage);
  const char* text = src.c_str();
  glShaderSource(sh, 1, &text, nullptr);
  glCompileShader(sh);
  GLint ok = 0;
  glGetShaderiv(sh, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[4096];
    glGetShaderInfoLog(sh, sizeof log, nullptr, log);
    throw std::runtime_error(std::string("shader compile failed: ") + log);
  }
  return sh;
}

GLuint link(std::initializer_list<GLuint> shaders) {
  GLuint p = glCreateProgram();
  for (GLuint s : shaders) glAttachShader(p, s);
  glLinkProgram(p);
  for (GLuint s : shaders) glDeleteShader(s);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[4096];
    glGetProgramInfoLog(p, sizeof log, nullptr, log);
    throw std::runtime_error(std::string("program link failed: ") + log);
  }
  return p;
}

// cdsm::Mat4 is row-major: GL takes it with transpose = GL_TRUE.
void set_mat4(GLuint p, const char* name, const cdsm::Mat4& m) {
  glProgramUniformMatrix4fv(p, glGetUniformLocation(p, name), 1, GL_TRUE, &m.m[0][0]);
}
void set_vec3(GLuint p, const char* name, cdsm::Vec3 v) {
  glProgramUniform3f(p, glGetUniformLocation(p, name), v.x, v.y, v.z);
}

cdsm::Mat4 inverse(const cdsm::Mat4& m) {
  cdsm::Mat4 inv;
  if (!cdsm::invert_affine(m, inv)) throw std::runtime_error("a transform has no inverse");
  return inv;
}

// The camera as GL sees it (OpenGL's clip depth).
cdsm::Mat4 view_projection(const cdsm::Camera& c) { return c.projection_matrix() * c.view_matrix(); }

bool passes_all(const cdsm::SurfaceMaterial& s) {
  return s.opacity <= 0.0f && s.transmission_color.x >= 1.0f && s.transmission_color.y >= 1.0f &&
         s.transmission_color.z >= 1.0f;
}

}  // namespace

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

namespace {
// The largest density below which the transfer function has no extinction
// (-inf when even the lowest has some).
float empty_below(const std::vector<cdsm::TransferPoint>& tf) {
  if (tf.empty() || cdsm::max_channel(tf[0].extinction) > 0.0f) return -3.0e38f;
  for (size_t k = 1; k < tf.size(); ++k)
    if (cdsm::max_channel(tf[k].extinction) > 0.0f) return tf[k - 1].density;
  return 3.0e38f;  // none anywhere
}

// The vertex and geometry stages every mesh program shares, and `fragment`.
GLuint mesh_program(const std::string& fragment, int cdsm_layout) {
  return link({compile(GL_VERTEX_SHADER, kMeshVertex, kNoCdsm), compile(GL_GEOMETRY_SHADER, kMeshGeometry, kNoCdsm),
               compile(GL_FRAGMENT_SHADER, std::string(kMeshFragmentCommon) + fragment, cdsm_layout)});
}
}  // namespace

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

void ForwardRenderer::resize(int width, int height) {
  if (width == width_ && height == height_) return;
  GLuint fbos[4] = {fbo_, depth_copy_fbo_, pick_fbo_, back_fbo_};
  glDeleteFramebuffers(4, fbos);
  GLuint texs[9] = {color_,      depth_,      depth_copy_,    pick_id_, pick_pos_,
                    pick_plane_, pick_depth_, back_distance_, display_};
  glDeleteTextures(9, texs);
  display_ = 0;
  fbo_ = depth_copy_fbo_ = pick_fbo_ = back_fbo_ = color_ = depth_ = depth_copy_ = pick_id_ = pick_pos_ = pick_depth_ =
      0;
  pick_plane_ = back_distance_ = 0;
  width_ = width;
  height_ = height;
  if (width <= 0 || height <= 0) return;
  // The frame: linear float colour, depth + stencil (the stencil marks what
  // the translucent passes covered), and a copy of the opaque depth the ray
  // marcher reads (sampling the attached one would be a feedback loop).
  auto texture = [&](GLenum format) {
    GLuint t;
    glCreateTextures(GL_TEXTURE_2D, 1, &t);
    glTextureStorage2D(t, 1, format, width, height);
    glTextureParameteri(t, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(t, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    return t;
  };
  color_ = texture(GL_RGBA32F);
  glTextureParameteri(color_, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTextureParameteri(color_, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  depth_ = texture(GL_DEPTH24_STENCIL8);
  depth_copy_ = texture(GL_DEPTH24_STENCIL8);
  display_ = texture(GL_RGBA8);
  glCreateFramebuffers(1, &fbo_);
  glNamedFramebufferTexture(fbo_, GL_COLOR_ATTACHMENT0, color_, 0);
  glNamedFramebufferTexture(fbo_, GL_DEPTH_STENCIL_ATTACHMENT, depth_, 0);
  glCreateFramebuffers(1, &depth_copy_fbo_);
  glNamedFramebufferTexture(depth_copy_fbo_, GL_DEPTH_STENCIL_ATTACHMENT, depth_copy_, 0);
  // Constant media: the nearest back face of one object at a time.
  back_distance_ = texture(GL_R32F);
  glCreateFramebuffers(1, &back_fbo_);
  glNamedFramebufferTexture(back_fbo_, GL_COLOR_ATTACHMENT0, back_distance_, 0);
  // Picking: ids, positions, planes.
  pick_id_ = texture(GL_R32UI);
  pick_pos_ = texture(GL_RGBA32F);
  pick_plane_ = texture(GL_RGBA32F);
  pick_depth_ = texture(GL_DEPTH_COMPONENT32F);
  glCreateFramebuffers(1, &pick_fbo_);
  glNamedFramebufferTexture(pick_fbo_, GL_COLOR_ATTACHMENT0, pick_id_, 0);
  glNamedFramebufferTexture(pick_fbo_, GL_COLOR_ATTACHMENT1, pick_pos_, 0);
  glNamedFramebufferTexture(pick_fbo_, GL_COLOR_ATTACHMENT2, pick_plane_, 0);
  glNamedFramebufferTexture(pick_fbo_, GL_DEPTH_ATTACHMENT, pick_depth_, 0);
  const GLenum bufs[3] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};
  glNamedFramebufferDrawBuffers(pick_fbo_, 3, bufs);
  if (glCheckNamedFramebufferStatus(fbo_, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE ||
      glCheckNamedFramebufferStatus(pick_fbo_, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw std::runtime_error("the frame's framebuffers are incomplete");
  check("framebuffers");
}

void ForwardRenderer::draw_object(size_t i, const cdsm::Object& o, GLuint p, const DrawOptions& opt, bool medium) {
  const Mesh& m = *meshes_.at(o.mesh.get());
  set_mat4(p, "u_model", o.transform);
  const cdsm::Mat4 nm = cdsm::transpose(inverse(o.transform));
  float n3[9];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) n3[c * 3 + r] = nm.m[r][c];  // column-major
  glProgramUniformMatrix3fv(p, glGetUniformLocation(p, "u_normal_matrix"), 1, GL_FALSE, n3);
  const cdsm::SurfaceMaterial& s = o.surface;
  set_vec3(p, "u_color", s.color);
  const float w = i < opt.tint_weight.size() ? opt.tint_weight[i] : 0.0f;
  const cdsm::Vec3 t = i < opt.tint.size() ? opt.tint[i] : cdsm::Vec3{};
  glProgramUniform4f(p, glGetUniformLocation(p, "u_tint"), t.x, t.y, t.z, w);
  glProgramUniform1f(p, glGetUniformLocation(p, "u_opacity"), s.opacity);
  set_vec3(p, "u_transmission", s.transmission_color);
  glProgramUniform4f(p, glGetUniformLocation(p, "u_phong"), s.ambient, s.diffuse, s.specular, s.shininess);
  glProgramUniform1ui(p, glGetUniformLocation(p, "u_object"), o.casts_shadows ? GLuint(i) : 0xffffffffu);
  glProgramUniform1i(p, glGetUniformLocation(p, "u_has_normals"), m.has_normals);
  glProgramUniform1i(p, glGetUniformLocation(p, "u_shadows"), opt.shadows);
  glProgramUniform1ui(p, glGetUniformLocation(p, "u_id"), GLuint(i + 1));
  glProgramUniform1i(p, glGetUniformLocation(p, "u_medium"), medium);
  glFrontFace(cdsm::mirrors(o.transform) ? GL_CW : GL_CCW);
  glBindVertexArray(m.vao);
  glDrawElements(GL_TRIANGLES, m.index_count, GL_UNSIGNED_INT, nullptr);
}

FrameTimes ForwardRenderer::draw(cdsm::ShadowSystem& system, const cdsm::Scene& scene, const cdsm::Camera& camera_in,
                                 const DrawOptions& opt) {
  FrameTimes t;
  const auto t0 = Clock::now();
  cdsm::Camera cam = camera_in;
  if (opt.width > 0) cam.width = opt.width;
  if (opt.height > 0) cam.height = opt.height;
  resize(cam.width, cam.height);
  use_layout(uint32_t(system.gl_buffers().layout));
  const cdsm::Mat4 vp = view_projection(cam);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glViewport(0, 0, width_, height_);
  const float bg[4] = {scene.background.x, scene.background.y, scene.background.z, 1.0f};
  glClearNamedFramebufferfv(fbo_, GL_COLOR, 0, bg);
  glClearNamedFramebufferfi(fbo_, GL_DEPTH_STENCIL, 0, 1.0f, 0);
  for (GLuint p : {surface_program_, volume_programs_[0], volume_programs_[1], solid_program_, line_program_}) {
    set_mat4(p, "u_view_proj", vp);
    set_vec3(p, "u_eye", cam.position);
    set_vec3(p, "u_ambient", scene.shadows.ambient_light);
  }
  // A surface that passes all light is not drawn, unless it bounds a
  // constant medium (drawn with opacity 0: the medium's absorption only).
  auto visible = [&](const cdsm::Object& o) {
    const bool medium = o.interior == cdsm::InteriorKind::Constant && cdsm::max_channel(o.sigma) > 0.0f;
    return o.mesh && meshes_.count(o.mesh.get()) && (!passes_all(o.surface) || medium);
  };
  auto drawn_volume = [&](const cdsm::Object& o) -> const Grid* {
    if (o.interior != cdsm::InteriorKind::Volume || o.volume < 0 || size_t(o.volume) >= scene.volumes.size())
      return nullptr;
    const cdsm::Volume& v = scene.volumes[size_t(o.volume)];
    if (!v.grid || v.shading != cdsm::VolumeShading::Scatter || !o.mesh || !meshes_.count(o.mesh.get())) return nullptr;
    auto it = grids_.find(v.grid.get());
    return it == grids_.end() ? nullptr : it->second.get();
  };

  // 1. Opaque surfaces: a depth-only pass, then shading where the depth is
  //    equal (each pixel shaded once, whatever the draw order); stencil 1
  //    where drawn.
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
  glUseProgram(solid_program_);
  for (size_t i = 0; i < scene.objects.size(); ++i)
    if (visible(scene.objects[i]) && scene.objects[i].surface.opacity >= 1.0f)
      draw_object(i, scene.objects[i], solid_program_, opt);
  glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  glDepthFunc(GL_EQUAL);
  glDepthMask(GL_FALSE);
  glUseProgram(surface_program_);
  system.bind_gl(surface_program_);
  glEnable(GL_STENCIL_TEST);
  glStencilFunc(GL_ALWAYS, 1, 0xff);
  glStencilOp(GL_KEEP, GL_KEEP, GL_REPLACE);
  for (size_t i = 0; i < scene.objects.size(); ++i)
    if (visible(scene.objects[i]) && scene.objects[i].surface.opacity >= 1.0f)
      draw_object(i, scene.objects[i], surface_program_, opt);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);

  glBlitNamedFramebuffer(fbo_, depth_copy_fbo_, 0, 0, width_, height_, 0, 0, width_, height_,
                         GL_DEPTH_BUFFER_BIT | GL_STENCIL_BUFFER_BIT, GL_NEAREST);

  // 2. Translucent surfaces and volumes, back to front (object centres):
  //    dst = src0 + dst * src1, no depth writes; stencil 2 where drawn.
  std::vector<std::pair<float, size_t>> order;
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    const cdsm::Object& o = scene.objects[i];
    if (drawn_volume(o) || (visible(o) && o.surface.opacity < 1.0f)) {
      const cdsm::Vec3 c = o.transform.point(meshes_.at(o.mesh.get())->box.center());
      order.push_back({cdsm::length(c - cam.position), i});
    }
  }
  std::sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  glEnable(GL_BLEND);
  glBlendFuncSeparate(GL_ONE, GL_SRC1_COLOR, GL_ZERO, GL_ONE);
  glDepthMask(GL_FALSE);
  glStencilFunc(GL_ALWAYS, 2, 0xff);
  glEnable(GL_CULL_FACE);
  const cdsm::Vec3 forward = cdsm::normalize(cam.target - cam.position);
  glBindTextureUnit(1, depth_copy_);
  for (GLuint p : volume_programs_) {
    set_vec3(p, "u_forward", forward);
    glProgramUniform2f(p, glGetUniformLocation(p, "u_near_far"), cam.near, cam.far);
    glProgramUniform1i(p, glGetUniformLocation(p, "u_scene_depth"), 1);
    glProgramUniform1i(p, glGetUniformLocation(p, "u_density"), 0);
  }
  for (const auto& [dist, i] : order) {
    const cdsm::Object& o = scene.objects[i];
    if (const Grid* g = drawn_volume(o)) {
      const cdsm::Volume& v = scene.volumes[size_t(o.volume)];
      const bool grid_shadows = opt.volume_shadows == VolumeShadows::LightGrid && opt.shadows;
      if (grid_shadows) t.light_grid_ms += prepare_light_grid(system, i, scene, *g, opt, &t.light_grids);
      const GLuint p = volume_programs_[grid_shadows ? 1 : 0];
      glUseProgram(p);
      system.bind_gl(p);
      const cdsm::Mat4 index_to_world = o.transform * v.index_to_object;
      set_mat4(p, "u_world_to_index", inverse(index_to_world));
      set_mat4(p, "u_world_to_box", inverse(o.transform));
      const cdsm::Box3& box = meshes_.at(o.mesh.get())->box;
      set_vec3(p, "u_box_lo", box.lo);
      set_vec3(p, "u_box_hi", box.hi);
      set_vec3(p, "u_grid_size", g->size);
      float voxel = 1e30f;
      for (int c = 0; c < 3; ++c)
        voxel = std::min(voxel, cdsm::length({index_to_world.m[0][c], index_to_world.m[1][c], index_to_world.m[2][c]}));
      glProgramUniform1f(p, glGetUniformLocation(p, "u_step"),
                         v.step_voxels * voxel * std::max(opt.volume_step_scale, 1.0f));
      const int n = int(std::min<size_t>(v.transfer.size(), 16));
      glProgramUniform1i(p, glGetUniformLocation(p, "u_points"), n);
      for (int k = 0; k < n; ++k) {
        const std::string idx = "[" + std::to_string(k) + "]";
        glProgramUniform1f(p, glGetUniformLocation(p, ("u_tf_density" + idx).c_str()), v.transfer[size_t(k)].density);
        set_vec3(p, ("u_tf_extinction" + idx).c_str(), v.transfer[size_t(k)].extinction);
        set_vec3(p, ("u_tf_color" + idx).c_str(), v.transfer[size_t(k)].color);
      }
      glBindTextureUnit(0, g->texture);
      glBindTextureUnit(3, g->blocks);
      glProgramUniform1i(p, glGetUniformLocation(p, "u_blocks"), 3);
      glProgramUniform3i(p, glGetUniformLocation(p, "u_block_count"), g->bx, g->by, g->bz);
      glProgramUniform1f(p, glGetUniformLocation(p, "u_empty_below"), empty_below(v.transfer));
      glProgramUniform1i(p, glGetUniformLocation(p, "u_lookup_every"), std::max(opt.volume_lookup_every, 1));
      glDisable(GL_DEPTH_TEST);  // the march itself stops at the opaque depth
      glCullFace(GL_FRONT);      // its back faces
      draw_object(i, o, p, opt);
      glEnable(GL_DEPTH_TEST);
      continue;
    }
    const bool medium = o.interior == cdsm::InteriorKind::Constant && cdsm::max_channel(o.sigma) > 0.0f;
    if (medium) {  // the distance of its back faces, for its front faces' absorption
      const float far_away[1] = {3.0e38f};
      glClearNamedFramebufferfv(back_fbo_, GL_COLOR, 0, far_away);
      glBindFramebuffer(GL_FRAMEBUFFER, back_fbo_);
      glUseProgram(distance_program_);
      set_mat4(distance_program_, "u_view_proj", vp);
      set_vec3(distance_program_, "u_eye", cam.position);
      glBlendEquation(GL_MIN);
      glBlendFunc(GL_ONE, GL_ONE);
      glDisable(GL_DEPTH_TEST);
      glDisable(GL_STENCIL_TEST);
      glCullFace(GL_FRONT);  // its back faces (draw_object sets the winding of mirrored objects)
      draw_object(i, o, distance_program_, opt);
      glEnable(GL_DEPTH_TEST);
      glEnable(GL_STENCIL_TEST);
      glBlendEquation(GL_FUNC_ADD);
      glBlendFuncSeparate(GL_ONE, GL_SRC1_COLOR, GL_ZERO, GL_ONE);
      glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
    }
    glUseProgram(surface_program_);
    system.bind_gl(surface_program_);
    glCullFace(GL_FRONT);  // its far side first, then its near side
    draw_object(i, o, surface_program_, opt);
    glCullFace(GL_BACK);
    if (medium) {
      const GLuint p = surface_program_;
      glBindTextureUnit(2, back_distance_);
      glProgramUniform1i(p, glGetUniformLocation(p, "u_back_distance"), 2);
      glProgramUniform1i(p, glGetUniformLocation(p, "u_scene_depth"), 1);
      set_vec3(p, "u_forward", forward);
      glProgramUniform2f(p, glGetUniformLocation(p, "u_near_far"), cam.near, cam.far);
      set_vec3(p, "u_sigma", o.sigma);
      draw_object(i, o, p, opt, true);
    } else {
      draw_object(i, o, surface_program_, opt);
    }
  }
  glDisable(GL_CULL_FACE);
  glDisable(GL_BLEND);
  glDisable(GL_STENCIL_TEST);
  glDepthMask(GL_TRUE);

  // 3. Overlays: the selection's outline, lines (frusta, lights).
  if (opt.selected >= 0 && size_t(opt.selected) < scene.objects.size() && scene.objects[size_t(opt.selected)].mesh) {
    glUseProgram(solid_program_);
    glProgramUniform4f(solid_program_, glGetUniformLocation(solid_program_, "u_solid"), 1.0f, 0.55f, 0.1f, 1.0f);
    glPolygonMode(GL_FRONT_AND_BACK, GL_LINE);
    glDepthFunc(GL_LEQUAL);
    draw_object(size_t(opt.selected), scene.objects[size_t(opt.selected)], solid_program_, opt);
    glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    glDepthFunc(GL_LESS);
  }
  if (!opt.lines.empty()) {
    std::vector<float> v;
    for (const Line& l : opt.lines)
      v.insert(v.end(), {l.a.x, l.a.y, l.a.z, l.color.x, l.color.y, l.color.z, l.b.x, l.b.y, l.b.z, l.color.x,
                         l.color.y, l.color.z});
    const uint64_t bytes = v.size() * sizeof(float);
    if (bytes > line_capacity_) {
      glDeleteBuffers(1, &line_vbo_);
      glCreateBuffers(1, &line_vbo_);
      line_capacity_ = std::max<uint64_t>(bytes, 2 * line_capacity_);
      glNamedBufferStorage(line_vbo_, GLsizeiptr(line_capacity_), nullptr, GL_DYNAMIC_STORAGE_BIT);
      glVertexArrayVertexBuffer(line_vao_, 0, line_vbo_, 0, 24);
    }
    glNamedBufferSubData(line_vbo_, 0, GLsizeiptr(bytes), v.data());
    glUseProgram(line_program_);
    glBindVertexArray(line_vao_);
    glDrawArrays(GL_LINES, 0, GLsizei(opt.lines.size() * 2));
  }
  glFrontFace(GL_CCW);
  glBindVertexArray(0);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  // 4. The display copy: sRGB-encoded 8 bits.
  glUseProgram(display_program_);
  glBindImageTexture(0, color_, 0, GL_FALSE, 0, GL_READ_ONLY, GL_RGBA32F);
  glBindImageTexture(1, display_, 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA8);
  glDispatchCompute(GLuint((width_ + 7) / 8), GLuint((height_ + 7) / 8), 1);
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
  glUseProgram(0);
  glFinish();
  check("frame");
  t.draw_ms = ms_since(t0);
  t.total_ms = t.draw_ms;
  return t;
}

Pick ForwardRenderer::pick(const cdsm::Scene& scene, const cdsm::Camera& camera_in, int x, int y) {
  Pick r;
  if (x < 0 || y < 0 || x >= width_ || y >= height_) return r;
  cdsm::Camera cam = camera_in;
  cam.width = width_;
  cam.height = height_;
  set_mat4(pick_program_, "u_view_proj", view_projection(cam));
  glBindFramebuffer(GL_FRAMEBUFFER, pick_fbo_);
  glViewport(0, 0, width_, height_);
  const GLuint zero[4] = {0, 0, 0, 0};
  const float fzero[4] = {0, 0, 0, 0};
  glClearNamedFramebufferuiv(pick_fbo_, GL_COLOR, 0, zero);
  glClearNamedFramebufferfv(pick_fbo_, GL_COLOR, 1, fzero);
  glClearNamedFramebufferfv(pick_fbo_, GL_COLOR, 2, fzero);
  const float far_depth = 1.0f;
  glClearNamedFramebufferfv(pick_fbo_, GL_DEPTH, 0, &far_depth);
  check("pick: clear");
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  glDisable(GL_BLEND);
  glBlendFunc(GL_ONE, GL_ZERO);  // no dual-source factors with three draw buffers
  glDisable(GL_CULL_FACE);
  glUseProgram(pick_program_);
  DrawOptions none;
  for (size_t i = 0; i < scene.objects.size(); ++i)
    if (scene.objects[i].mesh && meshes_.count(scene.objects[i].mesh.get()))
      draw_object(i, scene.objects[i], pick_program_, none);
  check("pick: draw");
  const int gy = height_ - 1 - y;  // GL rows go up
  GLuint id = 0;
  float pos[4] = {0, 0, 0, 0}, plane[4] = {0, 0, 0, 0};
  glGetTextureSubImage(pick_id_, 0, x, gy, 0, 1, 1, 1, GL_RED_INTEGER, GL_UNSIGNED_INT, sizeof id, &id);
  glGetTextureSubImage(pick_pos_, 0, x, gy, 0, 1, 1, 1, GL_RGBA, GL_FLOAT, sizeof pos, pos);
  glGetTextureSubImage(pick_plane_, 0, x, gy, 0, 1, 1, 1, GL_RGBA, GL_FLOAT, sizeof plane, plane);
  glUseProgram(0);
  glBindVertexArray(0);
  glFrontFace(GL_CCW);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  check("pick");
  r.object = int(id) - 1;
  r.position = {pos[0], pos[1], pos[2]};
  r.plane = {plane[0], plane[1], plane[2]};
  return r;
}

void ForwardRenderer::present(int x, int y, int width, int height) {
  glBlitNamedFramebuffer(fbo_, 0, 0, 0, width_, height_, x, y, x + width, y + height, GL_COLOR_BUFFER_BIT, GL_LINEAR);
}

cdsm::Image ForwardRenderer::read_color() const {
  std::vector<float> rgba(size_t(width_) * height_ * 4);
  glGetTextureImage(color_, 0, GL_RGBA, GL_FLOAT, GLsizei(rgba.size() * 4), rgba.data());
  cdsm::Image img;
  img.width = width_;
  img.height = height_;
  img.rgb.resize(size_t(width_) * height_ * 3);
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x)
      for (int c = 0; c < 3; ++c)
        img.rgb[(size_t(y) * width_ + x) * 3 + c] = rgba[(size_t(height_ - 1 - y) * width_ + x) * 4 + c];
  return img;
}

std::vector<unsigned char> ForwardRenderer::read_opaque_mask() const {
  std::vector<unsigned char> stencil(size_t(width_) * height_), mask(stencil.size());
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width_, height_, GL_STENCIL_INDEX, GL_UNSIGNED_BYTE, stencil.data());
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x)
      mask[size_t(y) * width_ + x] = stencil[size_t(height_ - 1 - y) * width_ + x] == 1 ? 1 : 0;
  return mask;
}

}  // namespace forward
