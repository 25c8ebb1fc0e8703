// content/shaders/cdsm.glsl against the CDSM_HD lookup (shadows/hd/lights.h):
// the maps of a ShadowSystem made on the application's context, read by a GL
// compute shader through cdsm.glsl and by the C++ functions the camera pass
// calls, at >= 10^5 points per scene — surface points of every object with
// their triangle's plane and caster flag, volume samples inside the media,
// and free points in the lights' reach — agree within 1e-5 per channel, in
// all three layouts, grey and RGB maps, clusters and cube faces.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "cdsm/error.h"
#include "cdsm/procedural.h"
#include "cdsm/gl.h"
#include "cdsm/scene_io.h"
#include "cdsm/shadow_system.h"
#include "gl/gl_api.h"
#include "gl_test_util.h"
#include "reference/reference.h"
#include "common/builders.h"
#include "frame_snapshot.h"
#include "scene_sync.h"

namespace cdsm::test {
namespace {

std::string scene_path(const std::string& name) { return std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/" + name; }

// One lookup: a point, the receiver's plane (0: a volume sample / free
// point) and its object when its surface is in the maps (kNoObject else).
struct LookupPoint {
  Vec3 p;
  Vec3 plane;
  uint32_t object;
  bool surface;
};

// Points over a compiled scene: `surface` on its triangles (area-uniform
// within a triangle, triangles uniform), `volume` inside the boxes of
// objects with an interior, `free` in the whole scene box.
std::vector<LookupPoint> sample_points(const SceneBuffers& sb, int surface, int volume, int free, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u01(0.0f, 1.0f);
  std::vector<LookupPoint> pts;
  const uint32_t tris = uint32_t(sb.tri_object.size());
  for (int i = 0; i < surface; ++i) {
    const uint32_t t = std::min(uint32_t(u01(rng) * float(tris)), tris - 1);
    const Vec3 a = sb.tri_vertices[3 * t], b = sb.tri_vertices[3 * t + 1], c = sb.tri_vertices[3 * t + 2];
    float r1 = u01(rng), r2 = u01(rng);
    if (r1 + r2 > 1.0f) r1 = 1.0f - r1, r2 = 1.0f - r2;
    const Vec3 p = a + (b - a) * r1 + (c - a) * r2;
    const Vec3 n = normalize(cross(b - a, c - a));
    const ObjectData& o = sb.objects[sb.tri_object[t]];
    pts.push_back({p, n, (o.flags & kObjCastsShadows) != 0u ? sb.tri_object[t] : kNoObject, true});
  }
  std::vector<Box3> media;
  for (size_t i = 0; i < sb.objects.size(); ++i)
    if (sb.objects[i].interior != InteriorKind::None) media.push_back(sb.object_bounds[i]);
  for (int i = 0; i < volume && !media.empty(); ++i) {
    const Box3& b = media[size_t(u01(rng) * float(media.size())) % media.size()];
    const Vec3 e = b.extent();
    pts.push_back({b.lo + Vec3{e.x * u01(rng), e.y * u01(rng), e.z * u01(rng)}, {0, 0, 0}, kNoObject, false});
  }
  const Vec3 e = sb.bounds.extent();
  for (int i = 0; i < free; ++i)
    pts.push_back({sb.bounds.lo + Vec3{e.x * u01(rng), e.y * u01(rng), e.z * u01(rng)}, {0, 0, 0}, kNoObject, false});
  return pts;
}

// `variant`: the CDSM_LAYOUT the include is compiled for, -1 none (every layout).
GLuint compile_compute(const std::string& body, int variant) {
  const std::string define = variant >= 0 ? "#define CDSM_LAYOUT " + std::to_string(variant) + "\n" : std::string();
  const std::string src = "#version 450\nlayout(local_size_x = 64) in;\n" + define + glsl_include() + body;
  const GLuint sh = glCreateShader(GL_COMPUTE_SHADER);
  const char* text = src.c_str();
  glShaderSource(sh, 1, &text, nullptr);
  glCompileShader(sh);
  GLint ok = 0;
  glGetShaderiv(sh, GL_COMPILE_STATUS, &ok);
  std::string log(4096, '\0');
  glGetShaderInfoLog(sh, GLsizei(log.size()), nullptr, log.data());
  EXPECT_TRUE(ok) << log.c_str();
  const GLuint prog = glCreateProgram();
  glAttachShader(prog, sh);
  glLinkProgram(prog);
  glDeleteShader(sh);
  glGetProgramiv(prog, GL_LINK_STATUS, &ok);
  EXPECT_TRUE(ok);
  return prog;
}

// Per point and light the transmittance from cdsm.glsl.
const char* const kLookupShader = R"(
layout(std430, binding = 0) readonly buffer Points { vec4 pts[]; };   // xyz, w: 1 a surface, 0 none
layout(std430, binding = 1) readonly buffer Planes { uvec4 planes[]; };  // xyz: the plane's bits, w: the object
layout(std430, binding = 2) writeonly buffer Result { vec4 result[]; };
uniform int u_count;
uniform int u_light;
void main() {
  int i = int(gl_GlobalInvocationID.x);
  if (i >= u_count) return;
  vec4 p = pts[i];
  vec3 t = p.w > 0.5 ? cdsm_surface_transmittance(p.xyz, uintBitsToFloat(planes[i].xyz), planes[i].w, u_light)
                     : cdsm_transmittance(p.xyz, u_light);
  result[i] = vec4(t, 0.0);
}
)";

class GlLookup : public GlTest {
 protected:
  // The GLSL transmittances of `pts` for light `light` of `sys`, from the
  // include compiled for every layout or for layout `variant` only.
  std::vector<Vec3> glsl_lookups(ShadowSystem& sys, const std::vector<LookupPoint>& pts, int light, int variant = -1) {
    GLuint& program_ = programs_[variant];
    if (!program_) program_ = compile_compute(kLookupShader, variant);
    std::vector<float> p4;
    std::vector<uint32_t> n4;
    const auto bits = [](float f) {
      uint32_t u;
      std::memcpy(&u, &f, 4);
      return u;
    };
    for (const LookupPoint& q : pts) {
      p4.insert(p4.end(), {q.p.x, q.p.y, q.p.z, q.surface ? 1.0f : 0.0f});
      n4.insert(n4.end(), {bits(q.plane.x), bits(q.plane.y), bits(q.plane.z), q.object});
    }
    GLuint bufs[3];
    glCreateBuffers(3, bufs);
    glNamedBufferStorage(bufs[0], GLsizeiptr(p4.size() * 4), p4.data(), 0);
    glNamedBufferStorage(bufs[1], GLsizeiptr(n4.size() * 4), n4.data(), 0);
    glNamedBufferStorage(bufs[2], GLsizeiptr(pts.size() * 16), nullptr, 0);
    glUseProgram(program_);
    sys.bind_gl(program_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, bufs[0]);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, bufs[1]);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, bufs[2]);
    glUniform1i(glGetUniformLocation(program_, "u_count"), int(pts.size()));
    glUniform1i(glGetUniformLocation(program_, "u_light"), light);
    glDispatchCompute(GLuint((pts.size() + 63) / 64), 1, 1);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    std::vector<float> out(pts.size() * 4);
    glGetNamedBufferSubData(bufs[2], 0, GLsizeiptr(out.size() * 4), out.data());
    glDeleteBuffers(3, bufs);
    glUseProgram(0);
    EXPECT_EQ(glGetError(), GLenum(GL_NO_ERROR));
    std::vector<Vec3> t(pts.size());
    for (size_t i = 0; i < pts.size(); ++i) t[i] = {out[4 * i], out[4 * i + 1], out[4 * i + 2]};
    return t;
  }

  void TearDown() override {
    for (const auto& [variant, program] : programs_) glDeleteProgram(program);
  }

  // Every light of `scene` at `pts`: GLSL against C++ within 1e-5; with
  // `variant` also the include compiled for the buffers' layout only.
  void expect_agreement(const Scene& scene, int surface, int volume, int free, const char* what, bool variant = false,
                        const std::vector<LookupPoint>& extra = {}) {
    SystemOptions o;
    o.gl_context = GlContextUse::Application;
    o.source = scene.source;
    ShadowSystem sys(o);
    sync_scene(sys, scene);
    sys.update();
    const FrameSnapshot snap(sys);
    std::vector<LookupPoint> pts = sample_points(snap.compiled(), surface, volume, free, 7);
    ASSERT_GE(pts.size(), size_t(surface + free));
    pts.insert(pts.end(), extra.begin(), extra.end());
    const ShadowView sv = snap.shadow_view();
    uint32_t rgb_maps = 0;
    for (const DsmMap& m : sv.maps) rgb_maps += m.rgb;
    EXPECT_EQ(sys.gl_buffers().layout, scene.shadows.layout) << what;
    for (int run = 0; run < (variant ? 2 : 1); ++run)
      for (int l = 0; l < int(sv.lights.size()); ++l) {
        const std::vector<Vec3> g = glsl_lookups(sys, pts, l, run == 0 ? -1 : int(uint32_t(sys.gl_buffers().layout)));
        double worst = 0.0;
        size_t identical = 0, shadowed = 0, worst_at = 0;
        for (size_t i = 0; i < pts.size(); ++i) {
          const LookupPoint& q = pts[i];
          const Receiver r{q.p, q.surface ? q.plane : Vec3{0, 0, 0}, q.surface ? q.object : kNoObject};
          const Vec3 c = one_minus(shadow_alpha(sv, sv.lights[uint32_t(l)], r));
          double d = 0.0;
          for (int k = 0; k < 3; ++k) d = std::max(d, double(std::fabs(c[k] - g[i][k])));
          if (!(d <= worst) || std::isnan(d)) worst = std::isnan(d) ? 1e9 : d, worst_at = i;
          identical += d == 0.0;
          shadowed += min_channel(c) < 0.999f;
        }
        std::printf(
            "[ lookup   ] %s%s light %d: %zu points (%zu shadowed), %u RGB of %zu maps, max |dT| %.3g, %.2f%% "
            "bit-identical\n",
            what, run ? " (CDSM_LAYOUT variant)" : "", l, pts.size(), shadowed, rgb_maps, sv.maps.size(), worst,
            100.0 * double(identical) / double(pts.size()));
        EXPECT_LE(worst, 1e-5) << what << " light " << l << " at point " << worst_at;
        EXPECT_GT(shadowed, pts.size() / 20) << what << ": the points must probe shadows, not only lit space";
      }
  }

  std::map<int, GLuint> programs_;  // by variant
};

TEST_F(GlLookup, DefaultSceneAllLayouts) {
  for (DsmLayout layout : {DsmLayout::Packed, DsmLayout::Fixed, DsmLayout::Chunked}) {
    Scene scene = load_scene(scene_path("default.json"));
    scene.shadows.layout = layout;
    scene.shadows.resolution = 256;
    const char* names[] = {"default packed", "default fixed", "default chunked"};
    expect_agreement(scene, 70000, 25000, 10000, names[int(layout)], true);
  }
}

TEST_F(GlLookup, DefaultSceneClustered) {
  Scene scene = load_scene(scene_path("default.json"));
  scene.shadows.max_clusters = 4;
  scene.shadows.d0 = 0.05f;
  expect_agreement(scene, 70000, 25000, 10000, "default 4 clusters");
}

// Parallel splits: the finest split whose window holds the point, only it.
TEST_F(GlLookup, DefaultSceneParallelSplits) {
  Scene scene = load_scene(scene_path("default.json"));
  scene.shadows.parallel_splits = 3;
  scene.shadows.resolution = 256;
  expect_agreement(scene, 70000, 25000, 10000, "default 3 parallel splits");
}

// Surfaces in contact (DESIGN.md §8): a casting slab under a glass box
// resting 1 mm above it, a pillar with a medium standing through it, a
// decal in its plane, a tinted slab lying on it (RGB maps) — the receiver
// rule (own step by identity, touching surfaces by rank) in GLSL, bit for
// bit, every layout; extra points on the slab under each of them.
TEST_F(GlLookup, SurfacesInContact) {
  for (DsmLayout layout : {DsmLayout::Packed, DsmLayout::Fixed, DsmLayout::Chunked})
    for (bool tinted : {false, true}) {
      Scene scene;
      scene.source = "contact";
      scene.camera.position = {0, 6, 8};
      scene.camera.target = {0, 0, 0};
      const uint32_t slab = cdsm_test::add_surface(scene, "slab", make_ground(8, 8, 0.3f), {0, 0, 0}, 1.0f);
      cdsm_test::add_surface(scene, "glass", make_box({1, 1, 1}), {-2, 0.501f, -2}, 0.45f);
      const uint32_t pillar =
          cdsm_test::add_surface(scene, "pillar", make_box({1, 1, 1}), {2, 0.0008f - 0.5f, -2}, 0.45f);
      scene.objects[pillar].interior = InteriorKind::Constant;
      scene.objects[pillar].sigma = vec3(0.6f);
      cdsm_test::add_surface(scene, "decal", make_quad(1, 1), {-2, 0, 2}, 0.5f);
      const uint32_t lying = cdsm_test::add_surface(scene, "lying slab", make_box({1, 0.1f, 1}), {2, 0.05f, 2}, 0.3f);
      if (tinted) scene.objects[lying].surface.transmission_color = {1.0f, 0.5f, 0.2f};
      scene.lights.push_back(cdsm_test::spot_light({0.5f, 9, 0.4f}, {-0.5f, -9, -0.4f}, 35, 32));
      scene.shadows.layout = layout;
      scene.shadows.resolution = 256;
      std::vector<LookupPoint> extra;
      for (Vec3 c : {Vec3{-2, 0, -2}, Vec3{2, 0, -2}, Vec3{-2, 0, 2}, Vec3{2, 0, 2}})
        for (int i = 0; i < 20; ++i)
          for (int j = 0; j < 20; ++j)
            extra.push_back(
                {c + Vec3{-0.6f + 1.2f * (i + 0.5f) / 20, 0, -0.6f + 1.2f * (j + 0.5f) / 20}, {0, 1, 0}, slab, true});
      const std::string what = std::string("contact ") + (tinted ? "RGB " : "grey ") +
                               (layout == DsmLayout::Packed  ? "packed"
                                : layout == DsmLayout::Fixed ? "fixed"
                                                             : "chunked");
      expect_agreement(scene, 20000, 2000, 2000, what.c_str(), true, extra);
    }
}

// The same contact with the GL rasterizer's fragments (depths up to ~1e-5
// relative off the exact ones): the slab under the glass box resting 1 mm
// above it and under the pillar's cap 0.8 mm above it receives what the
// reference gives, within epsilon + 0.005, and the lit slab is unshadowed.
TEST_F(GlLookup, SurfacesInContactWithGlFragments) {
  Scene scene;
  scene.source = "contact";
  const uint32_t slab = cdsm_test::add_surface(scene, "slab", make_ground(16, 16, 0.3f), {8, 0, 8}, 1.0f);
  cdsm_test::add_surface(scene, "pillar", make_box({1, 1, 1}), {5, 0.0008f - 0.5f, 5}, 0.45f);
  cdsm_test::add_surface(scene, "glass", make_box({1, 1, 1}), {11, 0.501f, 11}, 0.45f);
  scene.lights.push_back(cdsm_test::spot_light({8, 12, 8}, {0, -1, 0}, 40, 36));
  scene.shadows.resolution = 512;
  SystemOptions o;
  o.gl_context = GlContextUse::Application;
  o.fragments = FragmentSource::Gl;
  ShadowSystem sys(o);
  sync_scene(sys, scene);
  sys.update();
  const FrameSnapshot snap(sys);
  const ShadowView sv = snap.shadow_view();
  DsmVisibility vis{sv};
  ReferenceRenderer ref(snap.scene_view(), snap.frame().setup.lights);
  double worst = 0.0, lit = 0.0;
  int n = 0;
  for (Vec3 c : {Vec3{5, 0, 5}, Vec3{11, 0, 11}})
    for (int i = 0; i < 16; ++i)
      for (int j = 0; j < 16; ++j) {
        const Vec3 p = c + Vec3{-0.35f + 0.7f * (i + 0.5f) / 16, 0, -0.35f + 0.7f * (j + 0.5f) / 16};
        const Receiver r{p, {0, 1, 0}, slab};
        worst = std::max(worst, std::fabs(double(grey_of(vis(0, r))) - grey_of(ref.transmittance(0, r))));
        ++n;
      }
  for (float x = 6.5f; x <= 9.5f; x += 0.25f)
    for (float z = 6.5f; z <= 9.5f; z += 0.25f)
      lit = std::max(lit, 1.0 - grey_of(vis(0, Receiver{{x, 0, z}, {0, 1, 0}, slab})));
  std::printf(
      "[ contact  ] GL fragments: slab under the cap and the glass, %d points, max |dT| %.4f; lit slab max %.5f\n", n,
      worst, lit);
  EXPECT_LE(worst, 0.01 + 0.005);
  EXPECT_LE(lit, 1e-3);
}

TEST_F(GlLookup, StainedGlass) {
  Scene scene = load_scene(scene_path("stained_glass.json"));
  expect_agreement(scene, 70000, 25000, 10000, "stained glass");
}

// The sun: orthographic maps (one over every caster; four clusters; and the
// slope-bias baseline, whose light direction is the directional one) read
// by cdsm.glsl as the C++ reads them.
TEST_F(GlLookup, SunGlassAndClusteredSunClouds) {
  Scene glass = load_scene(scene_path("sun_glass.json"));
  glass.shadows.resolution = 512;
  expect_agreement(glass, 70000, 25000, 10000, "sun glass");
  glass.shadows.receiver = ReceiverLookup::SlopeBias;
  expect_agreement(glass, 30000, 10000, 5000, "sun glass, slope bias");
  Scene clouds = load_scene(scene_path("sun_clouds.json"));
  ASSERT_EQ(clouds.shadows.max_clusters, 4);
  clouds.shadows.resolution = 256;
  expect_agreement(clouds, 70000, 25000, 10000, "sun clouds, 4 clusters");
}

// Lights with a size: the soft lookup (blockers searched in the map, the
// filter over the penumbra's disk) and the fixed-kernel baseline, a spot
// light (every layout: the blocker walk reads each), the sun's cone and a
// point light's cube faces.
TEST_F(GlLookup, SoftSpotAndSun) {
  Scene scene = load_scene(scene_path("default.json"));
  scene.lights[0].radius = 0.15f;
  scene.shadows.resolution = 256;
  for (DsmLayout layout : {DsmLayout::Packed, DsmLayout::Fixed, DsmLayout::Chunked}) {
    scene.shadows.layout = layout;
    const char* names[] = {"default, spot radius 0.15, packed", "default, spot radius 0.15, fixed",
                           "default, spot radius 0.15, chunked"};
    expect_agreement(scene, 20000, 8000, 4000, names[int(layout)], layout == DsmLayout::Chunked);
  }
  scene.shadows.layout = DsmLayout::Packed;
  scene.shadows.penumbra = Penumbra::FixedKernel;
  expect_agreement(scene, 20000, 8000, 4000, "default, spot radius 0.15, fixed kernel");
  scene.shadows.penumbra = Penumbra::Estimated;
  scene.shadows.penumbra_taps = 5;  // the budget reaches the shader
  expect_agreement(scene, 20000, 8000, 4000, "default, spot radius 0.15, 5 taps across");
  scene.shadows.penumbra_taps = 11;
  Scene sun = load_scene(scene_path("sun_glass.json"));
  sun.lights[0].angular_diameter_deg = 3.0f;
  sun.shadows.resolution = 512;
  expect_agreement(sun, 20000, 8000, 4000, "sun glass, angular diameter 3");
  // Cube faces: the penumbra's ellipse off each face's axis (to a face's
  // corners, 3 x along the radial).
  Scene omni = load_scene(scene_path("teapot_omni.json"));
  omni.lights[0].radius = 0.1f;
  omni.shadows.resolution = 256;
  expect_agreement(omni, 20000, 8000, 4000, "teapot omni, radius 0.1");
  // Focused cluster maps: off-centre windows (the ellipse from the window's
  // absolute coordinates) and lattices of their own.
  Scene clustered = load_scene(scene_path("default.json"));
  clustered.lights[0].radius = 0.15f;
  clustered.shadows.resolution = 256;
  clustered.shadows.max_clusters = 3;
  expect_agreement(clustered, 20000, 8000, 4000, "default, spot radius 0.15, 3 clusters");
}

TEST_F(GlLookup, OmniCubeFacesAndSlopeBias) {
  Scene scene = load_scene(scene_path("teapot_omni.json"));
  scene.shadows.receiver = ReceiverLookup::SlopeBias;
  scene.shadows.filtering = false;
  expect_agreement(scene, 30000, 10000, 5000, "teapot omni, slope bias, nearest", true);
}

// An index outside the lights shows magenta rather than a plausible value.
TEST_F(GlLookup, UnknownLightIndexIsMagenta) {
  Scene scene = load_scene(scene_path("default.json"));
  SystemOptions o;
  o.gl_context = GlContextUse::Application;
  ShadowSystem sys(o);
  sync_scene(sys, scene);
  sys.update();
  const std::vector<LookupPoint> pts = {{{0, 0.01f, 0}, {0, 1, 0}, kNoObject, true},
                                        {{0, 1, 0}, {0, 0, 0}, kNoObject, false}};
  for (int light : {-1, int(scene.lights.size()), 99}) {
    const std::vector<Vec3> g = glsl_lookups(sys, pts, light);
    for (const Vec3& t : g) {
      EXPECT_EQ(t.x, 1.0f);
      EXPECT_EQ(t.y, 0.0f);
      EXPECT_EQ(t.z, 1.0f);
    }
  }
  // So does an include compiled for a layout the buffers do not hold.
  for (int variant : {1, 2}) {
    const std::vector<Vec3> g = glsl_lookups(sys, pts, 0, variant);
    for (const Vec3& t : g) {
      EXPECT_EQ(t.x, 1.0f) << "CDSM_LAYOUT " << variant << " reading packed maps";
      EXPECT_EQ(t.y, 0.0f) << "CDSM_LAYOUT " << variant << " reading packed maps";
      EXPECT_EQ(t.z, 1.0f) << "CDSM_LAYOUT " << variant << " reading packed maps";
    }
  }
  EXPECT_THROW(sys.gl_light_index(LightHandle{12345}), Error);
  EXPECT_EQ(sys.gl_light_index(sys.lights()[0]), 0);
}

}  // namespace
}  // namespace cdsm::test
