// The forward renderer's picking: which object is under a pixel.
#define GL_GLEXT_PROTOTYPES 1
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "forward_internal.h"
#include "shaders.h"

namespace forward {

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

}  // namespace forward
