// Raw scalar volumes: the shared 8-bit scans, generated 16-bit fixtures in
// both byte orders, sizes that do not match, and raw grids in scene files.
#include <gtest/gtest.h>

#include <cmath>

#include "cdsm/scene_io.h"
#include "scene_compile.h"
#include "hd/volume.h"
#include "loader_test_util.h"
#include "common/system_frame.h"

namespace cdsm_test {
namespace {

using namespace cdsm;

struct SharedRaw {
  const char* file;
  int n;
};

TEST(RawVolume, SharedScansLoadWithTheirDimensions) {
  const SharedRaw raws[] = {{"raw/fuel_64x64x64_uint8.raw", 64},
                            {"raw/neghip_64x64x64_uint8.raw", 64},
                            {"raw/bucky_32x32x32_uint8.raw", 32},
                            {"raw/hydrogen_atom_128x128x128_uint8.raw", 128}};
  for (const SharedRaw& r : raws) {
    RawVolumeDesc d;
    d.nx = d.ny = d.nz = r.n;
    auto g = load_raw(data_path(r.file), d);
    ASSERT_EQ(g->values.size(), size_t(r.n) * r.n * r.n) << r.file;
    float lo = 1e9f, hi = -1e9f;
    for (float v : g->values) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
    EXPECT_GE(lo, 0.0f) << r.file;
    EXPECT_LE(hi, 1.0f) << r.file;
    EXPECT_GT(hi, lo) << r.file << " is constant";
  }
  // The first byte of the hydrogen atom, as the file has it (x fastest).
  std::vector<char> bytes = read_bytes(data_path("raw/hydrogen_atom_128x128x128_uint8.raw"));
  RawVolumeDesc d;
  d.nx = d.ny = d.nz = 128;
  d.normalize = false;
  auto g = load_raw(data_path("raw/hydrogen_atom_128x128x128_uint8.raw"), d);
  for (size_t i : {size_t(0), size_t(1), size_t(128), size_t(128 * 128 * 64 + 128 * 64 + 64)})
    EXPECT_EQ(g->values[i], float(static_cast<unsigned char>(bytes[i]))) << i;
}

// 16-bit voxels v(i,j,k) = 1000 i + 100 j + k + 7 (distinct high and low bytes).
std::vector<char> raw16(int nx, int ny, int nz, bool big_endian, size_t header) {
  std::vector<char> b(header, char(0x5a));
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        unsigned v = unsigned(1000 * i + 100 * j + k + 7);
        char hi = char(v >> 8), lo = char(v & 0xffu);
        if (big_endian) {
          b.push_back(hi);
          b.push_back(lo);
        } else {
          b.push_back(lo);
          b.push_back(hi);
        }
      }
  return b;
}

TEST(RawVolume, SixteenBitBothByteOrders) {
  std::string dir = scratch_dir();
  for (bool big : {false, true}) {
    std::string path = dir + (big ? "/be.raw" : "/le.raw");
    write_bytes(path, raw16(5, 4, 3, big, 16));
    RawVolumeDesc d;
    d.nx = 5, d.ny = 4, d.nz = 3;
    d.format = RawFormat::UInt16;
    d.big_endian = big;
    d.header_bytes = 16;
    d.normalize = false;
    auto g = load_raw(path, d);
    for (int k = 0; k < 3; ++k)
      for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 5; ++i) ASSERT_EQ(g->at(i, j, k), float(1000 * i + 100 * j + k + 7)) << big;
    d.normalize = true;
    g = load_raw(path, d);
    EXPECT_FLOAT_EQ(g->at(4, 3, 2), float(4000 + 300 + 2 + 7) / 65535.0f);
  }
}

TEST(RawVolume, DimensionsThatDoNotMatchTheFileSize) {
  std::string dir = scratch_dir();
  std::string path = dir + "/v.raw";
  write_bytes(path, raw16(5, 4, 3, false, 0));  // 120 bytes
  RawVolumeDesc d;
  d.nx = 5, d.ny = 4, d.nz = 3;
  d.format = RawFormat::UInt16;
  d.nz = 4;
  expect_error([&] { load_raw(path, d); }, {path, "120 bytes", "5x4x4", "need 160"});
  d.nz = 3;
  d.format = RawFormat::UInt8;  // 60 bytes expected; the size fits 16-bit voxels
  expect_error([&] { load_raw(path, d); }, {path, "need 60", "fits 16-bit"});
  d.nx = 0;
  expect_error([&] { load_raw(path, d); }, {path, ">= 1"});
  d.nx = 5;
  expect_error([&] { load_raw(dir + "/missing.raw", d); }, {dir + "/missing.raw", "raw volume not found"});
  // A truncated shared scan.
  std::string cut = truncated_copy(data_path("raw/bucky_32x32x32_uint8.raw"), 32768 - 1, dir + "/bucky_cut.raw");
  d = RawVolumeDesc{};
  d.nx = d.ny = d.nz = 32;
  expect_error([&] { load_raw(cut, d); }, {cut, "32767 bytes", "need 32768"});
}

std::string raw_scene(const std::string& grid, const std::string& volume_extra = "") {
  return R"({"camera": {"position": [0, 0.5, 3], "target": [0, 0.1, 0], "width": 48, "height": 32},
    "volumes": [{"name": "v", "grid": )" +
         grid + volume_extra + R"(, "shading": "phong",
                 "transfer": [{"density": 0, "extinction": 0}, {"density": 1, "extinction": 20}]}],
    "objects": [{"name": "v", "interior": {"type": "volume", "volume": "v"}, "material": {"opacity": 0}}],
    "lights": [{"type": "spot", "position": [0, 3, 1], "target": [0, 0, 0]}]})";
}

TEST(RawVolume, SceneFileFields) {
  std::string dir = scratch_dir();
  write_bytes(dir + "/be.raw", raw16(5, 4, 3, true, 0));
  Scene s = parse_scene(raw_scene(R"({"type": "raw", "file": "be.raw", "dims": [5, 4, 3], "format": "uint16",
      "byte_order": "big", "normalize": false, "spacing": [0.1, 0.2, 0.3]})"),
                        dir + "/s.json", dir);
  ASSERT_EQ(s.volumes.size(), 1u);
  ASSERT_TRUE(s.volumes[0].grid);
  EXPECT_EQ(s.volumes[0].grid->at(2, 1, 0), float(2000 + 100 + 7));
  // Spacing is the voxel size: voxel (1,1,1) at origin + 1.5 * spacing.
  Vec3 p = s.volumes[0].index_to_object.point({1, 1, 1});
  EXPECT_NEAR(p.x, 0.15f, 1e-6f);
  EXPECT_NEAR(p.y, 0.30f, 1e-6f);
  EXPECT_NEAR(p.z, 0.45f, 1e-6f);
  // The proxy box spans the grid: 5*0.1 x 4*0.2 x 3*0.3.
  Box3 b = world_bounds(*s.objects[0].mesh, Mat4{});
  EXPECT_NEAR(b.hi.x - b.lo.x, 0.5f, 1e-6f);
  EXPECT_NEAR(b.hi.y - b.lo.y, 0.8f, 1e-6f);
  EXPECT_NEAR(b.hi.z - b.lo.z, 0.9f, 1e-6f);
  EXPECT_TRUE(is_closed(*s.objects[0].mesh));

  // Errors name the scene location and the raw file.
  expect_error(
      [&] {
        parse_scene(raw_scene(R"({"type": "raw", "file": "be.raw", "dims": [5, 4, 4], "format": "uint16"})"),
                    dir + "/s.json", dir);
      },
      {dir + "/s.json: /volumes/0/grid/file", dir + "/be.raw", "need 160"});
  expect_error(
      [&] {
        parse_scene(raw_scene(R"({"type": "raw", "file": "be.raw", "dims": [5, 4, 3], "format": "uint12"})"),
                    dir + "/s.json", dir);
      },
      {"/volumes/0/grid/format", "uint8 or uint16"});
  expect_error(
      [&] {
        parse_scene(raw_scene(R"({"type": "raw", "file": "nothere.raw", "dims": [5, 4, 3]})"), dir + "/s.json", dir);
      },
      {"/volumes/0/grid/file", "'nothere.raw' not found", dir + "/nothere.raw", "data directory"});
  expect_error(
      [&] {
        parse_scene(raw_scene(R"({"type": "raw", "file": "be.raw", "dims": [5, 4, 3], "format": "uint16",
                             "spacing": 0.1})",
                              R"(, "voxel_size": 0.1)"),
                    dir + "/s.json", dir);
      },
      {"spacing", "voxel_size", "not both"});
}

// The gradient of a raw grid (phong shading) through the shared sampling:
// a linear ramp along x has a constant gradient along x.
TEST(RawVolume, GradientOfARampForPhongShading) {
  std::string dir = scratch_dir();
  std::vector<char> b;
  for (int k = 0; k < 6; ++k)
    for (int j = 0; j < 6; ++j)
      for (int i = 0; i < 6; ++i) b.push_back(char(40 * i));
  write_bytes(dir + "/ramp.raw", b);
  Scene s =
      parse_scene(raw_scene(R"({"type": "raw", "file": "ramp.raw", "dims": [6, 6, 6]})", R"(, "voxel_size": 0.5)"),
                  dir + "/s.json", dir);
  SceneBuffers sb = compiled_scene(s);
  SceneView v = sb.view();
  Vec3 g = density_gradient(v, v.volumes[0], s.volumes[0].index_to_object.point({2.5f, 2.5f, 2.5f}));
  EXPECT_NEAR(g.x, 40.0f / 255.0f / 0.5f, 1e-4f);  // per world unit
  EXPECT_NEAR(g.y, 0.0f, 1e-6f);
  EXPECT_NEAR(g.z, 0.0f, 1e-6f);
}

}  // namespace
}  // namespace cdsm_test
