// The loaders' from-memory entry points (used by the fuzz targets) against
// their file versions: same results, same errors, and no file system access
// from memory (external glTF buffers fail).
#include <gtest/gtest.h>

#include <cstring>

#include "cdsm/procedural.h"
#include "loader_test_util.h"

namespace cdsm_test {
namespace {

using namespace cdsm;

std::vector<unsigned char> file_bytes(const std::string& path) {
  std::vector<char> b = read_bytes(path);
  return std::vector<unsigned char>(b.begin(), b.end());
}

// The fuzz seeds of tests/fuzz/corpus (generated without third-party assets).
std::string fuzz_seed(const std::string& rel) { return content_dir() + "/../tests/fuzz/corpus/" + rel; }

void expect_same_scene(const Scene& a, const Scene& b) {
  EXPECT_EQ(a.source, b.source);
  ASSERT_EQ(a.objects.size(), b.objects.size());
  for (size_t i = 0; i < a.objects.size(); ++i) {
    const Object &x = a.objects[i], &y = b.objects[i];
    EXPECT_EQ(x.name, y.name);
    ASSERT_TRUE(x.mesh && y.mesh);
    EXPECT_EQ(x.mesh->indices, y.mesh->indices);
    ASSERT_EQ(x.mesh->positions.size(), y.mesh->positions.size());
    EXPECT_EQ(0,
              std::memcmp(x.mesh->positions.data(), y.mesh->positions.data(), x.mesh->positions.size() * sizeof(Vec3)));
    EXPECT_EQ(0, std::memcmp(&x.transform, &y.transform, sizeof(Mat4)));
    EXPECT_EQ(x.surface.opacity, y.surface.opacity);
    EXPECT_EQ(x.interior, y.interior);
    EXPECT_EQ(std::memcmp(&x.sigma, &y.sigma, sizeof x.sigma), 0);
  }
  ASSERT_EQ(a.lights.size(), b.lights.size());
  for (size_t i = 0; i < a.lights.size(); ++i) {
    EXPECT_EQ(a.lights[i].type, b.lights[i].type);
    EXPECT_EQ(0, std::memcmp(&a.lights[i].position, &b.lights[i].position, sizeof(Vec3)));
    EXPECT_EQ(a.lights[i].intensity, b.lights[i].intensity);
  }
  EXPECT_EQ(0, std::memcmp(&a.camera.position, &b.camera.position, sizeof(Vec3)));
  EXPECT_EQ(a.camera.fov_y_deg, b.camera.fov_y_deg);
}

TEST(FromMemory, GltfScenesMatchTheFileLoader) {
  for (const std::string& path : {fuzz_seed("fuzz_gltf/scene_embedded.gltf"), fuzz_seed("fuzz_gltf/scene.glb"),
                                  fuzz_seed("fuzz_gltf/triangle.gltf"), data_path("mesh/vsa_primitives_scene.gltf"),
                                  data_path("mesh/vsa_torusknot.gltf")}) {
    SCOPED_TRACE(path);
    const Scene from_file = load_gltf_scene(path);
    const Scene from_memory = load_gltf_scene_from_memory(file_bytes(path), path);
    expect_same_scene(from_file, from_memory);
  }
  // The seed scene has what the fuzz target should reach: two lights, a
  // camera, a translucent box, and a mirrored box with a constant interior.
  const Scene s = load_gltf_scene_from_memory(file_bytes(fuzz_seed("fuzz_gltf/scene.glb")), "seed.glb");
  EXPECT_EQ(s.source, "seed.glb");
  EXPECT_EQ(s.lights.size(), 2u);
  EXPECT_EQ(s.objects.size(), 3u);
  EXPECT_NEAR(s.camera.fov_y_deg, 0.7f * 180.0f / 3.14159265f, 1e-3f);
  EXPECT_FLOAT_EQ(s.objects[0].surface.opacity, 0.5f);
  EXPECT_EQ(s.objects[1].interior, InteriorKind::Constant);
}

TEST(FromMemory, GltfExternalBuffersAreNotRead) {
  // Box.gltf's buffer is the external Box0.bin beside it: found from the
  // file, never from memory (whatever the current directory holds).
  const std::string path = data_path("mesh/khronos_Box/Box.gltf");
  EXPECT_NO_THROW(load_gltf_scene(path));
  expect_error([&] { load_gltf_scene_from_memory(file_bytes(path), "box in memory.gltf"); },
               {"box in memory.gltf: ", "invalid glTF file"});
  expect_error([&] { load_gltf_scene_from_memory(file_bytes(fuzz_seed("fuzz_gltf/external_buffer.gltf")), "x.gltf"); },
               {"x.gltf: ", "box.bin"});
  // Errors name the buffer's name as the file loader names the path.
  std::vector<unsigned char> cut = file_bytes(fuzz_seed("fuzz_gltf/scene.glb"));
  cut.resize(cut.size() / 2);
  expect_error([&] { load_gltf_scene_from_memory(cut, "half.glb"); }, {"half.glb: ", "invalid or truncated .glb file"});
  expect_error([&] { load_gltf_scene_from_memory({}, "empty.gltf"); }, {"empty.gltf: "});
  // The file loader is itself again afterwards (even for that name).
  expect_error([&] { load_gltf_scene("half.glb"); }, {"half.glb", "not found"});
}

TEST(FromMemory, RawMatchesTheFileLoader) {
  RawVolumeDesc d;
  d.nx = d.ny = d.nz = 32;
  const std::string path = data_path("raw/bucky_32x32x32_uint8.raw");
  const std::vector<unsigned char> bytes = file_bytes(path);
  EXPECT_EQ(load_raw(path, d)->values, load_raw_from_memory(bytes, path, d)->values);
  // 16-bit, big-endian, after a header: 32 bytes = 8 + 12 voxels of 2 bytes.
  d.nx = 3, d.ny = 2, d.nz = 2;
  d.format = RawFormat::UInt16;
  d.big_endian = true;
  d.header_bytes = 8;
  const std::string dir = scratch_dir();
  std::vector<char> b16(32);
  for (size_t i = 0; i < b16.size(); ++i) b16[i] = char(i * 37);
  write_bytes(dir + "/v.raw", b16);
  const std::vector<unsigned char> u16(b16.begin(), b16.end());
  EXPECT_EQ(load_raw(dir + "/v.raw", d)->values, load_raw_from_memory(u16, dir + "/v.raw", d)->values);
  // The same errors.
  d.nx = 4;
  std::string file_error, memory_error;
  try {
    load_raw(dir + "/v.raw", d);
  } catch (const Error& e) {
    file_error = e.what();
  }
  try {
    load_raw_from_memory(u16, dir + "/v.raw", d);
  } catch (const Error& e) {
    memory_error = e.what();
  }
  EXPECT_NE(file_error.find("need 40"), std::string::npos) << file_error;
  EXPECT_EQ(file_error, memory_error);
  // A header beyond the data, also where header + voxel bytes wraps around
  // 2^64 to the data's size (a file read fails there; memory must not be read).
  d.nx = 6;
  d.header_bytes = ~uint64_t(0) - 15;  // 2^64 - 16, + 48 voxel bytes = 32 (mod 2^64)
  expect_error([&] { load_raw_from_memory(u16, "wrap.raw", d); },
               {"wrap.raw", "header", "longer than the 32-byte data"});
  d.header_bytes = 0;
  d.nz = 0;
  expect_error([&] { load_raw_from_memory(u16, "zero.raw", d); }, {"zero.raw", ">= 1"});
}

TEST(FromMemory, VdbMatchesTheFileLoader) {
  if (!vdb_supported()) {
    expect_error([] { load_vdb_from_memory({}, "x.vdb"); }, {"x.vdb", "CDSM_VDB=OFF"});
    GTEST_SKIP() << "built with CDSM_VDB=OFF";
  }
  const std::pair<std::string, std::string> files[] = {{data_path("vdb/vpt_box_fog.vdb"), "density"},
                                                       {data_path("vdb/arnoldusd_torus_fog.vdb"), "voxel_fog_density"},
                                                       {fuzz_seed("fuzz_vdb/half_zip_rotated.vdb"), "density"},
                                                       {fuzz_seed("fuzz_vdb/sparse_tile_mask.vdb"), "density"}};
  for (const auto& [path, grid] : files) {
    SCOPED_TRACE(path);
    const VdbVolume a = load_vdb(path, grid), b = load_vdb_from_memory(file_bytes(path), path, grid);
    ASSERT_EQ(a.grid->nanovdb_bytes, b.grid->nanovdb_bytes);
    EXPECT_EQ(0, std::memcmp(a.grid->data(), b.grid->data(), a.grid->nanovdb_bytes));
    EXPECT_EQ(0, std::memcmp(&a.index_to_object, &b.index_to_object, sizeof(Mat4)));
    EXPECT_EQ(a.grid->active_voxels, b.grid->active_voxels);
  }
  const std::vector<unsigned char> box = file_bytes(data_path("vdb/vpt_box_fog.vdb"));
  expect_error([&] { load_vdb_from_memory(box, "box.vdb", "nothing"); }, {"box.vdb: ", "no grid named 'nothing'"});
  expect_error([&] { load_vdb_from_memory(file_bytes(fuzz_seed("fuzz_vdb/two_density.vdb")), "two.vdb"); },
               {"two.vdb: ", "2 grids are named 'density'"});
  for (size_t n : {size_t(0), size_t(7), size_t(200), box.size() / 2, box.size() - 1}) {
    SCOPED_TRACE(n);
    const std::vector<unsigned char> cut(box.begin(), box.begin() + std::ptrdiff_t(n));
    expect_error([&] { load_vdb_from_memory(cut, "cut.vdb"); }, {"cut.vdb: "});
  }
}

}  // namespace
}  // namespace cdsm_test
