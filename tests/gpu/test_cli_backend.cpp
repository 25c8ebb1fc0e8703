// `cdsm render --backend` as a user meets it (issue 16 item 6): the default
// prints which backend runs and why on stderr; without a CUDA device (here
// forced with CDSM_CUDA_DISABLE=1, so this holds on GPU machines too) the
// default is cpu and the frame renders, exit 0; --backend cuda then fails
// with the same reason in one line, exit 1, before any rendering work.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "common/cli_run.h"

namespace {

using cdsm_test::CliRun;
using cdsm_test::slurp;

std::string dir() { return cdsm_test::cli_output_dir("cli_backend"); }

CliRun cdsm(const std::string& env, const std::string& args) {
  return cdsm_test::run_program(CDSM_EXE, env, args, dir());
}

const std::string kScene = std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/default.json";
const std::string kSmall = " --width 24 --height 16 --dsm-res 32 --fragments cpu ";
const std::string kNoGpu = "CDSM_CUDA_DISABLE=1";

// The stderr line that starts with `prefix` (empty if none).
std::string line_of(const std::string& text, const std::string& prefix) {
  std::istringstream in(text);
  std::string l;
  while (std::getline(in, l))
    if (l.rfind(prefix, 0) == 0) return l;
  return "";
}

}  // namespace

TEST(CliBackend, DefaultWithoutDeviceFallsBackToCpuAndSaysWhy) {
  const std::string png = dir() + "/fallback.png", stats = dir() + "/fallback.json";
  std::remove(png.c_str());
  CliRun r = cdsm(kNoGpu, "render '" + kScene + "'" + kSmall + "-o '" + png + "' --stats '" + stats + "'");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(line_of(r.err, "cdsm: backend "), "cdsm: backend cpu: no CUDA device: disabled by CDSM_CUDA_DISABLE")
      << r.err;
  EXPECT_EQ(::access(png.c_str(), F_OK), 0) << "the frame was rendered";
  EXPECT_EQ(nlohmann::json::parse(slurp(stats))["backend"], "cpu");
}

TEST(CliBackend, CudaByNameWithoutDeviceFailsWithTheSameReason) {
  const std::string png = dir() + "/refused.png";
  std::remove(png.c_str());
  CliRun r = cdsm(kNoGpu, "render '" + kScene + "'" + kSmall + "-o '" + png + "' --backend cuda");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_EQ(r.err, "cdsm: error: --backend cuda: no CUDA device: disabled by CDSM_CUDA_DISABLE\n");
  EXPECT_NE(::access(png.c_str(), F_OK), 0) << "nothing rendered";
  EXPECT_EQ(r.out.find("scene "), std::string::npos) << r.out;
}

// The CUDA fragment producer runs on the cuda backend: without a device it
// is refused by name before anything is rendered (the library's refusal on
// the cpu backend: test_backend_choice).
TEST(CliBackend, CudaFragmentsNeedTheCudaBackend) {
  const std::string png = dir() + "/cuda-fragments.png";
  std::remove(png.c_str());
  CliRun r = cdsm(kNoGpu, "render '" + kScene + "'" + kSmall + "-o '" + png + "' --fragments cuda");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_EQ(r.err,
            "cdsm: error: --fragments cuda: the CUDA fragment producer needs the cuda backend (no CUDA device: "
            "disabled by CDSM_CUDA_DISABLE)\n");
  EXPECT_NE(::access(png.c_str(), F_OK), 0) << "nothing rendered";
}

TEST(CliBackend, ExplicitCpuAndReferenceSayRequested) {
  CliRun r = cdsm("", "render '" + kScene + "'" + kSmall + "-o '" + dir() + "/cpu.png' --backend cpu");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(line_of(r.err, "cdsm: backend "), "cdsm: backend cpu: requested");
  r = cdsm("", "render '" + kScene + "'" + kSmall + "-o '" + dir() + "/ref.png' --backend reference");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(line_of(r.err, "cdsm: backend "), "cdsm: backend reference: requested");
}

// On this machine, whatever it has: the default names a backend that ran.
TEST(CliBackend, DefaultNamesTheBackendThatRan) {
  const std::string stats = dir() + "/default.json";
  CliRun r = cdsm("", "render '" + kScene + "'" + kSmall + "-o '" + dir() + "/default.png' --stats '" + stats + "'");
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string l = line_of(r.err, "cdsm: backend ");
  const std::string name = nlohmann::json::parse(slurp(stats))["backend"];
  EXPECT_EQ(l.rfind("cdsm: backend " + name + ": ", 0), 0u) << l;
  if (name == "cpu") {
    EXPECT_NE(l.find("no CUDA device"), std::string::npos) << l;
  }
}

TEST(CliBackend, UnknownBackendListsTheChoices) {
  CliRun r = cdsm("", "render '" + kScene + "'" + kSmall + "-o '" + dir() + "/x.png' --backend vulkan");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("unknown backend 'vulkan' (cuda, cpu or reference)"), std::string::npos) << r.err;
}

TEST(CliBackend, BenchRefusesCudaWithoutDevice) {
  CliRun r = cdsm(kNoGpu, "bench '" + kScene + "' --backends cuda --out '" + dir() + "/bench'");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("--backends cuda: no CUDA device: disabled by CDSM_CUDA_DISABLE"), std::string::npos) << r.err;
}
