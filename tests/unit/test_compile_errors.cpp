// Scenes built in code that the system's compile must refuse with a clear error
// (issue "No silent wrong answers", item 8): transforms that turn finite
// vertices into Inf/NaN in world space, singular transforms, and an
// allocation that fails while compiling (named, with its size).
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "cdsm/error.h"
#include "unit_util.h"
#include "common/sanitized.h"

using namespace cdsm;
using namespace cdsm_test;

namespace {

::testing::AssertionResult refused(const Scene& s, const std::vector<std::string>& parts) {
  try {
    compiled_scene(s);
  } catch (const Error& e) {
    std::string m = e.what();
    for (const std::string& p : parts)
      if (m.find(p) == std::string::npos) return ::testing::AssertionFailure() << "'" << p << "' not in: " << m;
    return ::testing::AssertionSuccess();
  } catch (const std::exception& e) {
    return ::testing::AssertionFailure() << "not a cdsm::Error: " << e.what();
  }
  return ::testing::AssertionFailure() << "no error";
}

}  // namespace

TEST(CompileErrors, TransformTurnsVerticesInfinite) {
  Scene s = empty_scene("huge");
  TriangleMesh m = make_box({2e30f, 2e30f, 2e30f});  // finite: +-1e30
  s.objects.push_back(surface_object("big box", m, make_transform({0, 0, 0}, {0, 0, 0}, {1e10f, 1, 1})));
  EXPECT_TRUE(refused(s, {"huge", "big box", "world space", "infinite"}));
}

TEST(CompileErrors, SingularTransform) {
  Scene s = empty_scene("flat");
  Mat4 flat = make_transform({0, 1, 0}, {0, 0, 0}, {1, 1, 1});
  flat.m[1][1] = 0.0f;  // squashes y: no inverse, no shading normals
  s.objects.push_back(surface_object("squashed", make_sphere(1.0f, 12, 6), flat));
  EXPECT_TRUE(refused(s, {"flat", "squashed", "singular"}));
}

// Builds a 600 MB grid, limits the address space to what is mapped plus
// 256 MB, compiles (copying the grid cannot succeed), prints the error and
// exits 0: the body of a death test.
[[noreturn]] void compile_big_grid_with_little_memory() {
  Scene s = empty_scene("big grid");
  auto g = std::make_shared<DenseGrid>();
  g->nx = 600;
  g->ny = 500;
  g->nz = 500;  // 150 M voxels, 600 MB
  g->values.assign(size_t(g->nx) * g->ny * g->nz, 0.5f);
  Volume v;
  v.name = "fog";
  v.grid = g;
  v.transfer = {TransferPoint{0, vec3(1), {1, 1, 1}}};
  s.volumes.push_back(v);
  Object o = surface_object("fog", make_box({1, 1, 1}));
  o.interior = InteriorKind::Volume;
  o.volume = 0;
  s.objects.push_back(o);
  long pages = 0;
  std::ifstream("/proc/self/statm") >> pages;
  rlimit lim{};
  lim.rlim_cur = lim.rlim_max = rlim_t(pages) * 4096 + (rlim_t(256) << 20);
  setrlimit(RLIMIT_AS, &lim);
  try {
    compiled_scene(s);
    std::fprintf(stderr, "no error\n");
  } catch (const Error& e) {
    std::fprintf(stderr, "%s\n", e.what());
  }
  std::exit(0);
}

// An allocation that fails while compiling says what and how large (in a
// child process, a death test, whose address space is limited).
TEST(CompileErrorsDeathTest, AllocationFailureIsNamed) {
#if CDSM_TEST_SANITIZED
  GTEST_SKIP() << "address-space limits and sanitizer shadow memory do not mix";
#else
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(compile_big_grid_with_little_memory(), ::testing::ExitedWithCode(0),
              "big grid: volume 0 'fog': out of memory while copying its 150000000 voxels \\(572 MiB\\)");
#endif
}

// A broken invariant (CDSM_CHECK) is a std::logic_error naming what was
// expected, the condition and where; a check that holds costs nothing.
TEST(Check, FailedChecksNameTheConditionAndThePlace) {
  int calls = 0;
  const auto count = [&] { return ++calls; };
  CDSM_CHECK(count() == 1, "evaluated once");
  EXPECT_EQ(calls, 1);
  try {
    CDSM_CHECK(calls == 2, "lists: a tile out of order");
    ADD_FAILURE() << "a failed check did not throw";
  } catch (const std::logic_error& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.find("lists: a tile out of order"), 0u) << m;
    EXPECT_NE(m.find("calls == 2"), std::string::npos) << m;
    EXPECT_NE(m.find("test_compile_errors.cpp:"), std::string::npos) << m;
  }
}
