// The forward renderer's render targets: their sizes, presenting the image
// and reading it (and its opaque mask) back.
#define GL_GLEXT_PROTOTYPES 1
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "forward_internal.h"
#include "shaders.h"

namespace forward {

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
