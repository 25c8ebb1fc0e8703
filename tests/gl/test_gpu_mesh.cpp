// Meshes that stay on the GPU (ShadowSystem::add_gpu_object, issue 47 item
// 1): a curtain whose vertices a compute shader moves every frame, read by
// the rasterizer where they are, against the same curtain given on the host
// each frame; and the uses such a mesh refuses by name.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "common/builders.h"
#include "cdsm/error.h"
#include "cdsm/procedural.h"
#include "cdsm/scene_io.h"
#include "cdsm/shadow_system.h"
#include "common/sanitized.h"
#include "backend/exec_shadow_backend.h"
#include "frame_snapshot.h"
#include "gl/fragment_raster.h"
#include "gl/gl_api.h"
#include "gl_test_util.h"
#include "scene_sync.h"
#include "hd/camera_pass.h"

namespace cdsm::test {
namespace {

using cdsm_test::spot_light;
using cdsm_test::surface_object;

// A curtain of kCols x kRows vertices in the application's buffers, laid out
// as an engine might: 32-byte vertices (uv, position, padding) after a
// 64-byte header, 16-bit indices after 6 bytes of something else. A compute
// shader of the application moves it: a wave along x that grows downwards.
constexpr uint32_t kCols = 25, kRows = 9;
constexpr uint32_t kVertices = kCols * kRows;
constexpr uint32_t kTriangles = (kCols - 1) * (kRows - 1) * 2;
constexpr uint64_t kPositionsAt = 64 + 8, kStride = 32, kIndicesAt = 6;

const char* const kWave = R"(#version 450 core
layout(local_size_x = 64) in;
layout(std430, binding = 0) buffer Vertices { float v[]; };
layout(location = 0) uniform float u_time;
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= 225u) return;
  float c = float(i % 25u), r = float(i / 25u);
  float x = -1.2 + 2.4 * c / 24.0, y = 1.8 - 1.4 * r / 8.0;
  float z = 0.3 * sin(2.7 * x + u_time) * (1.8 - y);
  uint f = 18u + 8u * i;  // (64 + 8) / 4 + 32 / 4 * i
  v[f] = x;
  v[f + 1u] = y;
  v[f + 2u] = z;
}
)";

struct Curtain {
  GLuint vbo = 0, ibo = 0, program = 0;
  Curtain() {
    glCreateBuffers(1, &vbo);
    glNamedBufferStorage(vbo, GLsizeiptr(64 + kStride * kVertices), nullptr, GL_DYNAMIC_STORAGE_BIT);
    std::vector<uint16_t> idx(3 + 3 * kTriangles, 0);  // (3 shorts = 6 bytes first)
    size_t k = 3;
    for (uint32_t r = 0; r + 1 < kRows; ++r)
      for (uint32_t c = 0; c + 1 < kCols; ++c) {
        const uint16_t a = uint16_t(r * kCols + c), b = uint16_t(a + 1), d = uint16_t(a + kCols), e = uint16_t(d + 1);
        for (uint16_t q : {a, d, b, b, d, e}) idx[k++] = q;
      }
    glCreateBuffers(1, &ibo);
    glNamedBufferStorage(ibo, GLsizeiptr(idx.size() * 2), idx.data(), 0);
    GLuint cs = glCreateShader(GL_COMPUTE_SHADER);
    glShaderSource(cs, 1, &kWave, nullptr);
    glCompileShader(cs);
    program = glCreateProgram();
    glAttachShader(program, cs);
    glLinkProgram(program);
    glDeleteShader(cs);
    GLint ok = 0;
    glGetProgramiv(program, GL_LINK_STATUS, &ok);
    EXPECT_TRUE(ok) << "the test's wave shader";
  }
  ~Curtain() {
    glDeleteProgram(program);
    glDeleteBuffers(1, &vbo);
    glDeleteBuffers(1, &ibo);
  }
  GlMeshSource source() const {
    return GlMeshSource::indexed(vbo, kStride, kVertices, ibo, GL_UNSIGNED_SHORT, 3 * kTriangles)
        .positions_at(kPositionsAt)
        .indices_at(kIndicesAt);
  }
  // The application's frame: the wave at `time`, written on the GPU.
  void move(float time) const {
    glUseProgram(program);
    glProgramUniform1f(program, 0, time);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, vbo);
    glDispatchCompute((kVertices + 63) / 64, 1, 1);
    glUseProgram(0);
    glMemoryBarrier(GL_ALL_BARRIER_BITS);
  }
  // What the test (not the system) reads back to give the same floats on the host.
  std::shared_ptr<const TriangleMesh> on_host() const {
    std::vector<float> raw((64 + kStride * kVertices) / 4);
    glGetNamedBufferSubData(vbo, 0, GLsizeiptr(raw.size() * 4), raw.data());
    std::vector<uint16_t> idx(3 + 3 * kTriangles);
    glGetNamedBufferSubData(ibo, 0, GLsizeiptr(idx.size() * 2), idx.data());
    auto m = std::make_shared<TriangleMesh>();
    for (uint32_t i = 0; i < kVertices; ++i) {
      const float* p = raw.data() + (kPositionsAt + kStride * i) / 4;
      m->positions.push_back({p[0], p[1], p[2]});
    }
    m->indices.assign(idx.begin() + 3, idx.end());
    return m;
  }
};

// The curtain (translucent, 0.5 per crossing) 0.4 m over a receive-only
// ground and an opaque box 8 m away, both under one spot with two clusters:
// the box's map never holds the curtain.
Scene curtain_scene() {
  Scene s = cdsm_test::empty_scene("curtain");
  TriangleMesh ground = make_box({16.0f, 0.1f, 8.0f});
  s.objects.push_back(surface_object("ground", ground, make_transform({4, -0.05f, 0}, {0, 0, 0}, {1, 1, 1}), 1.0f,
                                     /*casts=*/false));
  s.objects.push_back(
      surface_object("box", make_box({0.6f, 0.6f, 0.6f}), make_transform({8.0f, 0.3f, 0}, {0, 0, 0}, {1, 1, 1}), 1.0f));
  s.lights.push_back(spot_light({4.0f, 6.0f, 4.0f}, {0, -6.0f, -4.0f}, 60.0f, 55.0f));
  s.camera = cdsm_test::camera_at({4.0f, 7.0f, 9.0f}, {4.0f, 0.0f, 0.0f}, 96, 64);
  s.shadows.resolution = 96;
  s.shadows.epsilon = 0.01f;
  s.shadows.max_clusters = 2;
  s.shadows.d0 = 0.0f;  // the curtain and the box apart: the box's maps never see the curtain move
  return s;
}

Object curtain_object() {
  Object o;
  o.name = "curtain";
  o.surface.opacity = 0.5f;
  return o;
}

// The ground's transmittance from light 0 on a grid under the curtain, every
// channel: what a shader looking the maps up would draw there.
std::vector<float> ground_image(const ShadowSystem& sys) {
  const FrameSnapshot snap(sys);
  const ShadowView sv = snap.shadow_view();
  const DsmVisibility vis{sv};
  std::vector<float> img;
  for (int j = 0; j < 40; ++j)
    for (int i = 0; i < 60; ++i) {
      const Vec3 p{-2.0f + 4.0f * (float(i) + 0.5f) / 60.0f, 0.0f, -3.5f + 3.5f * (float(j) + 0.5f) / 40.0f};
      const Vec3 t = vis(0, Receiver(p, {0, 1, 0}, kNoObject));
      img.insert(img.end(), {t.x, t.y, t.z});
    }
  return img;
}

// Every map's header and its texels' nodes (read_map: the nodes texel by
// texel; the storage's own bytes are not compared, since where a texel's
// nodes lie may differ between builds on CPU threads).
std::vector<float> map_nodes(ShadowSystem& sys) {
  auto& backend = dynamic_cast<exec::ExecShadowBackend&>(SystemHooks::backend(sys));
  const FrameSnapshot snap(sys);
  std::vector<float> out;
  for (size_t i = 0; i < snap.frame().maps.size(); ++i) {
    const PinholeView& v = snap.frame().headers[i].view;
    const auto* h = reinterpret_cast<const float*>(&v);
    out.insert(out.end(), h, h + sizeof(PinholeView) / sizeof(float));
    std::vector<uint32_t> counts;
    std::vector<DsmNode> nodes;
    constexpr uint32_t kCap = 64;
    backend.read_map(snap.frame().maps[i], kCap, counts, nodes);
    for (size_t t = 0; t < counts.size(); ++t) {
      out.push_back(float(counts[t]));
      for (uint32_t k = 0; k < std::min(counts[t], kCap); ++k)
        out.insert(out.end(), {nodes[t * kCap + k].z, nodes[t * kCap + k].alpha});
    }
  }
  return out;
}

// The maps a frame planned with `object` among their members.
uint32_t maps_holding(const ShadowSystem& sys, uint32_t object) {
  uint32_t n = 0;
  for (const MapPlan& p : FrameSnapshot(sys).frame().setup.maps)
    n += std::find(p.members.begin(), p.members.end(), object) != p.members.end() ? 1u : 0u;
  return n;
}

class GpuResidentMesh : public GlTest {};

// The rasterizer's gather (gl_mesh_gather.comp) gives the triangles of a
// mesh in application buffers exactly the positions and facing normals an
// upload of the same floats gives them: the same lists, fragment for
// fragment, also under a mirroring transform.
TEST_F(GpuResidentMesh, GatheredTrianglesRasterizeAsUploadedOnes) {
  Curtain curtain;
  curtain.move(0.7f);
  const std::shared_ptr<const TriangleMesh> mesh = curtain.on_host();
  for (const Mat4& model : {Mat4{}, make_transform({0.3f, 0.1f, -0.2f}, {10, 25, 5}, {1.1f, -0.9f, 1.0f})}) {
    SCOPED_TRACE(mirrors(model) ? "mirrored" : "identity");
    TestScene host, placeholder;
    for (int i = 0; i < 24; ++i) {  // another object's triangles first: the mesh starts at triangle 24
      host.add_triangle({50.0f + i, 0, 0}, {51.0f + i, 0, 0}, {50.0f + i, 1, 0}, 0);
      placeholder.add_triangle({50.0f + i, 0, 0}, {51.0f + i, 0, 0}, {50.0f + i, 1, 0}, 0);
    }
    // (the rasterizer's triangles in world space, winding as compile_object gives it)
    const bool flip = mirrors(model);
    for (size_t t = 0; t < mesh->indices.size(); t += 3) {
      const uint32_t a = mesh->indices[t], b = mesh->indices[t + (flip ? 2 : 1)], c = mesh->indices[t + (flip ? 1 : 2)];
      host.add_triangle(model.point(mesh->positions[a]), model.point(mesh->positions[b]),
                        model.point(mesh->positions[c]), 1);
      placeholder.add_triangle({0, 0, 0}, {0, 0, 0}, {0, 0, 0}, 1);
    }
    host.finish();
    placeholder.finish();
    gl::FragmentRasterizer a(context()), b(context());
    host.upload(a);
    placeholder.upload(b);
    gl::FragmentRasterizer::AppMesh m;
    m.vertex_buffer = curtain.vbo;
    m.vertex_offset = kPositionsAt;
    m.vertex_stride = uint32_t(kStride);
    m.vertex_count = kVertices;
    m.index_buffer = curtain.ibo;
    m.index_offset = kIndicesAt;
    m.index_size = 2;
    m.triangles = kTriangles;
    b.gather_mesh(24, m, model, flip);
    const PinholeView v = look_at({0.4f, 2.5f, 4.0f}, {0, 1.0f, 0}, {0, 1, 0}, 50.0f, 128, 96, 0.1f, 50.0f);
    FragmentBuffers fa, fb;
    a.rasterize(v, {}, fa);
    b.rasterize(v, {}, fb);
    EXPECT_GT(fa.total(), 500u);
    EXPECT_EQ(lists_differ(fa, fb), "");
    const Box3 box = b.mesh_bounds(m, model);
    EXPECT_TRUE(std::memcmp(&box, &host.sb.object_bounds[1], sizeof box) == 0)
        << box.lo.x << " " << host.sb.object_bounds[1].lo.x;
  }
}

// 100 frames of a waving curtain (60 under a sanitizer): its shadow follows
// the wave; the ground's transmittance (every frame) and the maps' nodes
// (every 10th) equal those from the same floats given on the host each
// frame; nothing of the mesh is read back or sent; only the curtain's map
// rebuilds, with one host synchronization.
TEST_F(GpuResidentMesh, ACurtainMovedByAComputeShaderCastsTheShadowOfTheHostCurtain) {
  Curtain curtain;
  curtain.move(0.0f);
  const Scene scene = curtain_scene();
  ShadowSystem gpu(app_options()), host(app_options());
  sync_scene(gpu, scene);
  sync_scene(host, scene);
  const ObjectHandle on_gpu = gpu.add_gpu_object(curtain_object(), curtain.source());
  Object given = curtain_object();
  given.mesh = curtain.on_host();
  const ObjectHandle on_host = host.add_object(given);
  const int frames = CDSM_TEST_SANITIZED ? 60 : 100;
  std::vector<float> first;
  uint64_t differ_from_first = 0;
  for (int f = 0; f < frames; ++f) {
    SCOPED_TRACE("frame " + std::to_string(f));
    if (f > 0) {
      curtain.move(0.1f * float(f));
      gpu.mark_changed(on_gpu);
      host.set_mesh(on_host, curtain.on_host());
    }
    FrameStats gs, hs;
    gpu.update(&gs);
    host.update(&hs);
    ASSERT_EQ(gs.fragment_source, "gl");
    EXPECT_EQ(gs.update.gl_readback_bytes, 0u) << "the mesh is never read back";
    if (f > 0) {
      EXPECT_EQ(gs.maps_rebuilt, maps_holding(gpu, 2)) << "the curtain's maps only";
      EXPECT_GE(gs.maps_reused, 1u) << "the box's maps are kept";
      EXPECT_EQ(gs.update.gl_upload_bytes, 0u) << "the curtain's triangles are read where they are, not sent";
      EXPECT_EQ(gs.update.host_to_backend_bytes, 0u) << "nothing of the curtain is sent to the backend either";
      // (read_map's reads after the previous frame count in this one's)
      if ((f - 1) % 10 != 0) {
        EXPECT_EQ(gs.counters.host_syncs, 1u) << "one host synchronization per rebuild frame";
      }
    }
    EXPECT_EQ(gs.maps_rebuilt, hs.maps_rebuilt);
    const std::vector<float> image = ground_image(gpu);
    if (f % 10 == 0) {
      ASSERT_TRUE(map_nodes(gpu) == map_nodes(host)) << "the maps differ from those of the curtain given on the host";
    }
    ASSERT_TRUE(image == ground_image(host)) << "the ground's shadow differs";
    if (f == 0) {
      first = image;
      float darkest = 1.0f;
      for (float t : image) darkest = std::min(darkest, t);
      EXPECT_LT(darkest, 0.6f) << "the curtain shades the ground";
    } else if (image != first) {
      ++differ_from_first;
    }
  }
  EXPECT_GT(differ_from_first, uint64_t(frames) * 9 / 10) << "the shadow follows the wave";
}

// A curtain placed by its object's transform, then moved by set_transform
// (its triangles read again under the new one, also when it mirrors):
// the same shadow as the host's curtain under the same transforms.
TEST_F(GpuResidentMesh, ItsTransformPlacesItAsAHostMesh) {
  Curtain curtain;
  curtain.move(0.5f);
  const Scene scene = curtain_scene();
  ShadowSystem gpu(app_options()), host(app_options());
  sync_scene(gpu, scene);
  sync_scene(host, scene);
  Object o = curtain_object();
  o.transform = make_transform({0.2f, 0.1f, -0.3f}, {0, 20, 0}, {1, 1, 1});
  const ObjectHandle a = gpu.add_gpu_object(o, curtain.source());
  o.mesh = curtain.on_host();
  const ObjectHandle b = host.add_object(o);
  for (const Mat4& t : {make_transform({-0.4f, 0.2f, 0.1f}, {5, -30, 0}, {1.2f, 1, 1}),
                        make_transform({0, 0, 0}, {0, 0, 0}, {-1, 1, 1})}) {
    gpu.update();
    host.update();
    EXPECT_EQ(map_nodes(gpu), map_nodes(host));
    EXPECT_TRUE(ground_image(gpu) == ground_image(host));
    gpu.set_transform(a, t);
    host.set_transform(b, t);
  }
  gpu.update();
  host.update();
  EXPECT_TRUE(ground_image(gpu) == ground_image(host)) << "mirrored";
}

// Bounds given by the application: no bounds read back in a frame (only
// the light views' two reads), the object's box the given one.
TEST_F(GpuResidentMesh, BoundsGivenByTheApplicationReadNothingBack) {
  Curtain curtain;
  curtain.move(0.3f);
  const Scene scene = curtain_scene();
  ShadowSystem sys(app_options());
  sync_scene(sys, scene);
  GpuMeshOptions opt;
  opt.bounds.lo = {-1.2f, 0.4f, -0.45f};
  opt.bounds.hi = {1.2f, 1.8f, 0.45f};
  const ObjectHandle h = sys.add_gpu_object(curtain_object(), curtain.source(), opt);
  sys.update();
  curtain.move(0.4f);
  sys.mark_changed(h);
  FrameStats st;
  sys.update(&st);
  EXPECT_EQ(st.maps_rebuilt, maps_holding(sys, 2));
  EXPECT_EQ(st.update.gl_readback_bytes, 0u);
  EXPECT_EQ(st.counters.gl_readbacks, 2u) << "the light views' offsets and fragments only: no bounds read";
  const FrameSnapshot snap(sys);
  const Box3& b = snap.compiled().object_bounds[2];
  EXPECT_EQ(b.lo.x, -1.2f);
  EXPECT_EQ(b.hi.y, 1.8f);
}

// What a mesh that stays on the GPU cannot do is refused, naming it.
TEST_F(GpuResidentMesh, UsesThatNeedTheTrianglesOnTheHostAreRefusedByName) {
  Curtain curtain;
  curtain.move(0.0f);
  const Scene scene = curtain_scene();
  {
    ShadowSystem sys(app_options());
    sync_scene(sys, scene);
    const ObjectHandle h = sys.add_gpu_object(curtain_object(), curtain.source());
    EXPECT_NE(error_of([&] { sys.render(); }).find("'curtain'"), std::string::npos);
    EXPECT_NE(error_of([&] { sys.render(); }).find("render()"), std::string::npos);
    EXPECT_NE(error_of([&] { sys.render_reference(); }).find("stays on the GPU"), std::string::npos);
    EXPECT_NE(error_of([&] { sys.set_mesh(h, curtain.on_host()); }).find("mark_changed"), std::string::npos);
    EXPECT_NE(error_of([&] {
                sys.set_interior(h, InteriorKind::Constant, {1, 1, 1});
              }).find("interior"),
              std::string::npos);
    EXPECT_NE(error_of([&] { sys.mark_changed(sys.objects()[0]); }).find("add_gpu_object"), std::string::npos);
    Box3 bad;
    bad.lo = {0, 0, 0};
    bad.hi = {1, std::nanf(""), 1};
    EXPECT_NE(error_of([&] { sys.mark_changed(h, &bad); }).find("finite"), std::string::npos);
    const std::string saved = error_of([&] { scene_to_json(FrameSnapshot(sys).scene()); });
    EXPECT_NE(saved.find("/objects/2"), std::string::npos) << saved;
    EXPECT_NE(saved.find("stays on the GPU"), std::string::npos) << saved;
    sys.update();  // (still fine after the refusals)
  }
  {
    ShadowSystem cpu(app_options(FragmentSource::Cpu));
    cpu.add_gpu_object(curtain_object(), curtain.source());
    const std::string e = error_of([&] { cpu.update(); });
    EXPECT_NE(e.find("'curtain'"), std::string::npos) << e;
    EXPECT_NE(e.find("only the GL rasterizer"), std::string::npos) << e;
  }
  {
    SystemOptions own;
    own.gl_context = GlContextUse::Own;
    ShadowSystem sys(own);
    EXPECT_NE(
        error_of([&] { sys.add_gpu_object(curtain_object(), curtain.source()); }).find("GlContextUse::Application"),
        std::string::npos);
    SystemOptions priv = app_options();
    priv.private_fragment_context = true;
    ShadowSystem p(priv);
    EXPECT_NE(error_of([&] { p.add_gpu_object(curtain_object(), curtain.source()); }).find("private_fragment_context"),
              std::string::npos);
  }
  {
    ShadowSystem sys(app_options());
    GlMeshSource s = curtain.source();
    s.vertex_offset = 70;  // not a multiple of 4
    EXPECT_NE(error_of([&] { sys.add_gpu_object(curtain_object(), s); }).find("multiples of 4"), std::string::npos);
    s = curtain.source();
    s.index_count = 3 * (kTriangles + 1000);  // past the index buffer
    EXPECT_NE(error_of([&] { sys.add_gpu_object(curtain_object(), s); }).find("index buffer"), std::string::npos);
    Object o = curtain_object();
    o.interior = InteriorKind::Constant;
    EXPECT_NE(error_of([&] { sys.add_gpu_object(o, curtain.source()); }).find("interior"), std::string::npos);
  }
}

}  // namespace
}  // namespace cdsm::test
