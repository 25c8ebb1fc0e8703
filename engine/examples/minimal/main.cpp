// The smallest engine integration of cdsm: an application with its own EGL
// context, its own vertex buffers and its own shader asks a ShadowSystem for
// the transmittance of a translucent box onto a ground, and checks it.
//
//   - GL: EGL (surfaceless on Mesa, else the default display) for the
//     context and libOpenGL with GL_GLEXT_PROTOTYPES for the calls; an
//     engine would use its own loader (glad, epoxy, GLEW) the same way.
//   - Scene: a closed box of opacity 0.5 (two crossings: 0.5 * 0.5 = 0.25 of
//     the light passes) over a receive-only ground, a point light above.
//   - Per frame: update() (builds only what changed), bind_gl(program), the
//     GLSL call cdsm_surface_transmittance(), FrameStats to watch.
//
// It draws the ground's transmittance into a float framebuffer, top-down
// (pixel = world x, z) and exits non-zero unless the pixel under the box
// reads 0.25 and one beside it 1.0. Built and run against the installed
// package by `ctest -R package_consumer`.
#include <cdsm/cdsm.h>

#include <EGL/egl.h>
#include <EGL/eglext.h>
#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace {

// A GL 4.5 core context without a window, current on this thread.
bool make_context() {
  EGLDisplay dpy = EGL_NO_DISPLAY;
  auto get_platform_display =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (get_platform_display) dpy = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  if (dpy == EGL_NO_DISPLAY) dpy = eglGetDisplay(EGL_DEFAULT_DISPLAY);
  if (dpy == EGL_NO_DISPLAY || !eglInitialize(dpy, nullptr, nullptr) || !eglBindAPI(EGL_OPENGL_API)) return false;
  // No default framebuffer is drawn to: any GL config, or none at all.
  const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, 0, EGL_NONE};
  EGLConfig config = EGL_NO_CONFIG_KHR;
  EGLint n = 0;
  if (!eglChooseConfig(dpy, config_attribs, &config, 1, &n) || n < 1) config = EGL_NO_CONFIG_KHR;
  const EGLint ctx_attribs[] = {
      EGL_CONTEXT_MAJOR_VERSION,           4,       EGL_CONTEXT_MINOR_VERSION, 5, EGL_CONTEXT_OPENGL_PROFILE_MASK,
      EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  EGLContext ctx = eglCreateContext(dpy, config, EGL_NO_CONTEXT, ctx_attribs);
  return ctx != EGL_NO_CONTEXT && eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx);
}

// An indexed mesh in the application's own buffers: positions, 3 floats.
struct Mesh {
  GLuint vbo = 0, ibo = 0;
  GLsizei vertex_count = 0, index_count = 0;
};
Mesh upload(const std::vector<float>& xyz, const std::vector<uint32_t>& indices) {
  Mesh m;
  glCreateBuffers(1, &m.vbo);
  glNamedBufferStorage(m.vbo, GLsizeiptr(xyz.size() * 4), xyz.data(), 0);
  glCreateBuffers(1, &m.ibo);
  glNamedBufferStorage(m.ibo, GLsizeiptr(indices.size() * 4), indices.data(), 0);
  m.vertex_count = GLsizei(xyz.size() / 3);
  m.index_count = GLsizei(indices.size());
  return m;
}

// An axis-aligned box [lo, hi], outward counter-clockwise faces.
Mesh box(cdsm::Vec3 lo, cdsm::Vec3 hi) {
  std::vector<float> v;
  for (int i = 0; i < 8; ++i) v.insert(v.end(), {i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z});
  return upload(
      v, {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5});
}

GLuint compile(GLenum stage, const std::string& src) {
  GLuint s = glCreateShader(stage);
  const char* t = src.c_str();
  glShaderSource(s, 1, &t, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[4096];
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    std::fprintf(stderr, "minimal: shader: %s\n", log);
  }
  return s;
}

const char* kVertex = R"(#version 450
layout(location = 0) in vec3 p;
out vec3 world_pos;
void main() { world_pos = p; gl_Position = vec4(p.x / 2.0, p.z / 2.0, 0.0, 1.0); }  // top-down: x, z in [-2, 2]
)";
const char* kFragment = R"(
in vec3 world_pos;
layout(location = 0) out vec4 color;
uniform int light;
void main() {
  // The ground receives only: CDSM_NO_OBJECT (it is in no map, nothing to leave out).
  color = vec4(cdsm_surface_transmittance(world_pos, vec3(0.0, 1.0, 0.0), CDSM_NO_OBJECT, light), 1.0);
}
)";

}  // namespace

int main() {
  if (!make_context()) {
    std::fprintf(stderr, "minimal: no EGL / OpenGL 4.5 context\n");
    return 1;
  }
  try {
    cdsm::SystemOptions opt;
    opt.gl_context = cdsm::GlContextUse::Application;  // this context, current now
    cdsm::ShadowSystem shadows(opt);

    const Mesh ground = box({-2, -0.01f, -2}, {2, 0, 2});
    const Mesh caster = box({-0.5f, 1, -0.5f}, {0.5f, 2, 0.5f});
    cdsm::Object g;
    g.mesh = shadows.read_gl_mesh(cdsm::GlMeshSource::indexed(ground.vbo, 12, ground.vertex_count, ground.ibo,
                                                              GL_UNSIGNED_INT, ground.index_count));
    g.casts_shadows = false;  // a large receiver: keep it out of the maps
    shadows.add_object(g);
    cdsm::Object b;
    b.mesh = shadows.read_gl_mesh(cdsm::GlMeshSource::indexed(caster.vbo, 12, caster.vertex_count, caster.ibo,
                                                              GL_UNSIGNED_INT, caster.index_count));
    b.surface.opacity = 0.5f;  // applied at each surface crossed
    shadows.add_object(b);
    cdsm::Light lamp;
    lamp.type = cdsm::LightType::Point;
    lamp.position = {0, 6, 0};
    const cdsm::LightHandle lh = shadows.add_light(lamp);
    cdsm::Camera cam;  // what the maps focus on (clustering); not how this program draws
    cam.position = {0, 8, 0.01f};
    cam.target = {0, 0, 0};
    cam.up = {0, 0, -1};
    cam.width = cam.height = 64;
    shadows.set_camera(cam);

    GLuint program = glCreateProgram();
    glAttachShader(program, compile(GL_VERTEX_SHADER, kVertex));
    glAttachShader(program, compile(GL_FRAGMENT_SHADER, "#version 450\n" + cdsm::glsl_include() + kFragment));
    glLinkProgram(program);
    GLuint vao, fbo, target;
    glCreateVertexArrays(1, &vao);
    glVertexArrayVertexBuffer(vao, 0, ground.vbo, 0, 12);
    glVertexArrayElementBuffer(vao, ground.ibo);
    glEnableVertexArrayAttrib(vao, 0);
    glVertexArrayAttribFormat(vao, 0, 3, GL_FLOAT, GL_FALSE, 0);
    glCreateTextures(GL_TEXTURE_2D, 1, &target);
    glTextureStorage2D(target, 1, GL_RGBA32F, 64, 64);
    glCreateFramebuffers(1, &fbo);
    glNamedFramebufferTexture(fbo, GL_COLOR_ATTACHMENT0, target, 0);

    for (int frame = 0; frame < 2; ++frame) {  // the second frame rebuilds nothing
      cdsm::FrameStats st;
      shadows.update(&st);
      std::printf("frame %d: %u maps rebuilt, %llu bytes uploaded, fragments %.2f ms, maps %.2f ms\n", frame,
                  st.maps_rebuilt, (unsigned long long)st.update.gl_map_upload_bytes, st.times.fragments_ms,
                  st.times.dsm_build_ms);
      glBindFramebuffer(GL_FRAMEBUFFER, fbo);
      glViewport(0, 0, 64, 64);
      glUseProgram(program);
      shadows.bind_gl(program);  // after every update(): the buffers may be new
      glUniform1i(glGetUniformLocation(program, "light"), shadows.gl_light_index(lh));
      glBindVertexArray(vao);
      glDrawElements(GL_TRIANGLES, ground.index_count, GL_UNSIGNED_INT, nullptr);
    }
    std::vector<float> px(64 * 64 * 4);
    glGetTextureImage(target, 0, GL_RGBA, GL_FLOAT, GLsizei(px.size() * 4), px.data());
    // Row r, column c sees world (x, z) = ((c + 0.5) / 16 - 2, (r + 0.5) / 16 - 2).
    const float under = px[(32 * 64 + 32) * 4], beside = px[(4 * 64 + 4) * 4];
    std::printf("transmittance under the box %.4f (0.25), beside it %.4f (1)\n", under, beside);
    if (std::fabs(under - 0.25f) > 0.01f || std::fabs(beside - 1.0f) > 0.01f) return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "minimal: %s\n", e.what());
    return 1;
  }
  return 0;
}
