#define GL_GLEXT_PROTOTYPES 1
#include "forward_renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
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

GLuint compile(GLenum stage, const std::string& body, bool with_cdsm) {
  const std::string src = "#version 450\n" + (with_cdsm ? cdsm::glsl_include() : std::string()) + body;
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
void set_vec3(GLuint p, const char* name, cdsm::Vec3 v) { glProgramUniform3f(p, glGetUniformLocation(p, name), v.x, v.y, v.z); }

cdsm::Mat4 inverse(const cdsm::Mat4& m) {
  cdsm::Mat4 inv;
  if (!cdsm::invert_affine(m, inv)) throw std::runtime_error("a transform has no inverse");
  return inv;
}

// The camera as GL sees it: the library's pinhole (forward, right, up
// from target and up; vertical field of view) as view and projection.
cdsm::Mat4 view_projection(const cdsm::Camera& c) {
  using cdsm::Vec3;
  const Vec3 f = cdsm::normalize(c.target - c.position);
  Vec3 r = cdsm::cross(f, c.up);
  if (cdsm::length(r) < 1e-6f) r = cdsm::cross(f, std::fabs(f.x) < 0.9f ? Vec3{1, 0, 0} : Vec3{0, 1, 0});
  r = cdsm::normalize(r);
  const Vec3 u = cdsm::cross(r, f);
  cdsm::Mat4 view;
  const Vec3 rows[3] = {r, u, -f};
  for (int i = 0; i < 3; ++i) {
    view.m[i][0] = rows[i].x;
    view.m[i][1] = rows[i].y;
    view.m[i][2] = rows[i].z;
    view.m[i][3] = -cdsm::dot(rows[i], c.position);
  }
  const float ty = std::tan(c.fov_y_deg * 0.5f * 3.14159265f / 180.0f);
  const float tx = ty * float(c.width) / float(c.height);
  cdsm::Mat4 proj;
  proj.m[0][0] = 1.0f / tx;
  proj.m[1][1] = 1.0f / ty;
  proj.m[2][2] = -(c.far + c.near) / (c.far - c.near);
  proj.m[2][3] = -2.0f * c.far * c.near / (c.far - c.near);
  proj.m[3][2] = -1.0f;
  proj.m[3][3] = 0.0f;
  return proj * view;
}

bool passes_all(const cdsm::SurfaceMaterial& s) {
  return s.opacity <= 0.0f && s.transmission_color.x >= 1.0f && s.transmission_color.y >= 1.0f &&
         s.transmission_color.z >= 1.0f;
}

}  // namespace

struct ForwardRenderer::Mesh {
  GLuint vao = 0, vbo = 0, ibo = 0;
  GLsizei index_count = 0;
  cdsm::Mat4 model;
  float normal_matrix[9] = {};
  cdsm::SurfaceMaterial surface;
  bool caster = true, has_normals = false, mirrored = false, invisible = false;
  cdsm::Vec3 center;
  cdsm::Box3 box;  // object space
  int volume = -1;  // index into volumes_ (a volume's proxy)
};

struct ForwardRenderer::Volume {
  GLuint texture = 0;
  cdsm::Mat4 world_to_index, world_to_box;
  cdsm::Vec3 size;
  float step = 0.01f;
  const cdsm::Volume* volume = nullptr;
};

ForwardRenderer::ForwardRenderer(const cdsm::Scene& scene, std::vector<std::string>& notes) : scene_(scene) {
  cdsm::SystemOptions o;
  o.gl_context = cdsm::GlContextUse::Application;  // this renderer's context, current now
  o.source = scene.source;
  system_ = std::make_unique<cdsm::ShadowSystem>(o);
  cdsm::ShadowSystem& sys = *system_;

  std::vector<cdsm::VolumeHandle> volume_handles;
  for (const cdsm::Volume& v : scene.volumes) volume_handles.push_back(sys.add_volume(v));

  for (const cdsm::Object& obj : scene.objects) {
    const cdsm::TriangleMesh& tm = *obj.mesh;
    Mesh m;
    m.has_normals = tm.normals.size() == tm.positions.size();
    // The application's buffers: interleaved position + normal, 32-bit indices.
    std::vector<float> interleaved;
    interleaved.reserve(tm.positions.size() * 6);
    for (size_t i = 0; i < tm.positions.size(); ++i) {
      const cdsm::Vec3 p = tm.positions[i], n = m.has_normals ? tm.normals[i] : cdsm::Vec3{0, 0, 1};
      interleaved.insert(interleaved.end(), {p.x, p.y, p.z, n.x, n.y, n.z});
    }
    glCreateBuffers(1, &m.vbo);
    glNamedBufferStorage(m.vbo, GLsizeiptr(interleaved.size() * sizeof(float)), interleaved.data(), 0);
    glCreateBuffers(1, &m.ibo);
    glNamedBufferStorage(m.ibo, GLsizeiptr(tm.indices.size() * 4), tm.indices.data(), 0);
    glCreateVertexArrays(1, &m.vao);
    glVertexArrayVertexBuffer(m.vao, 0, m.vbo, 0, 24);
    glVertexArrayElementBuffer(m.vao, m.ibo);
    for (GLuint a = 0; a < 2; ++a) {
      glEnableVertexArrayAttrib(m.vao, a);
      glVertexArrayAttribFormat(m.vao, a, 3, GL_FLOAT, GL_FALSE, a * 12);
      glVertexArrayAttribBinding(m.vao, a, 0);
    }
    m.index_count = GLsizei(tm.indices.size());
    check("mesh upload");

    // The shadow system reads the same buffers back, once.
    cdsm::GlMeshSource src;
    src.vertex_buffer = m.vbo;
    src.vertex_stride = 24;
    src.vertex_count = uint32_t(tm.positions.size());
    if (m.has_normals) {
      src.normal_buffer = m.vbo;
      src.normal_offset = 12;
      src.normal_stride = 24;
    }
    src.index_buffer = m.ibo;
    src.index_type = GL_UNSIGNED_INT;
    src.index_count = uint32_t(tm.indices.size());
    cdsm::Object shadow_obj = obj;
    shadow_obj.mesh = sys.read_gl_mesh(src);
    const cdsm::VolumeHandle vh =
        obj.interior == cdsm::InteriorKind::Volume ? volume_handles[size_t(obj.volume)] : cdsm::VolumeHandle{};
    sys.add_object(shadow_obj, vh);

    m.model = obj.transform;
    const cdsm::Mat4 nm = cdsm::transpose(inverse(obj.transform));
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) m.normal_matrix[c * 3 + r] = nm.m[r][c];  // column-major
    m.surface = obj.surface;
    m.caster = obj.casts_shadows;
    m.mirrored = cdsm::mirrors(obj.transform);
    m.invisible = passes_all(obj.surface);
    for (const cdsm::Vec3& p : tm.positions) m.box.grow(p);
    m.center = obj.transform.point(m.box.center());
    if (obj.interior == cdsm::InteriorKind::Volume) {
      const cdsm::Volume& v = scene.volumes[size_t(obj.volume)];
      if (!v.grid) {
        notes.push_back("volume '" + v.name + "': sparse (NanoVDB) grids are not drawn by this example");
      } else if (v.shading != cdsm::VolumeShading::Scatter) {
        notes.push_back("volume '" + v.name + "': Phong-shaded volumes are not drawn by this example");
      } else {
        Volume vol;
        vol.volume = &scene_.volumes[size_t(obj.volume)];
        const cdsm::Mat4 index_to_world = obj.transform * v.index_to_object;
        vol.world_to_index = inverse(index_to_world);
        vol.world_to_box = inverse(obj.transform);
        vol.size = {float(v.grid->nx), float(v.grid->ny), float(v.grid->nz)};
        float voxel = 1e30f;
        for (int c = 0; c < 3; ++c)
          voxel = std::min(voxel, cdsm::length({index_to_world.m[0][c], index_to_world.m[1][c], index_to_world.m[2][c]}));
        vol.step = v.step_voxels * voxel;
        glCreateTextures(GL_TEXTURE_3D, 1, &vol.texture);
        glTextureStorage3D(vol.texture, 1, GL_R32F, v.grid->nx, v.grid->ny, v.grid->nz);
        glTextureSubImage3D(vol.texture, 0, 0, 0, 0, v.grid->nx, v.grid->ny, v.grid->nz, GL_RED, GL_FLOAT,
                            v.grid->values.data());
        glTextureParameteri(vol.texture, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
        glTextureParameteri(vol.texture, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        for (GLenum w : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
          glTextureParameteri(vol.texture, w, GL_CLAMP_TO_BORDER);
        const float border[4] = {v.grid->background, 0, 0, 0};
        glTextureParameterfv(vol.texture, GL_TEXTURE_BORDER_COLOR, border);
        check("volume texture");
        m.volume = int(volumes_.size());
        volumes_.push_back(vol);
      }
    } else if (obj.interior == cdsm::InteriorKind::Constant && obj.surface.opacity < 1.0f) {
      notes.push_back("object '" + obj.name + "': its constant medium is not drawn (only its surface)");
    }
    meshes_.push_back(m);
  }
  for (const cdsm::Light& l : scene.lights) sys.add_light(l);
  sys.set_camera(scene.camera);
  sys.set_settings(scene.shadows);
  sys.set_background(scene.background);

  // Programs: the application's shaders with the library's include.
  const GLuint vs = compile(GL_VERTEX_SHADER, kMeshVertex, false);
  const GLuint gs = compile(GL_GEOMETRY_SHADER, kMeshGeometry, false);
  surface_program_ = link({vs, gs, compile(GL_FRAGMENT_SHADER, kSurfaceFragment, true)});
  const GLuint vs2 = compile(GL_VERTEX_SHADER, kMeshVertex, false);
  const GLuint gs2 = compile(GL_GEOMETRY_SHADER, kMeshGeometry, false);
  volume_program_ = link({vs2, gs2, compile(GL_FRAGMENT_SHADER, kVolumeFragment, true)});

  // The frame: linear float colour, depth + stencil (the stencil marks what
  // the translucent passes covered), and a copy of the opaque depth the
  // ray marcher reads.
  width_ = scene.camera.width;
  height_ = scene.camera.height;
  glCreateTextures(GL_TEXTURE_2D, 1, &color_);
  glTextureStorage2D(color_, 1, GL_RGBA32F, width_, height_);
  glCreateTextures(GL_TEXTURE_2D, 1, &depth_);
  glTextureStorage2D(depth_, 1, GL_DEPTH24_STENCIL8, width_, height_);
  glCreateFramebuffers(1, &fbo_);
  glNamedFramebufferTexture(fbo_, GL_COLOR_ATTACHMENT0, color_, 0);
  glNamedFramebufferTexture(fbo_, GL_DEPTH_STENCIL_ATTACHMENT, depth_, 0);
  glCreateTextures(GL_TEXTURE_2D, 1, &depth_copy_);
  glTextureStorage2D(depth_copy_, 1, GL_DEPTH24_STENCIL8, width_, height_);
  glTextureParameteri(depth_copy_, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(depth_copy_, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glCreateFramebuffers(1, &depth_copy_fbo_);
  glNamedFramebufferTexture(depth_copy_fbo_, GL_DEPTH_STENCIL_ATTACHMENT, depth_copy_, 0);
  if (glCheckNamedFramebufferStatus(fbo_, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw std::runtime_error("the frame's framebuffer is incomplete");
  check("framebuffer");
}

ForwardRenderer::~ForwardRenderer() {
  system_.reset();  // before the GL objects and the context go
  for (Mesh& m : meshes_) {
    glDeleteVertexArrays(1, &m.vao);
    glDeleteBuffers(1, &m.vbo);
    glDeleteBuffers(1, &m.ibo);
  }
  for (Volume& v : volumes_) glDeleteTextures(1, &v.texture);
  glDeleteProgram(surface_program_);
  glDeleteProgram(volume_program_);
  glDeleteFramebuffers(1, &fbo_);
  glDeleteFramebuffers(1, &depth_copy_fbo_);
  glDeleteTextures(1, &color_);
  glDeleteTextures(1, &depth_);
  glDeleteTextures(1, &depth_copy_);
}

void ForwardRenderer::draw_mesh(const Mesh& m, GLuint p, bool shadows) {
  set_mat4(p, "u_model", m.model);
  glProgramUniformMatrix3fv(p, glGetUniformLocation(p, "u_normal_matrix"), 1, GL_FALSE, m.normal_matrix);
  const cdsm::SurfaceMaterial& s = m.surface;
  set_vec3(p, "u_color", s.color);
  glProgramUniform1f(p, glGetUniformLocation(p, "u_opacity"), s.opacity);
  set_vec3(p, "u_transmission", s.transmission_color);
  glProgramUniform4f(p, glGetUniformLocation(p, "u_phong"), s.ambient, s.diffuse, s.specular, s.shininess);
  glProgramUniform1i(p, glGetUniformLocation(p, "u_caster"), m.caster);
  glProgramUniform1i(p, glGetUniformLocation(p, "u_has_normals"), m.has_normals);
  glProgramUniform1i(p, glGetUniformLocation(p, "u_shadows"), shadows);
  glFrontFace(m.mirrored ? GL_CW : GL_CCW);
  glBindVertexArray(m.vao);
  glDrawElements(GL_TRIANGLES, m.index_count, GL_UNSIGNED_INT, nullptr);
}

void ForwardRenderer::draw_volume(const Volume& v, bool shadows) {
  const GLuint p = volume_program_;
  const cdsm::Volume& vol = *v.volume;
  set_mat4(p, "u_world_to_index", v.world_to_index);
  set_mat4(p, "u_world_to_box", v.world_to_box);
  set_vec3(p, "u_grid_size", v.size);
  glProgramUniform1f(p, glGetUniformLocation(p, "u_step"), v.step);
  const int n = int(std::min<size_t>(vol.transfer.size(), 16));
  glProgramUniform1i(p, glGetUniformLocation(p, "u_points"), n);
  for (int i = 0; i < n; ++i) {
    const std::string k = "[" + std::to_string(i) + "]";
    glProgramUniform1f(p, glGetUniformLocation(p, ("u_tf_density" + k).c_str()), vol.transfer[size_t(i)].density);
    set_vec3(p, ("u_tf_extinction" + k).c_str(), vol.transfer[size_t(i)].extinction);
    set_vec3(p, ("u_tf_color" + k).c_str(), vol.transfer[size_t(i)].color);
  }
  glProgramUniform1i(p, glGetUniformLocation(p, "u_shadows"), shadows);
  glBindTextureUnit(0, v.texture);
  glProgramUniform1i(p, glGetUniformLocation(p, "u_density"), 0);
}

FrameTimes ForwardRenderer::render(bool shadows, cdsm::FrameStats* stats) {
  FrameTimes t;
  const auto t0 = Clock::now();
  system_->update(stats);  // maps reused unless something changed
  t.update_ms = ms_since(t0);
  const auto t1 = Clock::now();

  const cdsm::Camera& cam = scene_.camera;
  const cdsm::Mat4 vp = view_projection(cam);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glViewport(0, 0, width_, height_);
  const float bg[4] = {scene_.background.x, scene_.background.y, scene_.background.z, 1.0f};
  glClearNamedFramebufferfv(fbo_, GL_COLOR, 0, bg);
  glClearNamedFramebufferfi(fbo_, GL_DEPTH_STENCIL, 0, 1.0f, 0);
  for (GLuint p : {surface_program_, volume_program_}) {
    set_mat4(p, "u_view_proj", vp);
    set_vec3(p, "u_eye", cam.position);
    set_vec3(p, "u_ambient", scene_.shadows.ambient_light);
  }

  // 1. Opaque surfaces: depth test and write; stencil 1 where drawn.
  glUseProgram(surface_program_);
  system_->bind_gl(surface_program_);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  glEnable(GL_STENCIL_TEST);
  glStencilFunc(GL_ALWAYS, 1, 0xff);
  glStencilOp(GL_KEEP, GL_KEEP, GL_REPLACE);
  for (const Mesh& m : meshes_)
    if (!m.invisible && m.surface.opacity >= 1.0f) draw_mesh(m, surface_program_, shadows);

  // The opaque depth for the ray marcher (sampling the attached one would
  // be a feedback loop).
  glBlitNamedFramebuffer(fbo_, depth_copy_fbo_, 0, 0, width_, height_, 0, 0, width_, height_,
                         GL_DEPTH_BUFFER_BIT | GL_STENCIL_BUFFER_BIT, GL_NEAREST);

  // 2. Translucent surfaces and volumes, back to front (object centres):
  //    dst = src0 + dst * src1, no depth writes; stencil 2 where drawn.
  std::vector<const Mesh*> order;
  for (const Mesh& m : meshes_)
    if (m.volume >= 0 || (!m.invisible && m.surface.opacity < 1.0f)) order.push_back(&m);
  std::sort(order.begin(), order.end(), [&](const Mesh* a, const Mesh* b) {
    return cdsm::length(a->center - cam.position) > cdsm::length(b->center - cam.position);
  });
  glEnable(GL_BLEND);
  glBlendFuncSeparate(GL_ONE, GL_SRC1_COLOR, GL_ZERO, GL_ONE);
  glDepthMask(GL_FALSE);
  glStencilFunc(GL_ALWAYS, 2, 0xff);
  glEnable(GL_CULL_FACE);
  const float viewport[2] = {float(width_), float(height_)};
  glProgramUniform2fv(volume_program_, glGetUniformLocation(volume_program_, "u_viewport"), 1, viewport);
  set_vec3(volume_program_, "u_forward", cdsm::normalize(cam.target - cam.position));
  glProgramUniform2f(volume_program_, glGetUniformLocation(volume_program_, "u_near_far"), cam.near, cam.far);
  glBindTextureUnit(1, depth_copy_);
  glProgramUniform1i(volume_program_, glGetUniformLocation(volume_program_, "u_scene_depth"), 1);
  for (const Mesh* m : order) {
    if (m->volume >= 0) {
      const Volume& v = volumes_[size_t(m->volume)];
      glUseProgram(volume_program_);
      system_->bind_gl(volume_program_);
      draw_volume(v, shadows);
      set_vec3(volume_program_, "u_box_lo", m->box.lo);
      set_vec3(volume_program_, "u_box_hi", m->box.hi);
      glDisable(GL_DEPTH_TEST);  // the march itself stops at the opaque depth
      glCullFace(m->mirrored ? GL_BACK : GL_FRONT);
      draw_mesh(*m, volume_program_, shadows);
      glEnable(GL_DEPTH_TEST);
      continue;
    }
    glUseProgram(surface_program_);
    system_->bind_gl(surface_program_);
    glCullFace(GL_FRONT);  // its far side first, then its near side
    draw_mesh(*m, surface_program_, shadows);
    glCullFace(GL_BACK);
    draw_mesh(*m, surface_program_, shadows);
  }
  glDisable(GL_CULL_FACE);
  glDisable(GL_BLEND);
  glDisable(GL_STENCIL_TEST);
  glDepthMask(GL_TRUE);
  glFrontFace(GL_CCW);
  glBindVertexArray(0);
  glUseProgram(0);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glFinish();
  check("frame");
  t.draw_ms = ms_since(t1);
  t.total_ms = ms_since(t0);
  return t;
}

void ForwardRenderer::present() {
  glBlitNamedFramebuffer(fbo_, 0, 0, 0, width_, height_, 0, 0, width_, height_, GL_COLOR_BUFFER_BIT, GL_NEAREST);
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
