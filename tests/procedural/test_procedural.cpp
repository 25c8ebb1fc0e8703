// Built-in content (procedural.h): closedness, analytic volumes, orientation,
// the Newell models from the shipped patch files, loader errors, noise volumes.
#include <algorithm>
#include <array>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "cdsm/error.h"
#include "cdsm/procedural.h"

namespace fs = std::filesystem;
using namespace cdsm;

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string newell_file(const char* name) { return std::string(CDSM_CONTENT_DIR_TEST) + "/meshes/newell/" + name; }

// Independent closedness check: weld vertices at identical positions, then
// every directed edge must occur once and its reverse once.
bool closed_by_edges(const TriangleMesh& m, std::string* why = nullptr) {
  std::map<std::tuple<float, float, float>, uint32_t> weld;
  std::vector<uint32_t> id(m.positions.size());
  for (size_t i = 0; i < m.positions.size(); ++i) {
    const Vec3 p = m.positions[i];
    id[i] = weld.emplace(std::make_tuple(p.x, p.y, p.z), uint32_t(weld.size())).first->second;
  }
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = id[m.indices[3 * t + k]], b = id[m.indices[3 * t + (k + 1) % 3]];
      if (a == b) {
        if (why) *why = "degenerate triangle " + std::to_string(t);
        return false;
      }
      ++directed[{a, b}];
    }
  }
  for (const auto& [e, n] : directed) {
    auto rev = directed.find({e.second, e.first});
    if (n != 1 || rev == directed.end() || rev->second != 1) {
      if (why)
        *why = "edge " + std::to_string(e.first) + "-" + std::to_string(e.second) + " used " + std::to_string(n) +
               " times, reverse " + std::to_string(rev == directed.end() ? 0 : rev->second);
      return false;
    }
  }
  return true;
}

// Enclosed volume by the divergence theorem (positive for outward winding).
double signed_volume(const TriangleMesh& m) {
  double v = 0.0;
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    const Vec3 a = m.positions[m.indices[3 * t]], b = m.positions[m.indices[3 * t + 1]];
    const Vec3 c = m.positions[m.indices[3 * t + 2]];
    v += double(a.x) * (double(b.y) * c.z - double(b.z) * c.y) + double(a.y) * (double(b.z) * c.x - double(b.x) * c.z) +
         double(a.z) * (double(b.x) * c.y - double(b.y) * c.x);
  }
  return v / 6.0;
}

Box3 bounds(const TriangleMesh& m) {
  Box3 b;
  for (Vec3 p : m.positions) b.grow(p);
  return b;
}

// Fraction of triangle corners whose vertex normal leans the face's way;
// also checks that there is one unit normal per vertex.
double normals_agreeing(const TriangleMesh& m) {
  EXPECT_EQ(m.normals.size(), m.positions.size());
  if (m.normals.size() != m.positions.size()) return 0.0;
  for (Vec3 n : m.normals) EXPECT_NEAR(length(n), 1.0f, 1e-4f);
  size_t agree = 0;
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    const uint32_t* f = &m.indices[3 * t];
    const Vec3 fn = cross(m.positions[f[1]] - m.positions[f[0]], m.positions[f[2]] - m.positions[f[0]]);
    for (int k = 0; k < 3; ++k) agree += dot(fn, m.normals[f[k]]) > 0.0f;
  }
  return double(agree) / double(3 * m.triangle_count());
}

// Every index refers to a vertex.
void expect_valid_indices(const TriangleMesh& m) {
  ASSERT_EQ(m.indices.size() % 3, 0u);
  for (uint32_t i : m.indices) ASSERT_LT(i, m.positions.size());
}

// ---- analytic shapes --------------------------------------------------------

TEST(Shapes, BoxIsClosedWithExactVolume) {
  const TriangleMesh m = make_box({2.0f, 3.0f, 0.5f});
  expect_valid_indices(m);
  std::string why;
  EXPECT_TRUE(closed_by_edges(m, &why)) << why;
  EXPECT_EQ(m.triangle_count(), 12u);
  EXPECT_NEAR(signed_volume(m), 3.0, 1e-5);
  const Box3 b = bounds(m);
  EXPECT_FLOAT_EQ(b.lo.x, -1.0f);
  EXPECT_FLOAT_EQ(b.hi.y, 1.5f);
  EXPECT_FLOAT_EQ(b.lo.z, -0.25f);
  EXPECT_DOUBLE_EQ(normals_agreeing(m), 1.0);
}

TEST(Shapes, SphereIsClosedWithinOnePercentOfAnalyticVolume) {
  const float r = 1.7f;
  const TriangleMesh m = make_sphere(r, 48, 24);
  expect_valid_indices(m);
  std::string why;
  EXPECT_TRUE(closed_by_edges(m, &why)) << why;
  const double exact = 4.0 / 3.0 * kPi * r * r * r;
  const double v = signed_volume(m);
  EXPECT_GT(v, 0.0);
  EXPECT_LT(v, exact);  // an inscribed polyhedron
  EXPECT_NEAR(v, exact, 0.01 * exact);
  // Poles are single vertices; no sliver triangles anywhere.
  int poles = 0;
  for (Vec3 p : m.positions) poles += std::fabs(std::fabs(p.y) - r) < 1e-6f;
  EXPECT_EQ(poles, 2);
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    const uint32_t* f = &m.indices[3 * t];
    const Vec3 n = cross(m.positions[f[1]] - m.positions[f[0]], m.positions[f[2]] - m.positions[f[0]]);
    EXPECT_GT(length(n), 1e-6f) << "triangle " << t;
  }
  for (size_t i = 0; i < m.positions.size(); ++i) EXPECT_NEAR(length(m.positions[i]), r, 1e-5f);
  EXPECT_DOUBLE_EQ(normals_agreeing(m), 1.0);
}

TEST(Shapes, CoarseSphereIsStillClosed) {
  const TriangleMesh m = make_sphere(1.0f, 3, 2);
  EXPECT_TRUE(closed_by_edges(m));
  EXPECT_EQ(m.triangle_count(), 6u);
  EXPECT_GT(signed_volume(m), 0.0);
}

TEST(Shapes, GroundIsAClosedSlabBelowZero) {
  const TriangleMesh m = make_ground(10.0f, 6.0f, 0.1f);
  std::string why;
  EXPECT_TRUE(closed_by_edges(m, &why)) << why;
  EXPECT_NEAR(signed_volume(m), 6.0, 1e-4);
  const Box3 b = bounds(m);
  EXPECT_FLOAT_EQ(b.hi.y, 0.0f);
  EXPECT_FLOAT_EQ(b.lo.y, -0.1f);
  EXPECT_FLOAT_EQ(b.hi.x, 5.0f);
  EXPECT_FLOAT_EQ(b.lo.z, -3.0f);
  EXPECT_DOUBLE_EQ(normals_agreeing(m), 1.0);
}

TEST(Shapes, QuadFacesUpAndIsOpen) {
  const TriangleMesh m = make_quad(2.0f, 4.0f);
  ASSERT_EQ(m.triangle_count(), 2u);
  EXPECT_FALSE(closed_by_edges(m));
  for (size_t t = 0; t < 2; ++t) {
    const uint32_t* f = &m.indices[3 * t];
    const Vec3 n = cross(m.positions[f[1]] - m.positions[f[0]], m.positions[f[2]] - m.positions[f[0]]);
    EXPECT_GT(n.y, 0.0f);
    EXPECT_FLOAT_EQ(n.x, 0.0f);
  }
  const Box3 b = bounds(m);
  EXPECT_FLOAT_EQ(b.hi.x, 1.0f);
  EXPECT_FLOAT_EQ(b.hi.z, 2.0f);
  EXPECT_FLOAT_EQ(b.extent().y, 0.0f);
  EXPECT_DOUBLE_EQ(normals_agreeing(m), 1.0);
}

// ---- Newell models ------------------------------------------------------------

// Bounding box of a patch file's control points, read independently.
Box3 control_point_bounds(const std::string& file) {
  std::ifstream in(file);
  int patches = 0, points = 0;
  std::string line;
  in >> patches;
  std::getline(in, line);
  for (int i = 0; i < patches; ++i) std::getline(in, line);
  in >> points;
  std::getline(in, line);
  Box3 b;
  for (int i = 0; i < points && std::getline(in, line); ++i) {
    Vec3 p;
    char c1, c2;
    std::istringstream(line) >> p.x >> c1 >> p.y >> c2 >> p.z;
    b.grow(p);
  }
  EXPECT_GT(points, 0) << file;
  return b;
}

// Bounding box of the corner control points of every patch (a Bezier patch
// passes through its four corners: the surface reaches at least this far).
Box3 patch_corner_bounds(const std::string& file) {
  std::ifstream in(file);
  int patches = 0, points = 0;
  std::string line;
  in >> patches;
  std::getline(in, line);
  std::vector<std::array<int, 16>> idx(static_cast<size_t>(patches));
  for (int i = 0; i < patches; ++i) {
    std::getline(in, line);
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream ls(line);
    for (int& k : idx[size_t(i)]) ls >> k;
  }
  in >> points;
  std::getline(in, line);
  std::vector<Vec3> cp;
  for (int i = 0; i < points && std::getline(in, line); ++i) {
    Vec3 p;
    char c1, c2;
    std::istringstream(line) >> p.x >> c1 >> p.y >> c2 >> p.z;
    cp.push_back(p);
  }
  Box3 b;
  for (const auto& patch : idx)
    for (int corner : {0, 3, 12, 15}) b.grow(cp.at(size_t(patch[size_t(corner)] - 1)));
  return b;
}

TEST(Newell, TeapotIsClosedOutwardAndYUp) {
  const std::string file = newell_file("teapot");
  const TriangleMesh m = make_newell_mesh(file, 8);
  expect_valid_indices(m);
  std::string why;
  EXPECT_TRUE(closed_by_edges(m, &why)) << why;
  EXPECT_GT(signed_volume(m), 20.0);
  // The file is z up: x spans [-3, 3.43] (handle to spout), z [0, 3.15], y [-2, 2].
  const Box3 cp = control_point_bounds(file);
  EXPECT_FLOAT_EQ(cp.lo.z, 0.0f);
  EXPECT_FLOAT_EQ(cp.hi.z, 3.15f);
  const Box3 b = bounds(m);
  EXPECT_NEAR(b.lo.x, -3.0f, 0.01f);
  EXPECT_NEAR(b.hi.x, 3.43f, 0.02f);
  EXPECT_FLOAT_EQ(b.lo.y, 0.0f);
  EXPECT_NEAR(b.hi.y, cp.hi.z - cp.lo.z, 0.01f);
  EXPECT_NEAR(b.lo.z, -2.0f, 0.01f);
  EXPECT_NEAR(b.hi.z, 2.0f, 0.01f);
  // The spout points to +x and rises: its tip is high up.
  float spout_tip_y = 0.0f;
  for (Vec3 p : m.positions)
    if (p.x > 3.3f) spout_tip_y = std::max(spout_tip_y, p.y);
  EXPECT_GT(spout_tip_y, 2.2f);
  EXPECT_GT(normals_agreeing(m), 0.995);
}

TEST(Newell, TeacupIsClosedOutwardAndStandsUpright) {
  const std::string file = newell_file("teacup");
  const TriangleMesh m = make_newell_mesh(file, 8);
  expect_valid_indices(m);
  std::string why;
  EXPECT_TRUE(closed_by_edges(m, &why)) << why;
  EXPECT_GT(signed_volume(m), 0.1);
  // Extents derived from the file (y up, like the mesh): the surface lies in
  // the hull of its control points and passes through every patch corner.
  const Box3 b = bounds(m), cp = control_point_bounds(file), corners = patch_corner_bounds(file);
  EXPECT_FLOAT_EQ(b.lo.y, 0.0f);
  for (int a : {0, 2}) {  // x, z (the mesh is only shifted in y, to rest on y = 0)
    EXPECT_GE(b.lo[a], cp.lo[a] - 1e-4f) << a;
    EXPECT_LE(b.hi[a], cp.hi[a] + 1e-4f) << a;
    EXPECT_LE(b.lo[a], corners.lo[a] + 1e-4f) << a;
    EXPECT_GE(b.hi[a], corners.hi[a] - 1e-4f) << a;
  }
  EXPECT_LE(b.hi.y - b.lo.y, cp.hi.y - cp.lo.y + 1e-4f);
  EXPECT_GE(b.hi.y - b.lo.y, corners.hi.y - corners.lo.y - 1e-4f);
  EXPECT_GT(normals_agreeing(m), 0.995);
}

TEST(Newell, TessellationConverges) {
  const double coarse = signed_volume(make_newell_mesh(newell_file("teapot"), 4));
  const TriangleMesh fine_mesh = make_newell_mesh(newell_file("teapot"), 16);
  const double fine = signed_volume(fine_mesh);
  EXPECT_TRUE(closed_by_edges(fine_mesh));
  EXPECT_LT(coarse, fine);
  EXPECT_NEAR(coarse, fine, 0.05 * fine);
  EXPECT_GT(fine_mesh.triangle_count(), 4 * make_newell_mesh(newell_file("teapot"), 4).triangle_count());
}

// A scratch directory for broken patch files, removed at the end.
class NewellErrors : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("cdsm_procedural_" + std::to_string(getpid()));
    fs::create_directories(dir_);
    std::ifstream in(newell_file("teapot"));
    std::string line;
    while (std::getline(in, line)) lines_.push_back(line);
    ASSERT_GT(lines_.size(), 300u);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Writes the teapot with line `n` (1-based) replaced; returns the path.
  std::string broken(const std::string& name, int n, const std::string& text) {
    const std::string path = (dir_ / name).string();
    std::ofstream out(path);
    for (size_t i = 0; i < lines_.size(); ++i) out << (int(i) + 1 == n ? text : lines_[i]) << "\n";
    return path;
  }

  // Loading `path` throws cdsm::Error naming it (and line `line` when > 0).
  void expect_error(const std::string& path, int line) {
    try {
      make_newell_mesh(path, 4);
      FAIL() << "no error for " << path;
    } catch (const Error& e) {
      EXPECT_NE(e.where().find(path), std::string::npos) << e.what();
      if (line > 0) {
        EXPECT_EQ(e.where(), path + ":" + std::to_string(line)) << e.what();
      }
      EXPECT_FALSE(e.problem().empty());
    }
  }

  fs::path dir_;
  std::vector<std::string> lines_;
};

TEST_F(NewellErrors, MissingFile) { expect_error((dir_ / "no_such_teapot").string(), 0); }

TEST_F(NewellErrors, NonNumericPatchCount) { expect_error(broken("count", 1, "thirty-two"), 1); }

TEST_F(NewellErrors, PatchCountBeyondTheFile) {
  // 400 patches: the point count and points are read as patch lines.
  expect_error(broken("too_many", 1, "400"), 34);
}

TEST_F(NewellErrors, ShortPatchLine) { expect_error(broken("short", 3, "4,17,18,19,8,20,21,22,12"), 3); }

TEST_F(NewellErrors, IndexOutOfRange) {
  expect_error(broken("range", 5, "31,41,42,1,34,43,44,5,37,45,46,9,40,47,48,999"), 5);
}

TEST_F(NewellErrors, ZeroIndex) { expect_error(broken("zero", 2, "0,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16"), 2); }

TEST_F(NewellErrors, NonNumericCoordinate) { expect_error(broken("coord", 40, "1.4,oops,2.4"), 40); }

TEST_F(NewellErrors, TruncatedPoints) {
  const std::string path = (dir_ / "truncated").string();
  std::ofstream out(path);
  for (size_t i = 0; i < 100; ++i) out << lines_[i] << "\n";
  out.close();
  expect_error(path, 0);
}

TEST_F(NewellErrors, BadPointCount) { expect_error(broken("points", 34, "-5"), 34); }

// The engine's own closedness test (scene.h) agrees with the one above.
TEST(Newell, EngineIsClosedAgrees) {
  EXPECT_TRUE(is_closed(make_newell_mesh(newell_file("teapot"), 8)));
  EXPECT_TRUE(is_closed(make_newell_mesh(newell_file("teacup"), 8)));
  EXPECT_TRUE(is_closed(make_box({1, 2, 3})));
  EXPECT_TRUE(is_closed(make_sphere(1.0f)));
  EXPECT_TRUE(is_closed(make_ground(4, 4)));
  EXPECT_FALSE(is_closed(make_quad(1, 1)));
}

// ---- noise volumes -------------------------------------------------------------

NoiseVolumeParams small_params(uint32_t seed, float plume) {
  NoiseVolumeParams p;
  p.nx = 24, p.ny = 40, p.nz = 20;
  p.seed = seed;
  p.plume = plume;
  p.density_scale = 2.5f;
  return p;
}

TEST(NoiseVolume, DeterministicPerSeed) {
  const auto a = make_noise_volume(small_params(7, 1.0f));
  const auto b = make_noise_volume(small_params(7, 1.0f));
  const auto c = make_noise_volume(small_params(8, 1.0f));
  ASSERT_EQ(a->values.size(), size_t(24 * 40 * 20));
  EXPECT_EQ(a->values, b->values);
  size_t differing = 0;
  for (size_t i = 0; i < a->values.size(); ++i) differing += std::fabs(a->values[i] - c->values[i]) > 1e-3f;
  EXPECT_GT(differing, a->values.size() / 20);
}

// Range, empty border and non-trivial content, for the plume and the ball.
void check_volume(const DenseGrid& g, float scale) {
  EXPECT_EQ(g.background, 0.0f);
  ASSERT_EQ(g.values.size(), size_t(g.nx) * g.ny * g.nz);
  float peak = 0.0f;
  for (int k = 0; k < g.nz; ++k)
    for (int j = 0; j < g.ny; ++j)
      for (int i = 0; i < g.nx; ++i) {
        const float v = g.at(i, j, k);
        ASSERT_GE(v, 0.0f);
        ASSERT_LE(v, scale);
        const bool border = i == 0 || j == 0 || k == 0 || i == g.nx - 1 || j == g.ny - 1 || k == g.nz - 1;
        if (border) {
          ASSERT_EQ(v, 0.0f) << i << "," << j << "," << k;
        }
        peak = std::max(peak, v);
      }
  EXPECT_GT(peak, 0.3f * scale);
}

TEST(NoiseVolume, PlumeInRangeWithEmptyBorder) {
  for (uint32_t seed : {1u, 2u, 99u}) check_volume(*make_noise_volume(small_params(seed, 1.0f)), 2.5f);
  check_volume(*make_noise_volume(NoiseVolumeParams{}), 1.0f);  // default 48x96x48
}

TEST(NoiseVolume, BallInRangeWithEmptyBorder) {
  for (uint32_t seed : {1u, 5u}) check_volume(*make_noise_volume(small_params(seed, 0.0f)), 2.5f);
}

TEST(NoiseVolume, PlumeIsDenseLowAndCentred) {
  const auto g = make_noise_volume(NoiseVolumeParams{});
  double low = 0.0, high = 0.0, centre = 0.0, side = 0.0;
  for (int k = 0; k < g->nz; ++k)
    for (int j = 0; j < g->ny; ++j)
      for (int i = 0; i < g->nx; ++i) {
        const float v = g->at(i, j, k);
        if (j < g->ny / 3) low += v;
        if (j >= 2 * g->ny / 3) high += v;
        const bool mid = std::abs(i - g->nx / 2) < g->nx / 6 && std::abs(k - g->nz / 2) < g->nz / 6;
        (mid ? centre : side) += v;
      }
  EXPECT_GT(low, high);
  // The centre column is a ninth of the cross-section but holds much more than that share.
  EXPECT_GT(centre / (centre + side), 0.2);
}

TEST(ContentDir, EnvironmentOverridesTheDefault) {
  const char* old = std::getenv("CDSM_CONTENT_DIR");
  const std::string saved = old ? old : "";
  setenv("CDSM_CONTENT_DIR", "/somewhere/content", 1);
  EXPECT_EQ(content_dir(), "/somewhere/content");
  setenv("CDSM_CONTENT_DIR", "", 1);
  EXPECT_EQ(content_dir(), CDSM_CONTENT_DIR_TEST);
  unsetenv("CDSM_CONTENT_DIR");
  EXPECT_EQ(content_dir(), CDSM_CONTENT_DIR_TEST);
  EXPECT_TRUE(fs::exists(content_dir() + "/meshes/newell/teapot"));
  if (old) setenv("CDSM_CONTENT_DIR", saved.c_str(), 1);
}

}  // namespace
