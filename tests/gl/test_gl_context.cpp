// GL context, checked calls and the GPU prefix sum.
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <random>
#include <vector>

#include "cdsm/error.h"
#include "gl/gl_api.h"
#include "gl/map_buffers.h"
#include "gl/prefix_sum.h"
#include "gl_test_util.h"

namespace cdsm::test {
namespace {

class GlContext : public GlTest {};

TEST_F(GlContext, DescribesItselfAndMeetsLimits) {
  const gl::Context& c = context();
  EXPECT_FALSE(c.description().empty());
  EXPECT_NE(c.description().find("4."), std::string::npos) << c.description();
  EXPECT_TRUE(c.is_current());
  EXPECT_EQ(gl::Context::current(), &c);
  EXPECT_GE(c.limits().max_ssbo_block_size, int64_t(16) << 20);  // GL 4.5 minimum is 16 MiB
  EXPECT_GE(c.limits().max_framebuffer_width, 4096);
  EXPECT_GE(c.limits().max_compute_groups_x, 65535);
  EXPECT_TRUE(c.platform() == gl::Platform::EglDevice || c.platform() == gl::Platform::EglSurfaceless);
}

// cdsm.glsl's nine storage blocks against the context's limits: this one
// holds them (MapBuffers checks on creation), and a context at GL 4.5's
// guaranteed minimum of 8 per stage is refused with the limits named.
TEST_F(GlContext, HoldsTheStorageBlocksOfCdsmGlsl) {
  const gl::Limits& l = context().limits();
  EXPECT_EQ(gl::kMapBlocks, 9);
  EXPECT_GE(l.max_fragment_ssbo_blocks, gl::kMapBlocks);
  EXPECT_GE(l.max_compute_ssbo_blocks, gl::kMapBlocks);
  EXPECT_GE(l.max_combined_ssbo_blocks, gl::kMapBlocks);
  EXPECT_GE(l.max_ssbo_bindings, 8 + gl::kMapBlocks);  // CDSM_BINDING_BASE 8 .. 16
  EXPECT_EQ(gl::storage_block_shortfall(l), "");

  gl::Limits minimum = l;
  minimum.max_fragment_ssbo_blocks = 8;
  minimum.max_combined_ssbo_blocks = 8;
  const std::string why = gl::storage_block_shortfall(minimum);
  EXPECT_NE(why.find("needs 9 shader storage blocks"), std::string::npos) << why;
  EXPECT_NE(why.find("GL_MAX_FRAGMENT_SHADER_STORAGE_BLOCKS is 8"), std::string::npos) << why;
  EXPECT_NE(why.find("GL_MAX_COMBINED_SHADER_STORAGE_BLOCKS is 8"), std::string::npos) << why;
  EXPECT_EQ(why.find("COMPUTE"), std::string::npos) << why;
  std::printf("storage blocks: fragment %d, compute %d, combined %d, bindings %d (%s)\n", l.max_fragment_ssbo_blocks,
              l.max_compute_ssbo_blocks, l.max_combined_ssbo_blocks, l.max_ssbo_bindings,
              context().description().c_str());
}

TEST_F(GlContext, CheckedCallNamesTheCallFileAndLine) {
  GLuint bogus = 0x7fffffff;  // never generated: binding it is GL_INVALID_OPERATION in core
  try {
    CDSM_GL(glBindBuffer(GL_ARRAY_BUFFER, bogus));
    FAIL() << "no error raised";
  } catch (const Error& e) {
    std::string what = e.what();
    EXPECT_NE(what.find("glBindBuffer(GL_ARRAY_BUFFER, bogus)"), std::string::npos) << what;
    EXPECT_NE(what.find("GL_INVALID_OPERATION"), std::string::npos) << what;
    EXPECT_NE(what.find("test_gl_context.cpp:"), std::string::npos) << what;
  }
  // The error queue is drained: the next checked call passes.
  EXPECT_NO_THROW(CDSM_GL(glBindBuffer(GL_ARRAY_BUFFER, 0)));
}

TEST_F(GlContext, SecondHeadlessContextCoexists) {
  std::string reason;
  {
    auto other = gl::create_headless_context({}, &reason);
    ASSERT_TRUE(other) << reason;
    EXPECT_TRUE(other->is_current());
    GLuint b = 0;
    CDSM_GL(glCreateBuffers(1, &b));
    CDSM_GL(glDeleteBuffers(1, &b));
  }
  // Destroying the second one must leave the first usable (shared EGL display).
  context().make_current();
  GLuint b = 0;
  EXPECT_NO_THROW(CDSM_GL(glCreateBuffers(1, &b)));
  glDeleteBuffers(1, &b);
}

TEST_F(GlContext, DebugContextLabelsObjects) {
  std::string reason;
  gl::ContextOptions o;
  o.debug = true;
  auto dbg = gl::create_headless_context(o, &reason);
  ASSERT_TRUE(dbg) << reason;
  EXPECT_TRUE(dbg->debug());
  {
    gl::Buffer b("cdsm.test.labelled");
    b.reserve(64);
    char label[64] = {};
    GLsizei n = 0;
    CDSM_GL(glGetObjectLabel(GL_BUFFER, b.id(), sizeof label, &n, label));
    EXPECT_STREQ(label, "cdsm.test.labelled");
  }
  dbg.reset();
  context().make_current();
}

// Window contexts need a display: run under xvfb-run (CDSM_REQUIRE_XVFB=1 makes a missing one a failure).
TEST(GlWindow, CreatesAWindowContextWhenADisplayExists) {
  const char* req = std::getenv("CDSM_REQUIRE_XVFB");
  bool required = req && std::string(req) == "1";
  std::string reason;
  gl::ContextOptions o;
  o.visible = false;
  o.width = 64;
  o.height = 48;
  auto w = gl::create_window_context(o, &reason);
  if (!w) {
    if (required) FAIL() << "CDSM_REQUIRE_XVFB=1 but " << reason;
    GTEST_SKIP() << reason;
  }
  EXPECT_EQ(w->platform(), gl::Platform::GlfwWindow);
  EXPECT_NE(w->native_window(), nullptr);
  CDSM_GL(glClearColor(0.1f, 0.2f, 0.3f, 1.0f));
  CDSM_GL(glClear(GL_COLOR_BUFFER_BIT));
  w->swap_buffers();
  std::printf("[  window  ] %s\n", w->description().c_str());
}

class GlPrefixSum : public GlTest {};

TEST_F(GlPrefixSum, MatchesCpuAcrossLevelBoundaries) {
  gl::PrefixSum scan(context());
  gl::Buffer in("cdsm.test.scan_in"), out("cdsm.test.scan_out");
  std::mt19937 rng(7);
  for (uint64_t n :
       {0ull, 1ull, 5ull, 1023ull, 1024ull, 1025ull, 300000ull, 1048576ull, 1048577ull, 4096ull * 4096ull + 3ull}) {
    std::vector<uint32_t> v(n);
    for (auto& x : v) x = rng() % 9;  // mostly small, like fragment counts
    in.reserve(std::max<uint64_t>(n * 4, 4));
    out.reserve((n + 1) * 4);
    in.upload(v.data(), n * 4);
    scan.exclusive_scan(in, out, n);
    std::vector<uint32_t> got(n + 1);
    out.download(got.data(), (n + 1) * 4);
    EXPECT_FALSE(scan.overflowed());
    uint32_t run = 0;
    uint64_t bad = 0;
    for (uint64_t i = 0; i < n; ++i) {
      if (got[i] != run) ++bad;
      run += v[i];
    }
    EXPECT_EQ(bad, 0u) << "n = " << n;
    EXPECT_EQ(got[n], run) << "total, n = " << n;
  }
}

TEST_F(GlPrefixSum, ReportsOverflow) {
  gl::PrefixSum scan(context());
  gl::Buffer in("cdsm.test.scan_in"), out("cdsm.test.scan_out");
  std::vector<uint32_t> v(3000, 0u);
  v[10] = 0x80000000u;
  v[2500] = 0x80000000u;  // different blocks: the carry happens in level 1
  in.reserve(v.size() * 4);
  out.reserve((v.size() + 2) * 4);
  // The flag read back alone, and copied after the total (no read-back of
  // its own: the rasterizer reads it with the offsets).
  const auto flag_in_out = [&] {
    scan.write_overflow_flag(out, v.size() + 1);
    uint32_t flag = 7;
    out.download(&flag, 4, (v.size() + 1) * 4);
    return flag;
  };
  in.upload(v.data(), v.size() * 4);
  scan.exclusive_scan(in, out, v.size());
  EXPECT_TRUE(scan.overflowed());
  EXPECT_NE(flag_in_out(), 0u);
  v[2500] = 0x7fffffffu;
  in.upload(v.data(), v.size() * 4);
  scan.exclusive_scan(in, out, v.size());
  EXPECT_FALSE(scan.overflowed());
  EXPECT_EQ(flag_in_out(), 0u);
}

}  // namespace
}  // namespace cdsm::test
