// Scene files that use real content: the demo scenes render, files are
// found relative to the scene, under $SHARED or in the shared data
// directory, and a missing file says which and where it was looked for.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

#include "cdsm/renderer.h"
#include "cdsm/scene_io.h"
#include "loader_test_util.h"

namespace cdsm_test {
namespace {

using namespace cdsm;

std::string scene_path(const char* name) { return std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/" + name; }

// Renders at a small size with the CPU fragment source; returns the mean
// luminance and checks the image is finite and not flat.
double render_small(Scene s, int w, int h, FrameStats* stats = nullptr) {
  s.camera.width = w;
  s.camera.height = h;
  s.shadows.resolution = std::min(s.shadows.resolution, 256);
  Renderer r;
  RenderOptions opt;
  opt.fragments = FragmentSource::Cpu;
  FrameStats local;
  Image img = r.render(s, opt, stats ? stats : &local);
  EXPECT_EQ(img.width, w);
  EXPECT_EQ(img.height, h);
  double sum = 0.0, lo = 1e9, hi = -1e9;
  for (size_t i = 0; i < img.rgb.size(); ++i) {
    double v = img.rgb[i];
    EXPECT_TRUE(std::isfinite(v));
    sum += v;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  EXPECT_GT(hi - lo, 0.05) << s.source << " renders flat";
  return sum / double(img.rgb.size());
}

TEST(DemoScenes, Render) {
  for (const char* name : {"ct_xray.json", "primitives.json", "smoke_gltf.json"}) {
    if (std::string(name) == "smoke_gltf.json" && !vdb_supported()) {
      expect_error([&] { load_scene(scene_path(name)); }, {"CDSM_VDB=OFF", "openvdb_smoke1_density.vdb"});
      continue;
    }
    Scene s = load_scene(scene_path(name));
    FrameStats st;
    double mean = render_small(s, 72, 48, &st);
    EXPECT_GT(mean, 0.01) << name;
    EXPECT_GT(st.memory.nodes, 0u) << name;
  }
}

TEST(DemoScenes, VolumesAndMeshesAreWhatTheDataSays) {
  Scene ct = load_scene(scene_path("ct_xray.json"));
  ASSERT_EQ(ct.volumes.size(), 1u);
  EXPECT_EQ(ct.volumes[0].grid->nx, 128);
  EXPECT_EQ(ct.volumes[0].shading, VolumeShading::Phong);
  Scene prim = load_scene(scene_path("primitives.json"));
  size_t tris = 0;
  for (const Object& o : prim.objects)
    if (o.name != "ground") {
      tris += o.mesh->triangle_count();
      EXPECT_TRUE(is_closed(*o.mesh)) << o.name;
    }
  EXPECT_EQ(tris, 3636u);  // each node alone: Sphere_1 without its children
}

TEST(GltfScene, RendersAsAWholeScene) {
  WarningCapture w;  // "no light: a default spot light"
  Scene s = load_scene(data_path("mesh/vsa_geosphere.gltf"));
  EXPECT_EQ(s.objects.size(), 1u);
  render_small(s, 48, 32);
  EXPECT_NE(w.all().find("default spot light"), std::string::npos) << w.all();
}

const char* kMeshScene = R"({"camera": {"position": [0, 1, 5], "target": [0, 0, 0]},
  "objects": [{"mesh": {"type": "gltf", "file": "FILE"}}], "lights": [{"type": "point", "position": [0, 4, 0]}]})";

std::string with_file(const std::string& file) {
  std::string s = kMeshScene;
  return s.replace(s.find("FILE"), 4, file);
}

TEST(AssetPaths, RelativeSharedAndMissing) {
  std::string dir = scratch_dir();
  write_bytes(dir + "/box.gltf", read_bytes(data_path("mesh/khronos_Box/Box.gltf")));
  write_bytes(dir + "/Box0.bin", read_bytes(data_path("mesh/khronos_Box/Box0.bin")));
  // Relative to the scene file.
  EXPECT_EQ(parse_scene(with_file("box.gltf"), dir + "/s.json", dir).objects[0].mesh->triangle_count(), 12u);
  // $SHARED/... and a relative path found in the data directory (the
  // repository's content/data, from the build tree).
  EXPECT_EQ(
      parse_scene(with_file("$SHARED/mesh/vsa_geosphere.gltf"), dir + "/s.json", dir).objects[0].mesh->triangle_count(),
      1280u);
  EXPECT_EQ(parse_scene(with_file("mesh/vsa_geosphere.gltf"), dir + "/s.json", dir).objects[0].mesh->triangle_count(),
            1280u);
  // Missing: which file, and every place looked in.
  expect_error([&] { parse_scene(with_file("nowhere.gltf"), dir + "/s.json", dir); },
               {dir + "/s.json: /objects/0/mesh/file", "'nowhere.gltf' not found", dir + "/nowhere.gltf",
                data_dir() + "/nowhere.gltf"});
  EXPECT_EQ(data_dir(), std::string(CDSM_CONTENT_DIR_TEST) + "/data");
  expect_error([&] { parse_scene(with_file("$SHARED/mesh/nope.glb"), dir + "/s.json", dir); },
               {"'$SHARED/mesh/nope.glb' not found", data_dir() + "/mesh/nope.glb",
                "the data directory " + data_dir() + " is the content directory's data/; $CDSM_DATA_DIR overrides it"});
  // $CDSM_DATA_DIR moves the data directory, and the message says so.
  ::setenv("CDSM_DATA_DIR", dir.c_str(), 1);
  EXPECT_EQ(data_dir(), dir);
  EXPECT_EQ(
      parse_scene(with_file("$SHARED/box.gltf"), dir + "/x.json", "/nonexistent").objects[0].mesh->triangle_count(),
      12u);
  expect_error([&] { parse_scene(with_file("$SHARED/mesh/vsa_geosphere.gltf"), dir + "/s.json", dir); },
               {dir + "/mesh/vsa_geosphere.gltf", "the data directory " + dir + " is $CDSM_DATA_DIR"});
  ::unsetenv("CDSM_DATA_DIR");
}

// A directory where a file is expected is reported as a directory, by every
// loader and by scene references (issue "No silent wrong answers", item 8).
TEST(AssetPaths, DirectoriesAreNotFiles) {
  std::string dir = scratch_dir();
  std::string sub = dir + "/folder.gltf";
  ASSERT_EQ(
      std::system(
          ("mkdir -p '" + sub + "' '" + dir + "/scene.json' '" + dir + "/grid.vdb' '" + dir + "/scan.raw'").c_str()),
      0);
  expect_error([&] { load_scene(dir + "/scene.json"); }, {dir + "/scene.json", "is a directory"});
  expect_error([&] { load_scene(sub); }, {sub, "is a directory"});
  expect_error([&] { load_gltf_mesh(sub); }, {sub, "is a directory"});
  RawVolumeDesc raw;
  raw.nx = raw.ny = raw.nz = 2;
  expect_error([&] { load_raw(dir + "/scan.raw", raw); }, {dir + "/scan.raw", "is a directory"});
  expect_error([&] { parse_scene(with_file("folder.gltf"), dir + "/s.json", dir); },
               {dir + "/s.json: /objects/0/mesh/file", sub, "is a directory"});
  if (vdb_supported()) expect_error([&] { load_vdb(dir + "/grid.vdb"); }, {dir + "/grid.vdb", "is a directory"});
}

TEST(SceneFields, VolumeFieldErrors) {
  std::string dir = scratch_dir();
  auto volume_scene = [](const std::string& volume) {
    return R"({"camera": {"position": [0, 1, 5], "target": [0, 0, 0]},
      "volumes": [)" +
           volume + R"(],
      "objects": [{"interior": {"type": "volume", "volume": 0}}], "lights": [{"type": "point", "position": [0, 4, 0]}]})";
  };
  const std::string tf = R"("transfer": [{"density": 0, "extinction": 0}, {"density": 1, "extinction": 1}])";
  expect_error(
      [&] {
        parse_scene(volume_scene(R"({"grid": {"type": "noise"}, "proxy": "leaves", )" + tf + "}"), "s.json", dir);
      },
      {"/volumes/0/proxy", "sparse"});
  expect_error(
      [&] { parse_scene(volume_scene(R"({"grid": {"type": "noise"}, "proxy": "hull", )" + tf + "}"), "s.json", dir); },
      {"/volumes/0/proxy", "box or leaves"});
  expect_error(
      [&] {
        parse_scene(
            volume_scene(R"({"grid": {"type": "vdb", "file": "$SHARED/vdb/vpt_box_fog.vdb"}, "voxel_size": 1, )" + tf +
                         "}"),
            "s.json", dir);
      },
      {"/volumes/0", "own transform"});
  expect_error(
      [&] {
        parse_scene(
            volume_scene(R"({"grid": {"type": "vdb", "file": "$SHARED/vdb/arnoldusd_torus_fog.vdb"}, )" + tf + "}"),
            "s.json", dir);
      },
      vdb_supported()
          ? std::vector<std::string>{"s.json: /volumes/0/grid/file", "no grid named 'density'", "voxel_fog_density"}
          : std::vector<std::string>{"s.json: /volumes/0/grid/file", "CDSM_VDB=OFF"});
  expect_error([&] { parse_scene(volume_scene(R"({"grid": {"type": "openvdb"}, )" + tf + "}"), "s.json", dir); },
               {"/volumes/0/grid/type", "noise, dense, raw or vdb"});
}

}  // namespace
}  // namespace cdsm_test
