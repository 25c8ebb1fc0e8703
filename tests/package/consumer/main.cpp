// An application of the installed cdsm package (find_package(cdsm),
// cdsm::cdsm): public headers and libcdsm only. It renders a small scene
// with the CPU fragment producer (no GL) and checks the shadows against
// the scene's geometry, then checks what the package installs beside the
// library. Prints every figure; exits non-zero on any failure.
//
// Usage: cdsm_consumer [OUTPUT_DIR]   (writes consumer.png there)
#include <cdsm/cdsm.h>
#include <cdsm/gl.h>
#include <cdsm/loaders.h>

#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <memory>
#include <string>

#ifndef CDSM_PACKAGE_VERSION
#error "CDSM_PACKAGE_VERSION (cdsm_VERSION of find_package) is not defined"
#endif
#ifndef CDSM_PACKAGE_GLSL_DIR
#error "CDSM_PACKAGE_GLSL_DIR (CDSM_GLSL_DIR of find_package) is not defined"
#endif

namespace {

int g_failures = 0;

void check(bool ok, const std::string& what) {
  std::printf("%s %s\n", ok ? "ok  " : "FAIL", what.c_str());
  if (!ok) ++g_failures;
}

bool file_exists(const std::string& path) { return std::ifstream(path).good(); }

// The pixel (column, row; row 0 at the top) whose centre sees `p`, for the
// scene's pinhole camera (vertical fov, square pixels).
struct Pixel {
  int x = -1, y = -1;
};
Pixel project(const cdsm::Camera& cam, cdsm::Vec3 p) {
  const cdsm::Vec3 f = cdsm::normalize(cam.target - cam.position);
  const cdsm::Vec3 r = cdsm::normalize(cdsm::cross(f, cam.up));
  const cdsm::Vec3 u = cdsm::cross(r, f);
  const cdsm::Vec3 d = p - cam.position;
  const float tan_y = std::tan(cam.fov_y_deg * 0.5f * 3.14159265f / 180.0f);
  const float tan_x = tan_y * float(cam.width) / float(cam.height);
  const float sx = cdsm::dot(d, r) / cdsm::dot(d, f);
  const float sy = cdsm::dot(d, u) / cdsm::dot(d, f);
  Pixel px;
  px.x = int(std::floor((1.0f + sx / tan_x) * 0.5f * float(cam.width)));
  px.y = int(std::floor((1.0f - sy / tan_y) * 0.5f * float(cam.height)));
  return px;
}

float grey_at(const cdsm::Image& img, Pixel px) {
  const size_t i = (size_t(px.y) * size_t(img.width) + size_t(px.x)) * 3;
  return (img.rgb[i] + img.rgb[i + 1] + img.rgb[i + 2]) / 3.0f;
}

// Scene (world units, y up): a 12 x 12 receive-only ground at y = 0; two
// unit cubes centred at (-1.5, 1, 0) (opaque) and (+1.5, 1, 0) (a white
// surface of opacity 0.3: each face passes 0.7, a ray through the cube
// crosses two faces, so T = 0.49); a spot light at (0, 6, -2) pointing
// straight down. The line from the light through a cube's centre meets the
// ground at (+-1.8, 0, 0.4) (the light is 6 above the ground and 5 above
// the centres: 1.2 x the offset (+-1.5, -2)), deep inside each shadow and,
// from the camera at (0, 5, 8), in front of the cube. The ground point
// (0, 0, 1) is lit by nothing but the light and lies at the same distance
// (3) from the light's foot (0, 0, -2) as both shadow points, so all three
// receive the same direct light (distance, spot cone, incidence) but for
// the casters' transmittance. The ground has no specular term, so a
// pixel is ambient + T x direct with T = 1 (lit), 0.49, 0 (opaque).
constexpr float kTranslucentOpacity = 0.3f;
constexpr float kExpectedT = (1.0f - kTranslucentOpacity) * (1.0f - kTranslucentOpacity);

// Returns the ground's handle.
cdsm::ObjectHandle build_scene(cdsm::ShadowSystem& system, cdsm::Camera& camera) {
  cdsm::Object ground;
  ground.name = "ground";
  ground.mesh = std::make_shared<cdsm::TriangleMesh>(cdsm::make_ground(12.0f, 12.0f));
  ground.casts_shadows = false;
  ground.surface.color = {0.8f, 0.8f, 0.8f};
  ground.surface.specular = 0.0f;
  const cdsm::ObjectHandle ground_handle = system.add_object(ground);

  auto cube = std::make_shared<cdsm::TriangleMesh>(cdsm::make_box({1.0f, 1.0f, 1.0f}));
  cdsm::Object opaque;
  opaque.name = "opaque cube";
  opaque.mesh = cube;
  opaque.transform = cdsm::make_transform({-1.5f, 1.0f, 0.0f}, {0, 0, 0}, {1, 1, 1});
  system.add_object(opaque);

  cdsm::Object glass = opaque;
  glass.name = "translucent cube";
  glass.transform = cdsm::make_transform({1.5f, 1.0f, 0.0f}, {0, 0, 0}, {1, 1, 1});
  glass.surface.opacity = kTranslucentOpacity;
  system.add_object(glass);

  cdsm::Light spot;
  spot.name = "spot";
  spot.type = cdsm::LightType::Spot;
  spot.position = {0.0f, 6.0f, -2.0f};
  spot.direction = {0.0f, -1.0f, 0.0f};
  spot.outer_cone_deg = 50.0f;
  spot.inner_cone_deg = 40.0f;
  system.add_light(spot);

  camera.position = {0.0f, 5.0f, 8.0f};
  camera.target = {0.0f, 0.0f, 0.0f};
  camera.fov_y_deg = 45.0f;
  camera.near = 0.1f;
  camera.far = 50.0f;
  camera.width = 96;
  camera.height = 64;
  system.set_camera(camera);

  cdsm::ShadowSettings settings;
  settings.epsilon = 0.01f;
  settings.resolution = 256;
  system.set_settings(settings);
  return ground_handle;
}

void check_shadows(const std::string& out_dir) {
  cdsm::SystemOptions options;
  options.fragments = cdsm::FragmentSource::Cpu;
  options.source = "package consumer";
  cdsm::ShadowSystem system(options);
  cdsm::Camera camera;
  build_scene(system, camera);

  cdsm::FrameStats stats;
  const cdsm::Image img = system.render(&stats);
  std::printf("rendered %dx%d: fragments %s, %u map(s) built, %.1f ms\n", img.width, img.height,
              stats.fragment_source.c_str(), stats.maps_rebuilt, stats.times.total_ms);
  check(img.width == camera.width && img.height == camera.height &&
            img.rgb.size() == size_t(img.width) * size_t(img.height) * 3,
        "image size is the camera's");
  check(stats.fragment_source == "cpu", "CPU fragment producer used (got '" + stats.fragment_source + "')");
  check(stats.maps_rebuilt >= 1, "a deep shadow map was built");
  if (!out_dir.empty()) cdsm::write_png(img, out_dir + "/consumer.png");

  const Pixel lit = project(camera, {0.0f, 0.0f, 1.0f});
  const Pixel translucent = project(camera, {1.8f, 0.0f, 0.4f});
  const Pixel opaque = project(camera, {-1.8f, 0.0f, 0.4f});
  for (const Pixel& p : {lit, translucent, opaque})
    if (p.x < 0 || p.y < 0 || p.x >= img.width || p.y >= img.height) {
      check(false, "expected pixels inside the image");
      return;
    }
  const float g_lit = grey_at(img, lit);
  const float g_trans = grey_at(img, translucent);
  const float g_opaque = grey_at(img, opaque);
  std::printf("ground lit          pixel (%d,%d): %.4f\n", lit.x, lit.y, g_lit);
  std::printf("translucent shadow  pixel (%d,%d): %.4f\n", translucent.x, translucent.y, g_trans);
  std::printf("opaque shadow       pixel (%d,%d): %.4f\n", opaque.x, opaque.y, g_opaque);
  check(g_lit > g_opaque + 0.05f, "the lit ground is clearly brighter than the opaque cube's shadow");
  check(g_trans < g_lit, "the translucent cube's shadow is darker than the lit ground");
  check(g_trans > g_opaque, "the translucent cube's shadow is lighter than the opaque cube's");
  // The fraction of the direct light that reaches the translucent shadow.
  const float t = (g_trans - g_opaque) / (g_lit - g_opaque);
  char line[160];
  std::snprintf(line, sizeof line, "transmittance in the translucent shadow %.3f, expected %.3f +- 0.05", t,
                kExpectedT);
  check(std::fabs(t - kExpectedT) <= 0.05f, line);
}

// The engine path: a shadow system on the application's own (headless)
// context, the maps in GL buffers, read by a compute shader built from the
// installed cdsm.glsl at the three ground points: T = 1, 0.49, 0.
void check_gl_lookups() {
  std::string why;
  auto context = cdsm::GlContext::create_headless(&why);
  if (!context) {
    const char* req = std::getenv("CDSM_REQUIRE_GL");
    check(!(req && std::string(req) == "1"), "an OpenGL 4.5 context (CDSM_REQUIRE_GL=1): " + why);
    std::printf("skip GL lookups: no OpenGL 4.5 context (%s)\n", why.c_str());
    return;
  }
  std::ifstream f(std::string(CDSM_PACKAGE_GLSL_DIR) + "/cdsm.glsl");
  const std::string include((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  check(!include.empty(), "the installed cdsm.glsl is readable");
  if (include.empty()) return;
  cdsm::SystemOptions options;
  options.gl_context = cdsm::GlContextUse::Application;
  options.source = "package consumer (GL)";
  cdsm::ShadowSystem system(options);
  cdsm::Camera camera;
  const cdsm::ObjectHandle ground = build_scene(system, camera);
  cdsm::FrameStats stats;
  system.update(&stats);
  check(stats.update.gl_map_upload_bytes > 0, "maps uploaded to GL buffers");

  const std::string src = "#version 450\nlayout(local_size_x = 4) in;\n" + include + R"(
layout(std430, binding = 0) buffer Out { vec4 t[]; };
uniform uint u_ground;  // ShadowSystem::gl_object_id of the ground
void main() {
  const vec3 p[3] = vec3[3](vec3(0.0, 0.0, 1.0), vec3(1.8, 0.0, 0.4), vec3(-1.8, 0.0, 0.4));
  uint i = gl_GlobalInvocationID.x;
  if (i < 3u) t[i] = vec4(cdsm_surface_transmittance(p[i], vec3(0.0, 1.0, 0.0), u_ground, 0), 0.0);
}
)";
  const char* text = src.c_str();
  GLuint sh = glCreateShader(GL_COMPUTE_SHADER);
  glShaderSource(sh, 1, &text, nullptr);
  glCompileShader(sh);
  GLint ok = 0;
  glGetShaderiv(sh, GL_COMPILE_STATUS, &ok);
  check(ok != 0, "a compute shader with the installed cdsm.glsl compiles");
  GLuint prog = glCreateProgram();
  glAttachShader(prog, sh);
  glLinkProgram(prog);
  glDeleteShader(sh);
  GLuint out;
  glCreateBuffers(1, &out);
  glNamedBufferStorage(out, 3 * 16, nullptr, 0);
  glUseProgram(prog);
  system.bind_gl(prog);
  check(system.gl_object_id(ground) == 0xffffffffu, "a receive-only object's gl_object_id is CDSM_NO_OBJECT");
  glUniform1ui(glGetUniformLocation(prog, "u_ground"), system.gl_object_id(ground));
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, out);
  glDispatchCompute(1, 1, 1);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  float t[12] = {};
  glGetNamedBufferSubData(out, 0, sizeof t, t);
  glDeleteBuffers(1, &out);
  glDeleteProgram(prog);
  std::printf("GLSL transmittance at the lit, translucent-shadow and opaque-shadow ground points: %.4f %.4f %.4f\n",
              t[0], t[4], t[8]);
  check(std::fabs(t[0] - 1.0f) <= 1e-4f, "GLSL: the lit point sees the light");
  check(std::fabs(t[4] - kExpectedT) <= 0.02f, "GLSL: the translucent cube passes 0.49 (+- 0.02)");
  check(t[8] <= 0.02f, "GLSL: the opaque cube passes nothing");
  check(glGetError() == GL_NO_ERROR, "no GL error");
}

// The installed data: the GLSL include, and content (scenes, meshes) that
// the library reads through CDSM_CONTENT_DIR, not the source tree it was
// built from.
void check_installed_files() {
  const std::string glsl_dir = CDSM_PACKAGE_GLSL_DIR;
  const std::string glsl = glsl_dir + "/cdsm.glsl";
  std::printf("CDSM_GLSL_DIR = %s\n", glsl_dir.c_str());
#if CDSM_CONSUMER_EXPECT_GLSL
  check(file_exists(glsl), "the GLSL include exists at " + glsl);
#else
  std::printf("skip the GLSL include is not required in this build (CDSM_CONSUMER_EXPECT_GLSL=OFF); %s %s\n",
              glsl.c_str(), file_exists(glsl) ? "exists" : "does not exist");
#endif

  // share/cdsm mirrors content/: shaders/, scenes/, meshes/.
  const std::string content = glsl_dir.substr(0, glsl_dir.find_last_of('/'));
  if (setenv("CDSM_CONTENT_DIR", content.c_str(), 1) != 0) {
    check(false, "setenv CDSM_CONTENT_DIR");
    return;
  }
  check(cdsm::content_dir() == content, "content_dir() follows CDSM_CONTENT_DIR (" + cdsm::content_dir() + ")");
  try {
    const cdsm::TriangleMesh cup = cdsm::make_newell_mesh(content + "/meshes/newell/teacup", 4);
    check(cup.triangle_count() > 0 && cdsm::is_closed(cup), "the installed teacup patches tessellate closed");
    const cdsm::Scene scene = cdsm::load_scene(content + "/scenes/teapot_omni.json");
    std::printf("installed teapot_omni.json: %zu objects, %zu lights\n", scene.objects.size(), scene.lights.size());
    check(!scene.objects.empty() && !scene.lights.empty(), "an installed scene loads with its installed meshes");
    // Scenes that name the public data ($SHARED/...) read share/cdsm/data.
    check(cdsm::data_dir() == content + "/data", "data_dir() is the installed data (" + cdsm::data_dir() + ")");
    for (const char* name : {"ct_xray", "smoke_gltf", "primitives"}) {
      if (std::string(name) == "smoke_gltf" && !cdsm::vdb_supported()) continue;  // a .vdb: CDSM_VDB=OFF
      const cdsm::Scene s = cdsm::load_scene(content + "/scenes/" + name + ".json");
      check(!s.objects.empty(), std::string("installed ") + name + ".json loads its installed data");
    }
  } catch (const cdsm::Error& e) {
    check(false, std::string("installed content: ") + e.what());
  }
}

}  // namespace

int main(int argc, char** argv) {
  const std::string version = CDSM_PACKAGE_VERSION;
  std::printf("cdsm_VERSION = %s\n", version.c_str());
  check(version.rfind("0.1.", 0) == 0, "package version 0.1.x");
  try {
    check_shadows(argc > 1 ? argv[1] : "");
    check_installed_files();
#if CDSM_CONSUMER_EXPECT_GLSL
    check_gl_lookups();
#endif
  } catch (const std::exception& e) {
    check(false, std::string("exception: ") + e.what());
  }
  std::printf("%s (%d failure%s)\n", g_failures == 0 ? "PASSED" : "FAILED", g_failures, g_failures == 1 ? "" : "s");
  return g_failures == 0 ? 0 : 1;
}
