// A ShadowSystem on the application's GL context (GlContextUse::Application):
// the GL state it must leave as it found it, the map uploads it counts
// (nothing when nothing changed, only new maps' nodes otherwise), meshes
// read from application buffers, and every misuse as a clear error.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "cdsm/error.h"
#include "cdsm/gl.h"
#include "cdsm/procedural.h"
#include "cdsm/scene_io.h"
#include "cdsm/shadow_system.h"
#include "backend/exec_backend.h"
#include "exec/host_exec.h"
#include "gl/gl_api.h"
#include "gl/map_buffers.h"
#include "gl_host_exec.h"
#include "gl_test_util.h"
#include "frame.h"
#include "frame_snapshot.h"
#include "scene_sync.h"

namespace cdsm::test {
namespace {

std::string scene_path(const std::string& name) { return std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/" + name; }

// Every piece of state the system promises to restore, as one comparable record.
struct GlStateSnapshot {
  GLint program, vao, draw_fbo, read_fbo, viewport[4], scissor[4], polygon[2], ssbo_generic;
  GLboolean mask[4], caps[8];
  GLint ssbo[8];
  GLint64 ssbo_start[8], ssbo_size[8];
  static GlStateSnapshot take() {
    GlStateSnapshot s{};
    glGetIntegerv(GL_CURRENT_PROGRAM, &s.program);
    glGetIntegerv(GL_VERTEX_ARRAY_BINDING, &s.vao);
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &s.draw_fbo);
    glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &s.read_fbo);
    glGetIntegerv(GL_VIEWPORT, s.viewport);
    glGetIntegerv(GL_SCISSOR_BOX, s.scissor);
    glGetIntegerv(GL_POLYGON_MODE, s.polygon);
    glGetBooleani_v(GL_COLOR_WRITEMASK, 0, s.mask);
    const GLenum caps[8] = {GL_SCISSOR_TEST, GL_DEPTH_CLAMP, GL_CLIP_DISTANCE0,     GL_DEPTH_TEST,
                            GL_CULL_FACE,    GL_BLEND,       GL_RASTERIZER_DISCARD, GL_MULTISAMPLE};
    for (int i = 0; i < 8; ++i) s.caps[i] = glIsEnabled(caps[i]);
    glGetIntegerv(GL_SHADER_STORAGE_BUFFER_BINDING, &s.ssbo_generic);
    for (GLuint i = 0; i < 8; ++i) {
      glGetIntegeri_v(GL_SHADER_STORAGE_BUFFER_BINDING, i, &s.ssbo[i]);
      glGetInteger64i_v(GL_SHADER_STORAGE_BUFFER_START, i, &s.ssbo_start[i]);
      glGetInteger64i_v(GL_SHADER_STORAGE_BUFFER_SIZE, i, &s.ssbo_size[i]);
    }
    return s;
  }
  bool operator==(const GlStateSnapshot& o) const { return std::memcmp(this, &o, sizeof *this) == 0; }
};

class GlSystem : public GlTest {};

TEST_F(GlSystem, LeavesTheApplicationsGlStateAsItFoundIt) {
  // The application's state: its own program, vertex array, framebuffer,
  // storage buffers in every low binding, non-default switches.
  GLuint vs = glCreateShader(GL_VERTEX_SHADER);
  const char* src = "#version 450\nvoid main() { gl_Position = vec4(0.0); }\n";
  glShaderSource(vs, 1, &src, nullptr);
  glCompileShader(vs);
  GLuint prog = glCreateProgram();
  glAttachShader(prog, vs);
  glLinkProgram(prog);
  GLuint vao, fbo, tex, bufs[8];
  glCreateVertexArrays(1, &vao);
  glCreateFramebuffers(1, &fbo);
  glCreateTextures(GL_TEXTURE_2D, 1, &tex);
  glTextureStorage2D(tex, 1, GL_RGBA8, 64, 64);
  glNamedFramebufferTexture(fbo, GL_COLOR_ATTACHMENT0, tex, 0);
  glCreateBuffers(8, bufs);
  for (GLuint i = 0; i < 8; ++i) {
    glNamedBufferStorage(bufs[i], 4096, nullptr, 0);
    if (i % 2)
      glBindBufferRange(GL_SHADER_STORAGE_BUFFER, i, bufs[i], 256, 512);
    else
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, i, bufs[i]);
  }
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, bufs[5]);
  glUseProgram(prog);
  glBindVertexArray(vao);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  glViewport(3, 5, 37, 41);
  glScissor(1, 2, 30, 20);
  glEnable(GL_SCISSOR_TEST);
  glEnable(GL_DEPTH_TEST);
  glEnable(GL_CULL_FACE);
  glEnable(GL_BLEND);
  glDisable(GL_MULTISAMPLE);
  glColorMaski(0, GL_TRUE, GL_FALSE, GL_TRUE, GL_FALSE);
  glPolygonMode(GL_FRONT_AND_BACK, GL_LINE);
  ASSERT_EQ(glGetError(), GLenum(GL_NO_ERROR));
  const GlStateSnapshot before = GlStateSnapshot::take();

  Scene scene = load_scene(scene_path("default.json"));
  scene.camera.width = 96;
  scene.camera.height = 64;
  scene.shadows.resolution = 128;
  ShadowSystem sys(app_options());
  sync_scene(sys, scene);
  FrameStats st;
  sys.update(&st);
  EXPECT_EQ(st.fragment_source, "gl");
  EXPECT_TRUE(GlStateSnapshot::take() == before) << "update() changed the application's GL state";
  sys.render(&st);  // camera fragments rasterized on the same context
  EXPECT_TRUE(GlStateSnapshot::take() == before) << "render() changed the application's GL state";
  auto mesh = std::make_shared<TriangleMesh>(make_box({1, 1, 1}));
  GLuint vb;
  glCreateBuffers(1, &vb);
  glNamedBufferStorage(vb, GLsizeiptr(mesh->positions.size() * 12), mesh->positions.data(), 0);
  GlMeshSource m;
  m.vertex_buffer = vb;
  m.vertex_count = uint32_t(mesh->positions.size());
  GLuint ib;
  glCreateBuffers(1, &ib);
  glNamedBufferStorage(ib, GLsizeiptr(mesh->indices.size() * 4), mesh->indices.data(), 0);
  m.index_buffer = ib;
  m.index_count = uint32_t(mesh->indices.size());
  sys.read_gl_mesh(m);
  EXPECT_TRUE(GlStateSnapshot::take() == before) << "read_gl_mesh() changed the application's GL state";

  // A GL error the application left pending is cleared and reported, not
  // blamed on the system's own calls.
  glBindBuffer(0xdead, 0);
  sys.set_camera(scene.camera);
  sys.update(&st);
  ASSERT_FALSE(st.warnings.empty());
  EXPECT_NE(st.warnings.back().find("GL_INVALID_ENUM"), std::string::npos) << st.warnings.back();
  EXPECT_EQ(glGetError(), GLenum(GL_NO_ERROR));

  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glUseProgram(0);
  glBindVertexArray(0);
  glDisable(GL_SCISSOR_TEST);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glDisable(GL_BLEND);
  glEnable(GL_MULTISAMPLE);
  glColorMaski(0, GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
  glDeleteBuffers(8, bufs);
  glDeleteBuffers(1, &vb);
  glDeleteBuffers(1, &ib);
  glDeleteTextures(1, &tex);
  glDeleteFramebuffers(1, &fbo);
  glDeleteVertexArrays(1, &vao);
  glDeleteProgram(prog);
  glDeleteShader(vs);
}

// Maps reach GL once: a frame in which nothing changed uploads nothing; a
// moved light uploads its new maps' nodes (appended) and the frame block.
TEST_F(GlSystem, UploadsOnlyWhatChanged) {
  Scene scene = load_scene(scene_path("teapot_omni.json"));
  scene.shadows.resolution = 128;
  ShadowSystem sys(app_options(FragmentSource::Cpu));
  sync_scene(sys, scene);
  FrameStats first, again, moved;
  sys.update(&first);
  const FrameSnapshot snap(sys);
  const DsmStorage s0 = snap.backend().storage();
  const uint64_t arrays0 = (s0.grey.texels.size() + s0.rgb.texels.size()) * 8 + s0.grey.nodes.size() * 8 +
                           s0.rgb.nodes.size() * 16 + s0.grey.chunks.size() * 12 + s0.rgb.chunks.size() * 20 +
                           (s0.grey.tags.size() + s0.rgb.tags.size()) * 2;
  const uint64_t frame_block = sizeof(gl::FrameBlockHeader) + sizeof(DsmMap) * snap.frame().headers.size();
  EXPECT_TRUE(first.update.gl_map_full_upload);
  EXPECT_EQ(first.update.gl_map_upload_bytes, arrays0 + frame_block);
  EXPECT_GE(first.update.gl_map_bytes, arrays0 + frame_block);

  sys.set_camera(scene.camera);  // the same camera: no map changes
  sys.update(&again);
  EXPECT_EQ(again.maps_rebuilt, 0u);
  EXPECT_EQ(again.update.gl_map_upload_bytes, 0u);
  EXPECT_FALSE(again.update.gl_map_full_upload);

  const auto array_bytes = [](const DsmStorage& d) {
    return (d.grey.texels.size() + d.rgb.texels.size()) * 8 + d.grey.nodes.size() * 8 + d.rgb.nodes.size() * 16 +
           d.grey.chunks.size() * 12 + d.rgb.chunks.size() * 20 + (d.grey.tags.size() + d.rgb.tags.size()) * 2;
  };
  // A spot light is added: its map is appended to the buffers.
  ASSERT_EQ(scene.lights[0].type, LightType::Spot);
  Light l = scene.lights[0];
  l.position = l.position + Vec3{-2.0f, 0, 0};
  sys.add_light(l);
  sys.update(&moved);
  ASSERT_EQ(moved.maps_rebuilt, 1u);
  ASSERT_FALSE(moved.update.gl_map_full_upload);
  const DsmStorage s1 = snap.backend().storage();
  const uint64_t frame1 = sizeof(gl::FrameBlockHeader) + sizeof(DsmMap) * snap.frame().headers.size();
  EXPECT_EQ(moved.update.gl_map_upload_bytes, array_bytes(s1) - arrays0 + frame1);
  // The omni light (six maps) moves: the holes its old maps leave exceed a
  // quarter of the store, which compacts. The first spot's map, first in
  // the store, stays where it is and is not sent again (issue 45 item 5);
  // the added spot's map moved down and the six new maps are sent. (Every
  // array was sent whole before.)
  FrameStats omni;
  Light o = scene.lights[1];
  o.position = o.position + Vec3{0.05f, 0, 0};
  sys.set_light(sys.lights()[1], o);
  const uint64_t compactions = snap.backend().map_store().compactions;
  sys.update(&omni);
  ASSERT_EQ(omni.maps_rebuilt, 6u);
  EXPECT_EQ(snap.backend().map_store().compactions, compactions + 1);
  EXPECT_FALSE(omni.update.gl_map_full_upload);
  const DsmStorage s2 = snap.backend().storage();
  // The first spot's map alone: its bytes in each array.
  Scene spot_only = scene;
  spot_only.lights.resize(1);
  ShadowSystem solo(app_options(FragmentSource::Cpu));
  sync_scene(solo, spot_only);
  solo.update();
  const uint64_t spot0 = array_bytes(FrameSnapshot(solo).backend().storage());
  ASSERT_GT(spot0, 0u);
  EXPECT_EQ(omni.update.gl_map_upload_bytes, array_bytes(s2) - spot0 + frame1);
  std::printf(
      "[ uploads  ] first %llu B (full), unchanged %llu B, spot added %llu B (appended), omni moved %llu B (compacted, "
      "%llu B of the store kept)\n",
      (unsigned long long)first.update.gl_map_upload_bytes, (unsigned long long)again.update.gl_map_upload_bytes,
      (unsigned long long)moved.update.gl_map_upload_bytes, (unsigned long long)omni.update.gl_map_upload_bytes,
      (unsigned long long)spot0);

  // The GL buffers hold exactly the backend's arrays.
  const GlMapBuffers b = sys.gl_buffers();
  std::vector<unsigned char> gl_nodes(s2.grey.nodes.size() * 8), gl_texels(s2.grey.texels.size() * 8);
  glGetNamedBufferSubData(b.nodes, 0, GLsizeiptr(gl_nodes.size()), gl_nodes.data());
  glGetNamedBufferSubData(b.texels, 0, GLsizeiptr(gl_texels.size()), gl_texels.data());
  EXPECT_EQ(std::memcmp(gl_nodes.data(), s2.grey.nodes.data(), gl_nodes.size()), 0);
  EXPECT_EQ(std::memcmp(gl_texels.data(), s2.grey.texels.data(), gl_texels.size()), 0);
}

// A mesh given through the application's buffers (interleaved, 16-bit
// indices at an offset) is the mesh given as arrays: the same maps, node
// for node; the bytes read back are counted once, never per frame.
TEST_F(GlSystem, MeshFromApplicationBuffersEqualsArrays) {
  auto mesh = std::make_shared<const TriangleMesh>(make_sphere(0.6f, 24, 12));
  ASSERT_LT(mesh->positions.size(), 65536u);
  // position + normal + a 4-byte attribute the system must skip
  const uint32_t stride = 28;
  std::vector<unsigned char> vbo(64 + mesh->positions.size() * stride, 0xab);
  for (size_t i = 0; i < mesh->positions.size(); ++i) {
    std::memcpy(vbo.data() + 64 + i * stride, &mesh->positions[i], 12);
    std::memcpy(vbo.data() + 64 + i * stride + 12, &mesh->normals[i], 12);
  }
  std::vector<uint16_t> ibo(8, 0);
  for (uint32_t v : mesh->indices) ibo.push_back(uint16_t(v));
  GLuint vb, ib;
  glCreateBuffers(1, &vb);
  glCreateBuffers(1, &ib);
  glNamedBufferStorage(vb, GLsizeiptr(vbo.size()), vbo.data(), 0);
  glNamedBufferStorage(ib, GLsizeiptr(ibo.size() * 2), ibo.data(), 0);
  // The named form, with counts as GL takes them (GLsizei).
  const GLsizei vertex_count = GLsizei(mesh->positions.size()), index_count = GLsizei(mesh->indices.size());
  const GlMeshSource src = GlMeshSource::indexed(vb, stride, vertex_count, ib, GL_UNSIGNED_SHORT, index_count)
                               .positions_at(64)
                               .indices_at(16)
                               .normals(vb, 64 + 12, stride);
  EXPECT_EQ(src.vertex_count, uint32_t(mesh->positions.size()));
  EXPECT_EQ(src.index_count, uint32_t(mesh->indices.size()));
  EXPECT_EQ(src.normal_stride, stride);
  EXPECT_THROW(GlMeshSource::indexed(vb, stride, -3, ib, GL_UNSIGNED_SHORT, index_count), Error);

  auto build = [&](bool from_gl, FrameStats& st) {
    ShadowSystem sys(app_options());
    Object ground;
    ground.mesh = std::make_shared<const TriangleMesh>(make_box({4, 0.1f, 4}));
    ground.casts_shadows = false;
    sys.add_object(ground);
    Object ball;
    ball.mesh = from_gl ? sys.read_gl_mesh(src) : mesh;
    ball.transform = make_transform({0, 1, 0}, {0, 0, 0}, {1, 1, 1});
    ball.surface.opacity = 0.5f;
    sys.add_object(ball);
    Light spot;
    spot.position = {0, 4, 0};
    sys.add_light(spot);
    ShadowSettings s;
    s.resolution = 96;
    sys.set_settings(s);
    sys.update(&st);
    // Texel by texel (the pool's order follows the tiles' reservations).
    const FrameSnapshot snap(sys);
    const DsmStorage d = snap.backend().storage();
    std::vector<DsmNode> nodes;
    for (const DsmMap& m : snap.frame().headers)
      for (int ty = 0; ty < int(m.res); ++ty)
        for (int tx = 0; tx < int(m.res); ++tx) {
          DsmNode buf[256];
          const uint32_t n = read_texel(d, m, tx, ty, buf, 256);
          nodes.push_back({float(n), -1.0f});
          nodes.insert(nodes.end(), buf, buf + std::min(n, 256u));
        }
    return nodes;
  };
  FrameStats a, g;
  const std::vector<DsmNode> from_arrays = build(false, a), from_gl = build(true, g);
  ASSERT_EQ(from_arrays.size(), from_gl.size());
  EXPECT_EQ(std::memcmp(from_arrays.data(), from_gl.data(), from_gl.size() * sizeof(DsmNode)), 0);
  const uint64_t expect = (uint64_t(src.vertex_count - 1) * stride + 12) * 2 + uint64_t(src.index_count) * 2;
  EXPECT_EQ(g.update.gl_readback_bytes, expect);
  EXPECT_EQ(a.update.gl_readback_bytes, 0u);
  glDeleteBuffers(1, &vb);
  glDeleteBuffers(1, &ib);
}

TEST_F(GlSystem, AnEmptySystemUpdatesAndPublishesNoMaps) {
  ShadowSystem sys(app_options());
  EXPECT_NE(error_of([&] { sys.bind_gl(1); }).find("call update() first"), std::string::npos);
  FrameStats st;
  EXPECT_EQ(error_of([&] { sys.update(&st); }), "no error") << "an empty level is valid";
  EXPECT_EQ(st.maps_rebuilt, 0u);
  EXPECT_NE(sys.gl_buffers().frame, 0u) << "the frame block exists (no lights, no maps) for shaders to read";
  // A shader binds and reads the empty frame: no lights, and a light index
  // outside them answers cdsm.glsl's magenta.
  const std::string src = "#version 450\nlayout(local_size_x = 1) in;\n" + glsl_include() +
                          "layout(std430, binding = 0) buffer B { vec4 x[]; };\n"
                          "void main() { x[0] = vec4(cdsm_transmittance(vec3(0.0), 0), float(cdsm_light_count())); }\n";
  const char* t = src.c_str();
  const GLuint sh = glCreateShader(GL_COMPUTE_SHADER);
  glShaderSource(sh, 1, &t, nullptr);
  glCompileShader(sh);
  const GLuint program = glCreateProgram();
  glAttachShader(program, sh);
  glLinkProgram(program);
  glDeleteShader(sh);
  EXPECT_EQ(error_of([&] { sys.bind_gl(program); }), "no error");
  GLuint out = 0;
  glCreateBuffers(1, &out);
  const float init[4] = {-1, -1, -1, -1};
  glNamedBufferData(out, sizeof init, init, GL_DYNAMIC_READ);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, out);
  glUseProgram(program);
  glDispatchCompute(1, 1, 1);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  float got[4] = {0, 0, 0, 0};
  glGetNamedBufferSubData(out, 0, sizeof got, got);
  glUseProgram(0);
  EXPECT_EQ(got[3], 0.0f) << "cdsm_light_count()";
  EXPECT_EQ(got[0], 1.0f);
  EXPECT_EQ(got[1], 0.0f);
  EXPECT_EQ(got[2], 1.0f);
  glDeleteBuffers(1, &out);
  glDeleteProgram(program);
}

TEST_F(GlSystem, AnotherOrNoContextCurrentIsAnError) {
  Scene scene = load_scene(scene_path("primitives.json"));
  scene.shadows.resolution = 64;
  ShadowSystem sys(app_options());
  sync_scene(sys, scene);
  sys.update();
  {
    std::string why;
    auto other = gl::create_headless_context({}, &why);  // current now
    ASSERT_TRUE(other) << why;
    const std::string e = error_of([&] { sys.update(); });
    EXPECT_NE(e.find("another OpenGL context is current"), std::string::npos) << e;
    other->release();
    const std::string none = error_of([&] { sys.update(); });
    EXPECT_NE(none.find("no OpenGL context is current"), std::string::npos) << none;
    EXPECT_NE(error_of([&] { sys.bind_gl(1); }).find("no OpenGL context is current"), std::string::npos);
  }
  context().make_current();
  FrameStats st;
  sys.update(&st);  // the system works again on its own context
  EXPECT_EQ(st.fragment_source, "gl");

  // Created without a current context: refused at construction.
  context().release();
  EXPECT_NE(error_of([&] { ShadowSystem s(app_options()); }).find("needs the application's OpenGL 4.5 context current"),
            std::string::npos);
  context().make_current();
}

TEST_F(GlSystem, BadApplicationBuffersAreNamedErrors) {
  ShadowSystem sys(app_options());
  const float tri[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  GLuint vb, ib;
  glCreateBuffers(1, &vb);
  glNamedBufferStorage(vb, sizeof tri, tri, 0);
  const uint32_t idx[3] = {0, 1, 7};
  glCreateBuffers(1, &ib);
  glNamedBufferStorage(ib, sizeof idx, idx, 0);
  GlMeshSource s;
  s.vertex_buffer = vb;
  s.vertex_count = 3;
  EXPECT_EQ(sys.read_gl_mesh(s)->indices.size(), 3u);  // the good case

  GlMeshSource big = s;
  big.vertex_count = 4;
  EXPECT_NE(error_of([&] { sys.read_gl_mesh(big); }).find("holds 36 bytes"), std::string::npos);
  GlMeshSource off = s;
  off.vertex_offset = 8;
  EXPECT_NE(error_of([&] { sys.read_gl_mesh(off); }).find("need 44"), std::string::npos);
  GlMeshSource stride = s;
  stride.vertex_stride = 8;
  EXPECT_NE(error_of([&] { sys.read_gl_mesh(stride); }).find("stride 8"), std::string::npos);
  GlMeshSource bad_name = s;
  bad_name.vertex_buffer = 987654;
  EXPECT_NE(error_of([&] { sys.read_gl_mesh(bad_name); }).find("is not a GL buffer"), std::string::npos);
  GlMeshSource type = s;
  type.index_buffer = ib;
  type.index_count = 3;
  type.index_type = GL_FLOAT;
  EXPECT_NE(error_of([&] { sys.read_gl_mesh(type); }).find("index_type 0x1406"), std::string::npos);
  GlMeshSource range = type;
  range.index_type = GL_UNSIGNED_INT;
  EXPECT_NE(error_of([&] { sys.read_gl_mesh(range); }).find("index 2 is 7, past the 3 vertices"), std::string::npos);
  GlMeshSource count = range;
  count.index_count = 4;
  EXPECT_NE(error_of([&] { sys.read_gl_mesh(count); }).find("not a multiple of 3"), std::string::npos);
  const float nan_tri[9] = {0, 0, 0, NAN, 0, 0, 0, 1, 0};
  glNamedBufferSubData(vb, 0, 0, nullptr);
  GLuint nb;
  glCreateBuffers(1, &nb);
  glNamedBufferStorage(nb, sizeof nan_tri, nan_tri, 0);
  GlMeshSource nan = s;
  nan.vertex_buffer = nb;
  EXPECT_NE(error_of([&] { sys.read_gl_mesh(nan); }).find("vertex 1 is not finite"), std::string::npos);
  glDeleteBuffers(1, &vb);
  glDeleteBuffers(1, &ib);
  glDeleteBuffers(1, &nb);

  // Without the application's context the GL calls are refused by name.
  ShadowSystem own;
  EXPECT_NE(error_of([&] { own.read_gl_mesh(s); }).find("GlContextUse::Application"), std::string::npos);
  EXPECT_NE(error_of([&] { own.bind_gl(1); }).find("GlContextUse::Application"), std::string::npos);
  EXPECT_THROW(own.gl_buffers(), Error);
}

TEST_F(GlSystem, ProgramsWithoutTheBlocksAreRefused) {
  Scene scene = load_scene(scene_path("primitives.json"));
  scene.shadows.resolution = 64;
  ShadowSystem sys(app_options(FragmentSource::Cpu));
  sync_scene(sys, scene);
  sys.update();
  auto program = [](const std::string& body) {
    const std::string src = "#version 450\nlayout(local_size_x = 1) in;\n" + body;
    const char* t = src.c_str();
    GLuint sh = glCreateShader(GL_COMPUTE_SHADER);
    glShaderSource(sh, 1, &t, nullptr);
    glCompileShader(sh);
    GLuint p = glCreateProgram();
    glAttachShader(p, sh);
    glLinkProgram(p);
    glDeleteShader(sh);
    return p;
  };
  const GLuint plain = program("layout(std430, binding = 0) buffer B { float x[]; };\nvoid main() { x[0] = 1.0; }\n");
  std::string e = error_of([&] { sys.bind_gl(plain); });
  EXPECT_NE(e.find("lacks the storage blocks CdsmFrame, CdsmTexels"), std::string::npos) << e;
  EXPECT_NE(e.find("share/cdsm/shaders/cdsm.glsl"), std::string::npos) << "names the installed file: " << e;
  EXPECT_NE(error_of([&] { sys.bind_gl(0); }).find("is not a GL program"), std::string::npos);
  EXPECT_NE(error_of([&] { sys.bind_gl(424242); }).find("is not a GL program"), std::string::npos);
  // The good case: a program that calls the lookup binds at its own base.
  const GLuint good = program("#define CDSM_BINDING_BASE 1\n" + glsl_include() +
                              "layout(std430, binding = 0) buffer B { vec4 x[]; };\n"
                              "void main() { x[0] = vec4(cdsm_transmittance(vec3(0.0), 0), 1.0); }\n");
  sys.bind_gl(good);
  GLint bound = 0;
  glGetIntegeri_v(GL_SHADER_STORAGE_BUFFER_BINDING, 1, &bound);
  EXPECT_EQ(GLuint(bound), sys.gl_buffers().frame);
  glGetIntegeri_v(GL_SHADER_STORAGE_BUFFER_BINDING, 7, &bound);
  EXPECT_EQ(GLuint(bound), sys.gl_buffers().rgb_chunks);
  for (GLuint p : {plain, good}) glDeleteProgram(p);
}

// Maps larger than one storage block are refused with the sizes, not cut.
TEST_F(GlSystem, MapsBeyondTheStorageBlockLimitAreRefused) {
  Scene scene = load_scene(scene_path("primitives.json"));
  scene.shadows.resolution = 256;
  ShadowSystem sys(app_options(FragmentSource::Cpu));
  sync_scene(sys, scene);
  SystemHooks::limit_gl_map_block(sys, 64 * 1024);  // 256^2 texel headers need 512 KiB
  const std::string e = error_of([&] { sys.update(); });
  EXPECT_NE(e.find("CdsmTexels"), std::string::npos) << e;
  EXPECT_NE(e.find("GL_MAX_SHADER_STORAGE_BLOCK_SIZE"), std::string::npos) << e;
  SystemHooks::limit_gl_map_block(sys, 0);
  sys.set_camera(scene.camera);
  sys.update();  // the driver's real limit (128 MiB on llvmpipe) holds them
}

// ---- Who writes the map arrays into GL (ShadowBackend::write_gl_maps) ----

// A stand-in for a backend whose store lives where the GL buffers do (the
// cuda backend with the context on its device, tests/gpu/test_gl_interop.cpp
// on a GPU): it says it can write the map buffers, gets the ranges
// engine/gl/map_buffers.h decided and writes them itself (here from its
// inner cpu backend's arrays with glNamedBufferSubData). Its storage_extent()
// has no data: nothing on the device path may read bytes through it. Like
// CudaExec's GL links it keeps a registry of the buffers it wrote (name ->
// buffer generation) that gl_buffer_released empties; a release of a name
// GL no longer knows, or a known name written under a new generation (the
// old object deleted unannounced, the name reused), is a violation. It
// takes no GL fragment lists (lists_from_gl: the exec backend's own, on
// GlHostExec below): its tests make their fragments on the CPU.
class InPlaceBackend final : public ShadowBackend {
 public:
  explicit InPlaceBackend(std::unique_ptr<ShadowBackend> inner) : inner_(std::move(inner)) {}
  const char* name() const override { return "in-place test double"; }
  void update_scene(const SceneBuffers& sb, const SceneChange& c) override { inner_->update_scene(sb, c); }
  ListsId cast_lists(const PinholeView& v, ObjectMask m) override { return inner_->cast_lists(v, m); }
  ListsId adopt_lists(FragmentBuffers&& f) override { return inner_->adopt_lists(std::move(f)); }
  ListsId copy_lists(ListsId id) override { return inner_->copy_lists(id); }
  void free_lists(ListsId id) override { inner_->free_lists(id); }
  uint64_t lists_fragments(ListsId id) const override { return inner_->lists_fragments(id); }
  uint64_t lists_bytes(ListsId id) const override { return inner_->lists_bytes(id); }
  void read_lists(ListsId id, FragmentBuffers& out) override { inner_->read_lists(id, out); }
  MapId build_map(const LightPassParams& p, ListsId f, const DsmLayoutParams& l, DsmBuildStats& st) override {
    return inner_->build_map(p, f, l, st);
  }
  void free_map(MapId id) override { inner_->free_map(id); }
  void free_maps(const std::vector<MapId>& ids) override { inner_->free_maps(ids); }
  DsmMap map_header(MapId id) const override { return inner_->map_header(id); }
  DsmStorage storage() const override { return inner_->storage(); }
  uint64_t storage_epoch() const override { return inner_->storage_epoch(); }
  void storage_kept_bytes(uint64_t since, uint64_t* kept) const override { inner_->storage_kept_bytes(since, kept); }
  DsmStorage storage_extent() const override { return storage_sizes(inner_->storage()); }
  void camera_pass(const ShadowView& v, const CameraPassParams& p, ListsId f, std::vector<float>& rgb,
                   WalkStats& w) override {
    inner_->camera_pass(v, p, f, rgb, w);
  }
  MapStoreStats map_store() const override { return inner_->map_store(); }
  std::vector<exec::StageTime> take_stage_times() override { return inner_->take_stage_times(); }
  exec::ExecCounters take_counters() override { return inner_->take_counters(); }

  bool can_write_gl_maps() const override { return true; }
  void write_gl_maps(const GlMapWrite* w, int n) override {
    if (fail_next) {
      fail_next = false;
      throw std::runtime_error("in-place test double: write failed");
    }
    const DsmStorage s = inner_->storage();
    const void* src[kStorageArrays] = {s.grey.texels.data(), s.grey.nodes.data(), s.grey.chunks.data(),
                                       s.rgb.texels.data(),  s.rgb.nodes.data(),  s.rgb.chunks.data(),
                                       s.grey.tags.data(),   s.rgb.tags.data()};
    static_assert(kStorageArrays == 8, "one source per storage array");
    for (int i = 0; i < n; ++i) {
      const auto known = registered.find(w[i].gl_buffer);
      if (known != registered.end() && known->second != w[i].gl_buffer_generation)
        violations.push_back("buffer " + std::to_string(w[i].gl_buffer) +
                             " written under a new generation, never released");
      registered[w[i].gl_buffer] = w[i].gl_buffer_generation;
      GLint64 size = 0;
      glGetNamedBufferParameteri64v(w[i].gl_buffer, GL_BUFFER_SIZE, &size);
      ASSERT_EQ(uint64_t(size), w[i].gl_buffer_bytes);
      ASSERT_LE(w[i].offset + w[i].bytes, w[i].gl_buffer_bytes);
      glNamedBufferSubData(w[i].gl_buffer, GLintptr(w[i].offset), GLsizeiptr(w[i].bytes),
                           static_cast<const unsigned char*>(src[int(w[i].array)]) + w[i].offset);
      ++writes;
    }
  }
  void gl_buffer_released(uint32_t name) override {
    ++releases;
    if (!glIsBuffer(name)) violations.push_back("buffer " + std::to_string(name) + " released after GL deleted it");
    registered.erase(name);
  }
  uint64_t writes = 0, releases = 0;
  bool fail_next = false;
  std::map<uint32_t, uint64_t> registered;  // GL name -> gl_buffer_generation
  std::vector<std::string> violations;

 private:
  std::unique_ptr<ShadowBackend> inner_;
};

// `sys`'s backend wrapped in an InPlaceBackend (its fragment producer
// follows); the wrapper, owned by the system.
InPlaceBackend* use_in_place_backend(ShadowSystem& sys) {
  InPlaceBackend* ip = nullptr;
  SystemHooks::wrap_backend(sys, [&](std::unique_ptr<ShadowBackend> inner) {
    auto in_place = std::make_unique<InPlaceBackend>(std::move(inner));
    ip = in_place.get();
    return std::unique_ptr<ShadowBackend>(std::move(in_place));
  });
  return ip;
}

// `sys`'s backend replaced by the exec backend on GlHostExec (the cuda
// backend's GL side on CPU threads); owned by the system.
exec::ExecBackend<test::GlHostExec>* use_gl_exec_backend(ShadowSystem& sys) {
  exec::ExecBackend<test::GlHostExec>* b = nullptr;
  SystemHooks::wrap_backend(sys, [&](std::unique_ptr<ShadowBackend>) {
    auto e = std::make_unique<exec::ExecBackend<test::GlHostExec>>("exec-gl-host");
    b = e.get();
    return std::unique_ptr<ShadowBackend>(std::move(e));
  });
  return b;
}

// GL fragment lists handed to the exec backend's lists_from_gl (the cuda
// backend's interop, on CPU threads: each GL buffer mapped where CUDA would
// map it) through a pool small enough to grow and to be filled and handed
// over several times: the image equals that from lists read back to the
// host, the frame's light views came in one batch and the camera's in
// another (each batch's offsets read once, to count them), views larger
// than the pool in several fillings, a filling with pieces of several
// views, and the pool the rasterizer replaced released before GL deleted
// it.
TEST_F(GlSystem, GlListsHandedOverPoolByPoolEqualListsReadBack) {
  Scene scene = load_scene(scene_path("teapot_omni.json"));
  scene.shadows.resolution = 96;
  ShadowSystem host(app_options(FragmentSource::Gl));
  SystemHooks::limit_fragment_pool(host, 4096, 64 * 1024);
  sync_scene(host, scene);
  FrameStats hs;
  const Image want = host.render(&hs);
  ASSERT_EQ(hs.fragment_source, "gl");

  ShadowSystem dev(app_options(FragmentSource::Gl));
  exec::ExecBackend<test::GlHostExec>* b = use_gl_exec_backend(dev);
  const test::GlHostExec& ex = b->executor();
  SystemHooks::limit_fragment_pool(dev, 4096, 64 * 1024);
  // A first frame at 8^2: its light views fit the first pool and are
  // handed over from it; the frame at 96^2 then grows the pool.
  sync_scene(dev, scene);
  ShadowSettings tiny = scene.shadows;
  tiny.resolution = 8;
  dev.set_settings(tiny);
  FrameStats first;
  dev.update(&first);
  ASSERT_EQ(first.counters.gl_readbacks, 1u) << "the light views' batch";
  ASSERT_EQ(ex.pool_maps, 1u) << "one filling of the first pool";
  const uint64_t fillings = ex.pool_maps, copies = ex.source_copies;
  dev.set_settings(scene.shadows);
  FrameStats st;
  const Image got = dev.render(&st);
  EXPECT_EQ(st.fragment_source, "gl");
  EXPECT_EQ(st.counters.gl_readbacks, 2u) << "the light views together, then the camera's: each batch's offsets once";
  EXPECT_GT(ex.pool_maps - fillings, 2u) << "views larger than the pool were handed over in several fillings";
  EXPECT_GT(ex.source_copies - copies, ex.pool_maps - fillings) << "a filling holds pieces of several views";
  EXPECT_GE(ex.pool_releases, 1u) << "the pool grew from 4 KiB to 64 KiB: the one handed over let go of first";
  for (const unsigned name : ex.pools) EXPECT_TRUE(glIsBuffer(name)) << "pool " << name << " deleted unannounced";
  EXPECT_EQ(ex.violations, std::vector<std::string>{});
  ASSERT_EQ(got.rgb.size(), want.rgb.size());
  EXPECT_EQ(std::memcmp(got.rgb.data(), want.rgb.data(), got.rgb.size() * sizeof(float)), 0);
}

// The exec backend's own GL hand-over (the cuda backend's lists_from_gl,
// lists_from_gl_unchecked, write_gl_maps) run on CPU threads, each GL
// buffer mapped where CUDA would map it (test GlHostExec), frame after
// frame: a first frame (every light view's lists and the camera's counted
// on the host once), the camera moved (its lists made unchecked), the spot
// moved (its lists and the camera's made unchecked: no GL read-back at
// all), the spot moved with every guess too small (both made again,
// checked) — each image equal to the cpu backend's from lists read back.
TEST_F(GlSystem, ExecBackendsGlHandOverOnCpuThreadsEqualsListsReadBack) {
  Scene scene = load_scene(scene_path("teapot_omni.json"));
  scene.shadows.resolution = 96;
  ShadowSystem host(app_options(FragmentSource::Gl));
  ShadowSystem dev(app_options(FragmentSource::Gl));
  exec::ExecBackend<test::GlHostExec>* b = use_gl_exec_backend(dev);
  ASSERT_TRUE(SystemHooks::backend(dev).can_write_gl_maps());
  sync_scene(host, scene);
  sync_scene(dev, scene);
  Light spot = scene.lights[0];
  for (int step = 0; step < 4; ++step) {
    SCOPED_TRACE("step " + std::to_string(step));
    if (step == 1) {
      Camera c = scene.camera;
      c.position = c.position + Vec3{0.3f, 0.1f, 0.0f};
      host.set_camera(c);
      dev.set_camera(c);
    } else if (step >= 2) {
      spot.position = spot.position + Vec3{0.2f, 0.0f, 0.0f};
      host.set_light(host.lights()[0], spot);
      dev.set_light(dev.lights()[0], spot);
      if (step == 3)
        for (auto& [slot, count] : b->gl_guesses()) count = 1;
    }
    FrameStats hs, ds;
    const uint64_t maps_before = b->executor().source_maps;
    const Image want = host.render(&hs);
    const Image got = dev.render(&ds);
    ASSERT_EQ(ds.fragment_source, "gl");
    EXPECT_EQ(ds.maps_rebuilt, hs.maps_rebuilt);
    EXPECT_EQ(b->executor().violations, std::vector<std::string>{});
    EXPECT_GT(b->executor().source_maps, maps_before) << "lists taken from the rasterizer's GL buffers";
    if (step == 0) {
      EXPECT_EQ(ds.maps_rebuilt, 7u);
      EXPECT_EQ(ds.counters.gl_readbacks, 2u) << "the light views' offsets and the camera's, read once to count them";
    } else if (step == 1) {
      EXPECT_EQ(ds.maps_rebuilt, 0u);
      EXPECT_EQ(ds.counters.gl_readbacks, 0u) << "the camera's lists made unchecked";
    } else {
      EXPECT_EQ(ds.maps_rebuilt, 1u) << "the spot's map";
      EXPECT_EQ(ds.update.fragment_lists_redone, step == 3 ? 2u : 0u);
      EXPECT_EQ(ds.counters.gl_readbacks, step == 3 ? 2u : 0u)
          << (step == 2 ? "the spot's and the camera's lists made unchecked: nothing read back"
                        : "their guesses too small: made again, each one's offsets read once");
    }
    ASSERT_EQ(got.rgb.size(), want.rgb.size());
    EXPECT_EQ(std::memcmp(got.rgb.data(), want.rgb.data(), got.rgb.size() * sizeof(float)), 0);
  }
}

// The engine's frame on the GL context's device, counted on CPU threads
// (issue 45 item 6): after warm-up, an update() that rebuilds a light's maps
// from GL lists waits for the backend once (the light pass's counter read,
// which also says the lists fit), reads nothing back from GL and allocates
// nothing, in the backend or in GL; an unchanged update() does nothing.
TEST_F(GlSystem, AWarmRebuildFromGlListsWaitsOnceAndAllocatesNothing) {
  Scene scene = load_scene(scene_path("teapot_omni.json"));
  scene.shadows.resolution = 96;
  ShadowSystem sys(app_options(FragmentSource::Gl));
  exec::ExecBackend<test::GlHostExec>* b = use_gl_exec_backend(sys);
  sync_scene(sys, scene);
  Light omni = scene.lights[1];
  FrameStats st;
  sys.update(&st);
  for (int frame = 0; frame < 8; ++frame) {
    SCOPED_TRACE("frame " + std::to_string(frame));
    omni.position = omni.position + Vec3{frame % 2 ? -0.01f : 0.01f, 0.0f, 0.0f};
    sys.set_light(sys.lights()[1], omni);
    st = FrameStats{};
    sys.update(&st);
    ASSERT_EQ(st.fragment_source, "gl");
    ASSERT_EQ(st.maps_rebuilt, 6u) << "the omni light's six faces";
    // Each face's lists guessed from its own last count (its map plan's
    // slot), from the first frame on, although the first frame's batch also
    // held the spot's view.
    EXPECT_EQ(st.update.fragment_lists_redone, 0u);
    EXPECT_EQ(st.counters.gl_readbacks, 0u) << "no offsets read to size the lists";
    if (frame < 4) continue;  // warm-up: arrays grown
    EXPECT_EQ(st.counters.host_syncs, 1u) << "the light pass's one read of its counters and the lists' status";
    EXPECT_EQ(st.counters.gl_readbacks, 0u) << "no offsets read to size the lists";
    EXPECT_EQ(st.counters.backend_allocations, 0u);
    EXPECT_EQ(st.counters.gl_allocations, 0u);
    EXPECT_EQ(st.update.fragment_lists_redone, 0u);
    EXPECT_EQ(st.update.host_to_backend_bytes, 0u) << "the lists went GL -> backend on the device";
    EXPECT_LE(st.update.backend_to_host_bytes, 6u * 128u) << "the six maps' counters, nothing else";
  }
  EXPECT_EQ(b->executor().violations, std::vector<std::string>{});
  FrameStats same;
  sys.update(&same);
  EXPECT_EQ(same.maps_rebuilt, 0u);
  EXPECT_EQ(same.counters.host_syncs, 0u);
  EXPECT_EQ(same.counters.backend_allocations, 0u);
  EXPECT_EQ(same.counters.gl_readbacks, 0u);
  EXPECT_EQ(same.counters.launches, 0u);
}

// A batch whose pool (capped here at 64 KiB, 8192 fragments) holds less
// than its views' fragments: with the first five faces' guesses far too
// small, their fragments run past the pool and the sixth face loses its
// own although its count is within its capacity. Every lists that did not
// fit is made again (the sixth too, or its build would fail again), and
// the image equals the cpu backend's from lists read back.
TEST_F(GlSystem, ListsPastAGuessedPoolAreMadeAgainToo) {
  Scene scene = load_scene(scene_path("teapot_omni.json"));
  scene.shadows.resolution = 96;
  ShadowSystem host(app_options(FragmentSource::Gl));
  ShadowSystem dev(app_options(FragmentSource::Gl));
  exec::ExecBackend<test::GlHostExec>* b = use_gl_exec_backend(dev);
  SystemHooks::limit_fragment_pool(dev, 4096, 64 * 1024);
  sync_scene(host, scene);
  sync_scene(dev, scene);
  dev.update();
  host.update();
  for (uint64_t v = 0; v < 5; ++v) {
    const uint64_t slot = lists_slot_key(v + 2, 96, 96);  // face v's: map plan v + 1 (the spot's is 0)
    ASSERT_EQ(b->gl_guesses().count(slot), 1u) << "face " << v << "'s slot";
    b->gl_guesses()[slot] = 1;
  }
  Light omni = scene.lights[1];
  omni.position = omni.position + Vec3{0.01f, 0.0f, 0.0f};
  dev.set_light(dev.lights()[1], omni);
  host.set_light(host.lights()[1], omni);
  FrameStats st;
  const Image got = dev.render(&st);
  const Image want = host.render();
  EXPECT_EQ(st.maps_rebuilt, 6u);
  EXPECT_GE(st.update.fragment_lists_redone, 1u);
  EXPECT_EQ(b->executor().violations, std::vector<std::string>{});
  ASSERT_EQ(got.rgb.size(), want.rgb.size());
  EXPECT_EQ(std::memcmp(got.rgb.data(), want.rgb.data(), got.rgb.size() * sizeof(float)), 0);
}

// Kept fragment lists (SystemOptions::keep_fragment_lists, the editor's
// ε edits) over unchecked GL lists: the copies kept carry their lists'
// status, a rebuild from them checks it, and copies of lists that did not
// fit are replaced by copies of the lists made again — every image equal
// to the cpu backend's from lists read back.
TEST_F(GlSystem, KeptListsOfUncheckedGlListsRebuildAsTheirLists) {
  Scene scene = load_scene(scene_path("teapot_omni.json"));
  scene.shadows.resolution = 96;
  SystemOptions o = app_options(FragmentSource::Gl);
  o.keep_fragment_lists = true;
  ShadowSystem host(o);
  ShadowSystem dev(o);
  exec::ExecBackend<test::GlHostExec>* b = use_gl_exec_backend(dev);
  sync_scene(host, scene);
  sync_scene(dev, scene);
  Light spot = scene.lights[0];
  ShadowSettings settings = scene.shadows;
  for (int step = 0; step < 5; ++step) {
    SCOPED_TRACE("step " + std::to_string(step));
    if (step == 1 || step == 3) {  // the spot moved (at 3 with every guess too small)
      spot.position = spot.position + Vec3{0.2f, 0.0f, 0.0f};
      host.set_light(host.lights()[0], spot);
      dev.set_light(dev.lights()[0], spot);
      if (step == 3)
        for (auto& [slot, count] : b->gl_guesses()) count = 1;
    } else if (step == 2 || step == 4) {  // ε changed: every map rebuilt from its kept lists
      settings.epsilon *= 0.5f;
      host.set_settings(settings);
      dev.set_settings(settings);
    }
    FrameStats hs, ds;
    const Image want = host.render(&hs);
    const Image got = dev.render(&ds);
    EXPECT_EQ(ds.maps_rebuilt, hs.maps_rebuilt);
    if (step == 2 || step == 4) {
      EXPECT_EQ(ds.update.fragment_lists_reused, 7u) << "every map from its kept lists";
    }
    if (step == 3) {
      EXPECT_GE(ds.update.fragment_lists_redone, 1u);
    }
    if (step == 4) {
      EXPECT_EQ(ds.update.fragment_lists_redone, 0u) << "the kept copies were replaced at step 3";
    }
    EXPECT_EQ(b->executor().violations, std::vector<std::string>{});
    ASSERT_EQ(got.rgb.size(), want.rgb.size());
    EXPECT_EQ(std::memcmp(got.rgb.data(), want.rgb.data(), got.rgb.size() * sizeof(float)), 0);
  }
}

// A frame's light views come back to the host in two GL reads (issue 45
// item 2): every view counted and scanned together, their offsets read once
// with the scan's overflow flag after them, every view filled into the
// pool, their fragments read once. (Two reads a view before, three before
// that.)
TEST_F(GlSystem, AFrameOfLightViewsReadsBackOffsetsAndFragmentsOnce) {
  Scene scene = load_scene(scene_path("teapot_omni.json"));
  scene.shadows.resolution = 96;
  ShadowSystem sys(app_options(FragmentSource::Gl));
  sync_scene(sys, scene);
  FrameStats st;
  sys.update(&st);
  ASSERT_EQ(st.fragment_source, "gl");
  ASSERT_EQ(st.maps_rebuilt, 7u) << "a spot's map and an omni light's six";
  EXPECT_EQ(st.counters.gl_readbacks, 2u) << "one read of the 7 views' offsets, one of their fragments";
  EXPECT_EQ(st.counters.host_syncs, 1u) << "the light pass reads every map's counters once";
}

// The figures of one update and whether the GL buffers then equal storage().
struct PublishStep {
  UpdateStats u;
  uint32_t rebuilt = 0;
  std::string differ;
};

// First frame, an unchanged frame, a spot light added (appended: tails), the
// omni light moved (compaction: a new epoch, the arrays from the first moved
// map).
std::vector<PublishStep> publish_steps(ShadowSystem& sys, Scene scene) {
  std::vector<PublishStep> steps;
  const FrameSnapshot snap(sys);
  const auto step = [&] {
    FrameStats st;
    sys.update(&st);
    steps.push_back({st.update, st.maps_rebuilt, gl_maps_differ(sys.gl_buffers(), snap.backend().storage())});
  };
  sync_scene(sys, scene);
  step();
  sys.set_camera(scene.camera);
  step();
  Light l = scene.lights[0];
  l.position = l.position + Vec3{-2.0f, 0, 0};
  sys.add_light(l);
  step();
  Light o = scene.lights[1];
  o.position = o.position + Vec3{0.05f, 0, 0};
  sys.set_light(sys.lights()[1], o);
  step();
  return steps;
}

// The cpu backend and the exec backend on CPU threads cannot write GL
// buffers: their maps reach GL as host uploads, none counted as device
// writes, and the buffers equal their storage() after every step — with
// point lights and with lights with a size.
TEST_F(GlSystem, HostBackendsUploadTheirMapsFromTheHost) {
  for (int run = 0; run < 4; ++run) {
    const int exec = run & 1;
    Scene scene = load_scene(scene_path("teapot_omni.json"));
    scene.shadows.resolution = 96;
    if (run >= 2)
      for (Light& l : scene.lights) l.radius = 0.1f;
    SCOPED_TRACE(std::string(exec ? "exec backend on CPU threads" : "cpu backend") +
                 (run >= 2 ? ", lights with a size" : ""));
    ShadowSystem sys(app_options(FragmentSource::Cpu));
    if (exec)
      SystemHooks::wrap_backend(sys, [](std::unique_ptr<ShadowBackend>) {
        return std::unique_ptr<ShadowBackend>(std::make_unique<exec::ExecBackend<exec::HostExec>>("exec-host"));
      });
    EXPECT_FALSE(SystemHooks::backend(sys).can_write_gl_maps());
    EXPECT_THROW(SystemHooks::backend(sys).write_gl_maps(nullptr, 0), std::logic_error);
    const std::vector<PublishStep> steps = publish_steps(sys, scene);
    for (size_t i = 0; i < steps.size(); ++i) {
      SCOPED_TRACE("step " + std::to_string(i));
      EXPECT_EQ(steps[i].u.gl_map_device_bytes, 0u);
      EXPECT_EQ(steps[i].differ, "");
    }
    EXPECT_GT(steps[0].u.gl_map_upload_bytes, 0u);
    EXPECT_EQ(steps[1].u.gl_map_upload_bytes, 0u);
  }
}

// A backend that can write the buffers gets exactly the ranges the host path
// uploads (the same epoch and tail logic): its device-written bytes are the
// host path's array bytes, only the frame block is still uploaded, and the
// buffers equal storage() byte for byte after every step.
TEST_F(GlSystem, InPlaceBackendGetsTheRangesTheHostPathUploads) {
  Scene scene = load_scene(scene_path("teapot_omni.json"));
  scene.shadows.resolution = 96;
  ShadowSystem host(app_options(FragmentSource::Cpu));
  const std::vector<PublishStep> h = publish_steps(host, scene);

  ShadowSystem dev(app_options(FragmentSource::Cpu));
  InPlaceBackend* ip = use_in_place_backend(dev);
  const std::vector<PublishStep> d = publish_steps(dev, scene);

  ASSERT_EQ(h.size(), d.size());
  ASSERT_EQ(d[2].rebuilt, 1u);
  ASSERT_EQ(d[3].rebuilt, 6u);
  EXPECT_FALSE(d[3].u.gl_map_full_upload) << "the omni light's move compacts the store, which keeps the first map";
  EXPECT_GT(d[3].u.gl_map_device_bytes, 0u);
  for (size_t i = 0; i < d.size(); ++i) {
    SCOPED_TRACE("step " + std::to_string(i));
    EXPECT_EQ(d[i].rebuilt, h[i].rebuilt);
    EXPECT_EQ(d[i].u.gl_map_full_upload, h[i].u.gl_map_full_upload);
    EXPECT_EQ(d[i].differ, "");
    EXPECT_EQ(h[i].differ, "");
    EXPECT_EQ(h[i].u.gl_map_device_bytes, 0u);
    // The host path's uploads = the frame block + the arrays' ranges; the
    // device path uploads the same frame block and writes the same ranges.
    EXPECT_EQ(d[i].u.gl_map_upload_bytes + d[i].u.gl_map_device_bytes, h[i].u.gl_map_upload_bytes);
    EXPECT_EQ(d[i].u.gl_map_copy_bytes, h[i].u.gl_map_copy_bytes);
    const uint64_t frame_block = d[i].u.gl_map_upload_bytes;
    EXPECT_TRUE(frame_block == 0 || frame_block % 16 == 0) << "only the frame block is uploaded: " << frame_block;
  }
  EXPECT_GT(d[0].u.gl_map_device_bytes, 0u);
  EXPECT_EQ(d[1].u.gl_map_device_bytes, 0u) << "nothing changed: nothing written";
  EXPECT_GT(d[2].u.gl_map_device_bytes, 0u);
  EXPECT_LT(d[2].u.gl_map_device_bytes, d[0].u.gl_map_device_bytes) << "a spot map appended: tails only";
  EXPECT_GT(ip->writes, 0u);
}

// The registry a backend keeps of the GL buffers it registered (CUDA-GL
// interop) hears of every buffer before GL deletes or replaces it: growth
// and re-allocation in update(), the buffers dropped by a new block limit;
// between updates every registered name is one of the system's buffers.
TEST_F(GlSystem, EveryMapBufferIsReleasedToTheBackendBeforeGlDeletesIt) {
  Scene scene = load_scene(scene_path("teapot_omni.json"));
  scene.shadows.resolution = 96;
  ShadowSystem sys(app_options(FragmentSource::Cpu));
  InPlaceBackend* ip = use_in_place_backend(sys);
  const FrameSnapshot snap(sys);
  const auto registered_are_live = [&] {
    const GlMapBuffers b = sys.gl_buffers();
    const uint32_t live[] = {b.texels, b.nodes, b.chunks, b.rgb_texels, b.rgb_nodes, b.rgb_chunks, b.tags, b.rgb_tags};
    for (const auto& r : ip->registered)
      EXPECT_NE(std::find(std::begin(live), std::end(live), r.first), std::end(live))
          << "buffer " << r.first << " is registered but no longer one of the system's";
  };
  sync_scene(sys, scene);
  sys.update();
  registered_are_live();
  const uint64_t first = ip->releases;
  for (float dx : {-2.0f, -1.0f, 1.0f, 2.0f}) {  // more maps: arrays grow (a GL-side copy into a new buffer)
    Light l = scene.lights[0];
    l.position = l.position + Vec3{dx, 0.5f, 0};
    sys.add_light(l);
    sys.update();
    registered_are_live();
  }
  while (sys.lights().size() > 1) {  // fewer: compaction, full syncs that re-allocate
    sys.remove_light(sys.lights().back());
    sys.update();
    registered_are_live();
  }
  EXPECT_GT(ip->releases, first) << "the updates replaced buffers";
  EXPECT_FALSE(ip->registered.empty());
  SystemHooks::limit_gl_map_block(sys, 0);  // drops every buffer
  EXPECT_TRUE(ip->registered.empty()) << ip->registered.size() << " buffers deleted while registered";
  sys.update();
  registered_are_live();
  EXPECT_EQ(gl_maps_differ(sys.gl_buffers(), snap.backend().storage()), "");
  for (const std::string& v : ip->violations) ADD_FAILURE() << v;
}

// A failed in-place write leaves the buffers behind: the next update writes
// every array again (a full sync), and the buffers equal storage().
TEST_F(GlSystem, AFailedInPlaceWriteIsRepairedByTheNextUpdate) {
  Scene scene = load_scene(scene_path("teapot_omni.json"));
  scene.shadows.resolution = 96;
  ShadowSystem sys(app_options(FragmentSource::Cpu));
  InPlaceBackend* ip = use_in_place_backend(sys);
  const FrameSnapshot snap(sys);
  sync_scene(sys, scene);
  sys.update();
  Light l = scene.lights[0];
  l.position = l.position + Vec3{-2.0f, 0, 0};
  sys.add_light(l);
  ip->fail_next = true;
  EXPECT_THROW(sys.update(), std::runtime_error);
  FrameStats st;
  sys.set_camera(scene.camera);
  sys.update(&st);
  EXPECT_TRUE(st.update.gl_map_full_upload);
  EXPECT_EQ(gl_maps_differ(sys.gl_buffers(), snap.backend().storage()), "");
}

// CDSM_SHADER_DIR (engine/gl/shaders.h): cdsm.glsl read from its parts on
// disk (content/shaders/cdsm/) is the embedded copy byte for byte; a
// directory without the parts is an error naming the part it lacks.
TEST(GlslInclude, ShaderDirJoinsThePartsAsTheBuildDoes) {
  struct Unset {
    ~Unset() { unsetenv("CDSM_SHADER_DIR"); }
  } unset;
  const std::string embedded = glsl_include();
  setenv("CDSM_SHADER_DIR", CDSM_CONTENT_DIR_TEST "/shaders", 1);
  EXPECT_EQ(glsl_include(), embedded);
  setenv("CDSM_SHADER_DIR", CDSM_TEST_OUTPUT_DIR, 1);
  try {
    glsl_include();
    ADD_FAILURE() << "a shader directory without cdsm.glsl's parts was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cdsm/interface.glsl"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cdsm::test
