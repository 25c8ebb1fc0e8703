// CUDA-GL interop (cuda/gl_interop.h): a GL buffer registered once, again
// only when it changed (a pool that grew), mapped per frame, written from
// CUDA and read by GL with no copy through the host; the cuda backend
// writing the engine's map buffers that way. Needs a CUDA device and a GL
// context on it (label gpu; skipped with the reason otherwise).
#include <gtest/gtest.h>

#include <cuda_runtime.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "cdsm/scene_io.h"
#include "cdsm/shadow_system.h"
#include "gl/gl_api.h"
#include "gl/map_buffers.h"
#include "gl_interop.h"
#include "gl_test_util.h"
#include "gpu_test.h"
#include "frame_snapshot.h"
#include "scene_sync.h"

using namespace cdsm;

class GlInterop : public test::GlTest {};

// A system on the test's GL context with the cuda backend (CPU fragments).
SystemOptions cuda_on_app_context() {
  SystemOptions o;
  o.gl_context = GlContextUse::Application;
  o.fragments = FragmentSource::Cpu;
  o.backend = Backend::Cuda;
  o.source = "interop system";
  return o;
}

TEST_F(GlInterop, RegisterOnceMapWriteRead) {
  CDSM_REQUIRE_GL_ON_DEVICE();
  GLuint buf = 0;
  glCreateBuffers(1, &buf);
  std::vector<uint32_t> zeros(1024, 0u);
  glNamedBufferData(buf, GLsizeiptr(zeros.size() * 4), zeros.data(), GL_DYNAMIC_DRAW);
  glFinish();

  cuda::GlBufferLink link;
  EXPECT_TRUE(link.bind(buf, zeros.size() * 4));
  EXPECT_FALSE(link.bind(buf, zeros.size() * 4)) << "the same buffer and size: no new registration";
  EXPECT_EQ(link.registrations(), 1u);
  cudaStream_t stream = nullptr;
  ASSERT_EQ(cudaStreamCreate(&stream), cudaSuccess);
  std::vector<uint32_t> values(1024);
  for (size_t i = 0; i < values.size(); ++i) values[i] = uint32_t(i * 7 + 1);
  {
    cuda::GlBufferLink* links[] = {&link};
    cuda::GlMapScope map(links, 1, stream);
    size_t bytes = 0;
    void* p = map.pointer(0, &bytes);
    EXPECT_EQ(bytes, values.size() * 4);
    ASSERT_EQ(cudaMemcpyAsync(p, values.data(), bytes, cudaMemcpyHostToDevice, stream), cudaSuccess);
  }
  ASSERT_EQ(cudaStreamSynchronize(stream), cudaSuccess);
  std::vector<uint32_t> back(values.size());
  glGetNamedBufferSubData(buf, 0, GLsizeiptr(back.size() * 4), back.data());
  EXPECT_EQ(back, values);

  // A pool that grew: a new size registers again.
  glNamedBufferData(buf, GLsizeiptr(zeros.size() * 8), nullptr, GL_DYNAMIC_DRAW);
  EXPECT_TRUE(link.bind(buf, zeros.size() * 8));
  EXPECT_EQ(link.registrations(), 2u);
  link.reset();
  glDeleteBuffers(1, &buf);
  cudaStreamDestroy(stream);
}

// Issue 16 item 4: the cuda backend writes the engine's map SSBOs in place
// (ShadowBackend::write_gl_maps: each buffer registered once per buffer
// object, mapped per update, device-to-device copies of the ranges
// engine/gl/map_buffers.h decided). After the first frame, a map added
// (tails) and a compaction (every array), the GL buffers equal the backend's
// storage() byte for byte, the array bytes are counted as device writes and
// only the frame block is uploaded from the host.
TEST_F(GlInterop, CudaBackendWritesTheMapBuffersInPlace) {
  CDSM_REQUIRE_GL_ON_DEVICE();
  ShadowSystem sys(cuda_on_app_context());
  const FrameSnapshot snap(sys);
  ASSERT_STREQ(snap.backend().name(), "cuda");
  ASSERT_TRUE(snap.backend().can_write_gl_maps());

  Scene scene = load_scene(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/teapot_omni.json");
  scene.shadows.resolution = 128;
  sync_scene(sys, scene);
  const auto check = [&](const char* what, bool expect_device_bytes) {
    SCOPED_TRACE(what);
    FrameStats st;
    sys.update(&st);
    EXPECT_EQ(test::gl_maps_differ(sys.gl_buffers(), snap.backend().storage()), "");
    if (expect_device_bytes)
      EXPECT_GT(st.update.gl_map_device_bytes, 0u);
    else
      EXPECT_EQ(st.update.gl_map_device_bytes, 0u);
    const uint64_t frame_block = sizeof(gl::FrameBlockHeader) + sizeof(DsmMap) * snap.frame().headers.size();
    EXPECT_TRUE(st.update.gl_map_upload_bytes == 0 || st.update.gl_map_upload_bytes == frame_block)
        << "only the frame block from the host: " << st.update.gl_map_upload_bytes;
    return st;
  };
  const FrameStats first = check("first frame", true);
  EXPECT_TRUE(first.update.gl_map_full_upload);
  sys.set_camera(scene.camera);
  check("nothing changed", false);
  Light l = scene.lights[0];
  l.position = l.position + Vec3{-2.0f, 0, 0};
  sys.add_light(l);
  const FrameStats added = check("a spot light added", true);
  EXPECT_FALSE(added.update.gl_map_full_upload);
  EXPECT_LT(added.update.gl_map_device_bytes, first.update.gl_map_device_bytes) << "tails only";
  Light omni = scene.lights[1];
  omni.position = omni.position + Vec3{0.05f, 0, 0};
  sys.set_light(sys.lights()[1], omni);
  const FrameStats compacted = check("the omni light moved (compaction)", true);
  EXPECT_TRUE(compacted.update.gl_map_full_upload);
}

// The cuda camera pass shading straight into a GL pixel buffer (mapped
// write-discard, registered once per buffer object): the same floats as
// the pass read back to the host.
TEST_F(GlInterop, CudaCameraPassWritesAPixelBuffer) {
  CDSM_REQUIRE_GL_ON_DEVICE();
  ShadowSystem sys(cuda_on_app_context());
  Scene scene = load_scene(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/teapot_omni.json");
  scene.shadows.resolution = 128;
  sync_scene(sys, scene);
  const Image img = sys.render();
  const FrameSnapshot snap(sys);
  const uint64_t bytes = img.rgb.size() * sizeof(float);
  ASSERT_GT(bytes, 0u);
  GLuint pbo = 0;
  glCreateBuffers(1, &pbo);
  glNamedBufferData(pbo, GLsizeiptr(bytes), nullptr, GL_STREAM_DRAW);
  for (int pass = 0; pass < 2; ++pass) {
    WalkStats ws;
    SystemHooks::backend(sys).camera_pass_to_gl(snap.shadow_view(), snap.camera(), snap.camera_lists(), pbo, bytes, 1,
                                                ws);
    std::vector<float> back(img.rgb.size());
    glGetNamedBufferSubData(pbo, 0, GLsizeiptr(bytes), back.data());
    EXPECT_EQ(std::memcmp(back.data(), img.rgb.data(), bytes), 0) << "pass " << pass;
  }
  glDeleteBuffers(1, &pbo);
}

// The engine's frame on the device (issue 45 item 2): GL fragment lists
// taken into the cuda backend without the host reading a count
// (lists_from_gl_unchecked). After warm-up, each frame that moves the omni
// light rebuilds its six maps with no GL read-back, no allocation, one
// wait (the light pass's counter read) and no lists made again; the image
// then agrees with the cpu backend's from the same GL lists read back.
TEST_F(GlInterop, CudaBackendTakesGlListsWithoutReadingACount) {
  CDSM_REQUIRE_GL_ON_DEVICE();
  SystemOptions o = cuda_on_app_context();
  o.fragments = FragmentSource::Gl;
  ShadowSystem dev(o);
  o.backend = Backend::Cpu;
  ShadowSystem host(o);
  Scene scene = load_scene(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/teapot_omni.json");
  scene.shadows.resolution = 128;
  sync_scene(dev, scene);
  sync_scene(host, scene);
  FrameStats st;
  dev.update(&st);
  host.update();
  ASSERT_EQ(st.backend, "cuda");
  ASSERT_EQ(st.fragment_source, "gl");
  Light omni = scene.lights[1];
  for (int frame = 0; frame < 8; ++frame) {
    SCOPED_TRACE("frame " + std::to_string(frame));
    omni.position = omni.position + Vec3{frame % 2 ? -0.01f : 0.01f, 0.0f, 0.0f};
    dev.set_light(dev.lights()[1], omni);
    host.set_light(host.lights()[1], omni);
    st = FrameStats{};
    dev.update(&st);
    host.update();
    ASSERT_EQ(st.maps_rebuilt, 6u);
    if (frame < 4) continue;
    EXPECT_EQ(st.counters.gl_readbacks, 0u);
    EXPECT_EQ(st.update.fragment_lists_redone, 0u);
    EXPECT_EQ(st.counters.backend_allocations, 0u);
    EXPECT_EQ(st.counters.host_syncs, 1u);
    EXPECT_EQ(st.update.host_to_backend_bytes, 0u);
  }
  const Image a = dev.render(), b = host.render();
  ASSERT_EQ(a.rgb.size(), b.rgb.size());
  double sq = 0.0;
  for (size_t i = 0; i < a.rgb.size(); ++i) sq += double(a.rgb[i] - b.rgb[i]) * double(a.rgb[i] - b.rgb[i]);
  const double mse = sq / double(a.rgb.size());
  EXPECT_TRUE(mse == 0.0 || 10.0 * std::log10(1.0 / mse) >= 50.0) << "PSNR " << 10.0 * std::log10(1.0 / mse) << " dB";
}
