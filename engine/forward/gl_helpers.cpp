// The forward renderer's GL helpers (forward_internal.h).
#define GL_GLEXT_PROTOTYPES 1
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "forward_internal.h"
#include "shaders.h"

namespace forward {

void check(const char* what) {
  if (GLenum e = glGetError(); e != GL_NO_ERROR) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "%s: GL error 0x%04x", what, e);
    throw std::runtime_error(buf);
  }
}

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

// The largest density below which the transfer function has no extinction
// (-inf when even the lowest has some).
float empty_below(const std::vector<cdsm::TransferPoint>& tf) {
  if (tf.empty() || cdsm::max_channel(tf[0].extinction) > 0.0f) return -3.0e38f;
  for (size_t k = 1; k < tf.size(); ++k)
    if (cdsm::max_channel(tf[k].extinction) > 0.0f) return tf[k - 1].density;
  return 3.0e38f;  // none anywhere
}

GLuint mesh_program(const std::string& fragment, int cdsm_layout) {
  return link({compile(GL_VERTEX_SHADER, kMeshVertex, kNoCdsm), compile(GL_GEOMETRY_SHADER, kMeshGeometry, kNoCdsm),
               compile(GL_FRAGMENT_SHADER, std::string(kMeshFragmentCommon) + fragment, cdsm_layout)});
}
}  // namespace forward
