// The main of the GPU tests (label gpu): GoogleTest, then a verdict on the
// skips, so that a failure cannot pass as a skip and a skip is never silent.
//
//   - a failed test: the run fails (GoogleTest's exit code);
//   - a skip without a stated reason (GTEST_SKIP() with no message): fails;
//   - every test that ran skipped, each for a stated reason: exit 77, which
//     ctest reports as "Skipped" (SKIP_RETURN_CODE, tests/gpu/CMakeLists.txt);
//   - some skipped, others passed: passes, listing the skips, except under
//     CDSM_REQUIRE_GPU=1 (scripts/gpu/run_kit.sh), where it fails, and so
//     does a run in which no test ran at all (a filter that matched nothing).
//
// tests/gpu/test_skip_verdict.cpp checks these rules in every build.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <set>
#include <string>

namespace {

constexpr int kAllSkipped = 77;  // ctest SKIP_RETURN_CODE

bool gpu_required() {
  const char* v = std::getenv("CDSM_REQUIRE_GPU");
  return v && std::string(v) == "1";
}

// The message of a skipped test's skip (trimmed), "" when it stated none.
std::string skip_reason(const testing::TestResult& r) {
  for (int i = 0; i < r.total_part_count(); ++i) {
    const testing::TestPartResult& p = r.GetTestPartResult(i);
    if (!p.skipped()) continue;
    std::string m = p.message() ? p.message() : "";
    const size_t b = m.find_first_not_of(" \t\r\n"), e = m.find_last_not_of(" \t\r\n");
    m = b == std::string::npos ? "" : m.substr(b, e - b + 1);
    if (m.rfind("Skipped", 0) == 0) m = m.substr(7);  // GoogleTest's own prefix, if any
    const size_t b2 = m.find_first_not_of(" \t\r\n");
    return b2 == std::string::npos ? "" : m.substr(b2);
  }
  return "";
}

int verdict(int gtest_code) {
  const testing::UnitTest& u = *testing::UnitTest::GetInstance();
  int ran = 0, skipped = 0, unexplained = 0;
  std::set<std::string> reasons;
  for (int s = 0; s < u.total_test_suite_count(); ++s) {
    const testing::TestSuite& suite = *u.GetTestSuite(s);
    for (int t = 0; t < suite.total_test_count(); ++t) {
      const testing::TestInfo& info = *suite.GetTestInfo(t);
      if (!info.should_run()) continue;
      ++ran;
      if (!info.result()->Skipped()) continue;
      ++skipped;
      const std::string why = skip_reason(*info.result());
      const std::string name = std::string(info.test_suite_name()) + "." + info.name();
      if (why.empty()) {
        ++unexplained;
        std::printf("[ verdict  ] %s skipped without a reason\n", name.c_str());
      } else {
        reasons.insert(why);
      }
    }
  }
  std::string listed;
  for (const std::string& r : reasons) listed += "\n[ verdict  ]   " + r;
  if (gtest_code != 0) {
    if (skipped) std::printf("[ verdict  ] failed; %d of %d tests skipped besides:%s\n", skipped, ran, listed.c_str());
    return gtest_code;
  }
  if (unexplained) {
    std::printf("[ verdict  ] FAILED: %d skipped tests stated no reason\n", unexplained);
    return 1;
  }
  if (ran == 0) {
    std::printf("[ verdict  ] no test ran%s\n", gpu_required() ? ": a failure under CDSM_REQUIRE_GPU=1" : "");
    return gpu_required() ? 1 : 0;
  }
  if (skipped == 0) return 0;
  if (gpu_required()) {
    std::printf("[ verdict  ] FAILED: CDSM_REQUIRE_GPU=1 and %d of %d tests skipped:%s\n", skipped, ran,
                listed.c_str());
    return 1;
  }
  if (skipped == ran) {
    std::printf("[ verdict  ] all %d tests skipped (exit %d, \"Skipped\" in ctest):%s\n", ran, kAllSkipped,
                listed.c_str());
    return kAllSkipped;
  }
  std::printf("[ verdict  ] passed; %d of %d tests skipped:%s\n", skipped, ran, listed.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  const int code = RUN_ALL_TESTS();
  return verdict(code);
}
