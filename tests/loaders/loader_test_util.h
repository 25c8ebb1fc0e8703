// Helpers of the loader tests: the shared data, a scratch directory for
// generated fixtures, byte-level file edits, and error expectations.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "cdsm/error.h"
#include "cdsm/loaders.h"

namespace cdsm_test {

inline std::string data_path(const std::string& rel) { return std::string(CDSM_DATA_DIR_TEST) + "/" + rel; }

// A fresh directory under the test output directory, per test.
inline std::string scratch_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string dir = std::string(CDSM_TEST_OUTPUT_DIR) + "/loaders/" + info->test_suite_name() + "." + info->name();
  std::string cmd = "rm -rf '" + dir + "' && mkdir -p '" + dir + "'";
  if (std::system(cmd.c_str()) != 0) ADD_FAILURE() << "cannot create " << dir;
  return dir;
}

inline std::vector<char> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(bool(in)) << "cannot read " << path;
  return std::vector<char>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

inline void write_bytes(const std::string& path, const std::vector<char>& b) {
  std::ofstream out(path, std::ios::binary);
  out.write(b.data(), std::streamsize(b.size()));
  ASSERT_TRUE(bool(out)) << "cannot write " << path;
}

inline void write_text(const std::string& path, const std::string& s) {
  write_bytes(path, std::vector<char>(s.begin(), s.end()));
}

inline std::string read_text(const std::string& path) {
  std::vector<char> b = read_bytes(path);
  return std::string(b.begin(), b.end());
}

// Copy of the first `n` bytes of `src`.
inline std::string truncated_copy(const std::string& src, size_t n, const std::string& dst) {
  std::vector<char> b = read_bytes(src);
  b.resize(std::min(n, b.size()));
  write_bytes(dst, b);
  return dst;
}

// Runs f, expects a cdsm::Error whose message holds every string of `parts`.
inline void expect_error(const std::function<void()>& f, const std::vector<std::string>& parts) {
  try {
    f();
    ADD_FAILURE() << "no error; expected one mentioning '" << (parts.empty() ? "" : parts[0]) << "'";
  } catch (const cdsm::Error& e) {
    std::string msg = e.what();
    for (const std::string& p : parts) EXPECT_NE(msg.find(p), std::string::npos) << "'" << p << "' not in: " << msg;
  }
}

// Signed volume of a closed mesh under a transform: > 0 when its triangles
// face outwards.
inline double signed_volume(const cdsm::TriangleMesh& m, const cdsm::Mat4& xf = cdsm::Mat4{}) {
  double v = 0.0;
  for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
    cdsm::Vec3 a = xf.point(m.positions[m.indices[t]]), b = xf.point(m.positions[m.indices[t + 1]]),
               c = xf.point(m.positions[m.indices[t + 2]]);
    v += double(cdsm::dot(a, cdsm::cross(b, c))) / 6.0;
  }
  return v;
}

// Captures loader warnings while alive.
struct WarningCapture {
  std::vector<std::string> lines;
  WarningCapture() {
    cdsm::set_warning_sink([this](const std::string& s) { lines.push_back(s); });
  }
  ~WarningCapture() { cdsm::set_warning_sink(nullptr); }
  std::string all() const {
    std::string s;
    for (const auto& l : lines) s += l + "\n";
    return s;
  }
};

}  // namespace cdsm_test
