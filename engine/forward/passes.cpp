// The forward renderer's passes: opaque meshes, then translucent meshes and
// volumes back to front, each shading call taking its shadows from cdsm.glsl.
#define GL_GLEXT_PROTOTYPES 1
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "forward_internal.h"
#include "shaders.h"

namespace forward {

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

}  // namespace forward
