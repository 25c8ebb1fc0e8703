// CUDA-GL interop (cuda/gl_interop.h): a GL buffer registered once, again
// only when it changed (a pool that grew), mapped per frame, written from
// CUDA and read by GL with no copy through the host. Needs a CUDA device
// and a GL context on it (label gpu; skipped with the reason otherwise).
#include <gtest/gtest.h>

#include <cuda_runtime.h>

#include <cstring>
#include <vector>

#include "gl/gl_api.h"
#include "gl_interop.h"
#include "gl_test_util.h"
#include "gpu_test.h"

using namespace cdsm;

class GlInterop : public test::GlTest {};

TEST_F(GlInterop, RegisterOnceMapWriteRead) {
  CDSM_REQUIRE_DEVICE();
  std::string why;
  if (!cuda::gl_context_on_device(cuda::probe_device().device, &why)) {
    if (test::gpu_required()) FAIL() << why;
    GTEST_SKIP() << why;
  }
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
