// Scene files round trip (engine/src/scene_write.cpp): every shipped scene,
// a whole glTF scene and a scene built in code load, save and reload to an
// equal scene (field by field, floats bit for bit), and saving the reloaded
// scene writes the same text. Bad paths and scenes a file cannot hold are
// errors naming the path and the field; a refused save leaves no file.
#include <dirent.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "cdsm/error.h"
#include "cdsm/loaders.h"
#include "cdsm/procedural.h"
#include "cdsm/scene_io.h"
#include "common/builders.h"
#include "editor/scene_equal.h"

namespace cdsm_test {
namespace {

using namespace cdsm;
using nlohmann::json;

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(bool(in)) << "cannot read " << path;
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  ASSERT_TRUE(bool(out)) << "cannot write " << path;
}

// A fresh directory under the test output directory, per test (and tag).
std::string scratch_dir(const std::string& tag = "") {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = std::string(info->test_suite_name()) + "." + info->name() + tag;
  for (char& c : name)
    if (c == '/') c = '_';
  std::string dir = std::string(CDSM_TEST_OUTPUT_DIR) + "/scene_write/" + name;
  std::string cmd = "rm -rf '" + dir + "' && mkdir -p '" + dir + "'";
  if (std::system(cmd.c_str()) != 0) ADD_FAILURE() << "cannot create " << dir;
  return dir;
}

std::vector<std::string> files_in(const std::string& dir) {
  std::vector<std::string> out;
  if (DIR* d = opendir(dir.c_str())) {
    while (dirent* e = readdir(d))
      if (std::string(e->d_name) != "." && std::string(e->d_name) != "..") out.push_back(e->d_name);
    closedir(d);
  }
  return out;
}

// Runs f, expects a cdsm::Error whose message holds every string of `parts`.
void expect_error(const std::function<void()>& f, const std::vector<std::string>& parts) {
  try {
    f();
    ADD_FAILURE() << "no error; expected one mentioning '" << (parts.empty() ? "" : parts[0]) << "'";
  } catch (const Error& e) {
    const std::string msg = e.what();
    for (const std::string& p : parts) EXPECT_NE(msg.find(p), std::string::npos) << "'" << p << "' not in: " << msg;
  }
}

// The first line where two texts differ (both lines), or "".
std::string first_difference(const std::string& a, const std::string& b) {
  std::istringstream x(a), y(b);
  std::string la, lb;
  for (int line = 1;; ++line) {
    const bool ga = bool(std::getline(x, la)), gb = bool(std::getline(y, lb));
    if (!ga && !gb) return "";
    if (!ga || !gb || la != lb)
      return "line " + std::to_string(line) + ":\n  " + (ga ? la.substr(0, 300) : "(end)") + "\n  " +
             (gb ? lb.substr(0, 300) : "(end)");
  }
}

// Saves `a` to dir/first.json, reloads, compares, saves the reloaded scene
// to dir/second.json and compares the texts. Returns the reloaded scene.
Scene round_trip(const Scene& a, const std::string& dir) {
  const std::string first = dir + "/first.json", second = dir + "/second.json";
  save_scene(a, first);
  Scene b = load_scene(first);
  std::string why;
  EXPECT_TRUE(equal_scenes(a, b, &why)) << a.source << " -> " << first << ": " << why;
  save_scene(b, second);
  EXPECT_EQ(first_difference(read_text(first), read_text(second)), "") << "saving the reloaded scene changed the text";
  EXPECT_EQ(first_difference(scene_to_json(b, dir), read_text(first)), "");
  return b;
}

// ---- the shipped scenes ---------------------------------------------------------

std::vector<std::string> shipped_scenes() {
  std::vector<std::string> names = files_in(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes");
  std::vector<std::string> out;
  for (const std::string& n : names)
    if (n.size() > 5 && n.substr(n.size() - 5) == ".json") out.push_back(n.substr(0, n.size() - 5));
  std::sort(out.begin(), out.end());
  return out;
}

class ShippedScene : public ::testing::TestWithParam<std::string> {};

TEST_P(ShippedScene, LoadsSavesAndReloadsEqual) {
  const std::string path = std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/" + GetParam() + ".json";
  const std::string text = read_text(path);
  Scene a;
  try {
    a = load_scene(path);
  } catch (const Error& e) {
    const std::string msg = e.what();
    if (text.find("\"vdb\"") != std::string::npos && !vdb_supported())
      GTEST_SKIP() << "needs the OpenVDB loader (built with CDSM_VDB=OFF): " << msg;
    FAIL() << msg;
  }
  // Every object and volume of a scene file keeps its description.
  for (const Object& o : a.objects) EXPECT_FALSE(o.mesh_source.empty()) << o.name;
  for (const Volume& v : a.volumes) EXPECT_FALSE(v.grid_source.empty()) << v.name;
  const std::string dir = scratch_dir();
  Scene b = round_trip(a, dir);
  // Descriptions are written, not data: no triangles or voxels inline.
  const std::string saved = read_text(dir + "/first.json");
  EXPECT_EQ(saved.find("\"triangles\""), std::string::npos);
  EXPECT_EQ(saved.find("\"values\""), std::string::npos);
  EXPECT_LT(saved.size(), 2 * text.size() + 4096);
}

INSTANTIATE_TEST_SUITE_P(Scenes, ShippedScene, ::testing::ValuesIn(shipped_scenes()),
                         [](const ::testing::TestParamInfo<std::string>& p) { return p.param; });

TEST(SceneWrite, EveryShippedSceneIsListed) { EXPECT_GE(shipped_scenes().size(), 6u); }

// ---- a whole glTF scene -----------------------------------------------------------

std::string base64(const std::vector<unsigned char>& b) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < b.size(); i += 3) {
    uint32_t v = uint32_t(b[i]) << 16 | (i + 1 < b.size() ? uint32_t(b[i + 1]) << 8 : 0) |
                 (i + 2 < b.size() ? uint32_t(b[i + 2]) : 0);
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += i + 1 < b.size() ? k[(v >> 6) & 63] : '=';
    out += i + 2 < b.size() ? k[v & 63] : '=';
  }
  return out;
}

// A .gltf with an embedded buffer: a unit cube used by two nodes (one under a
// rotated, scaled parent, one mirrored), a blended and a transmissive
// material, a spot and a point light, a perspective camera.
std::string write_gltf_fixture(const std::string& path) {
  const float p[8][3] = {{-.5f, -.5f, -.5f}, {.5f, -.5f, -.5f}, {-.5f, .5f, -.5f}, {.5f, .5f, -.5f},
                         {-.5f, -.5f, .5f},  {.5f, -.5f, .5f},  {-.5f, .5f, .5f},  {.5f, .5f, .5f}};
  const uint16_t idx[36] = {0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
                            2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5};
  std::vector<unsigned char> buf(sizeof p + sizeof idx);
  std::memcpy(buf.data(), p, sizeof p);
  std::memcpy(buf.data() + sizeof p, idx, sizeof idx);
  const double h = std::sqrt(0.5);
  json g = {
      {"asset", {{"version", "2.0"}}},
      {"extensionsUsed", {"KHR_lights_punctual", "KHR_materials_transmission"}},
      {"buffers", {{{"byteLength", buf.size()}, {"uri", "data:application/octet-stream;base64," + base64(buf)}}}},
      {"bufferViews",
       {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", sizeof p}},
        {{"buffer", 0}, {"byteOffset", sizeof p}, {"byteLength", sizeof idx}}}},
      {"accessors",
       {{{"bufferView", 0},
         {"componentType", 5126},
         {"count", 8},
         {"type", "VEC3"},
         {"min", {-.5, -.5, -.5}},
         {"max", {.5, .5, .5}}},
        {{"bufferView", 1}, {"componentType", 5123}, {"count", 36}, {"type", "SCALAR"}}}},
      {"materials",
       {{{"name", "blend"},
         {"alphaMode", "BLEND"},
         {"pbrMetallicRoughness", {{"baseColorFactor", {0.2, 0.4, 0.6, 0.4}}}}},
        {{"name", "glass"},
         {"pbrMetallicRoughness", {{"baseColorFactor", {0.9, 0.6, 0.3, 1.0}}}},
         {"extensions", {{"KHR_materials_transmission", {{"transmissionFactor", 0.5}}}}}}}},
      {"meshes",
       {{{"name", "cube"}, {"primitives", {{{"attributes", {{"POSITION", 0}}}, {"indices", 1}, {"material", 0}}}}},
        {{"name", "glass cube"},
         {"primitives", {{{"attributes", {{"POSITION", 0}}}, {"indices", 1}, {"material", 1}}}}}}},
      {"extensions",
       {{"KHR_lights_punctual",
         {{"lights",
           {{{"type", "spot"},
             {"name", "key"},
             {"color", {1, 0.5, 0.25}},
             {"intensity", 200},
             {"spot", {{"outerConeAngle", 0.5}, {"innerConeAngle", 0.25}}}},
            {{"type", "point"}, {"intensity", 50}}}}}}}},
      {"cameras",
       {{{"type", "perspective"},
         {"perspective", {{"yfov", 0.8}, {"znear", 0.1}, {"zfar", 100}, {"aspectRatio", 1.5}}}}}},
      {"nodes",
       {{{"name", "rig"}, {"translation", {1, 2, 3}}, {"rotation", {0, h, 0, h}}, {"children", {1}}},
        {{"name", "big"}, {"scale", {2, 2, 2}}, {"mesh", 0}},
        {{"name", "mirror"}, {"scale", {-1, 1, 1}}, {"translation", {-3, 0, 0}}, {"mesh", 1}},
        {{"name", "key"},
         {"translation", {0, 10, 0}},
         {"rotation", {-h, 0, 0, h}},
         {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}},
        {{"name", "fill"}, {"translation", {5, 5, 5}}, {"extensions", {{"KHR_lights_punctual", {{"light", 1}}}}}},
        {{"name", "cam"}, {"translation", {0, 1, 10}}, {"camera", 0}}}},
      {"scenes", {{{"nodes", {0, 2, 3, 4, 5}}}}},
      {"scene", 0}};
  write_text(path, g.dump(1));
  return path;
}

TEST(SceneWrite, WholeGltfSceneRoundTrips) {
  const std::string dir = scratch_dir();
  Scene a = load_scene(write_gltf_fixture(dir + "/fixture.gltf"));
  ASSERT_EQ(a.objects.size(), 2u);
  ASSERT_EQ(a.lights.size(), 2u);
  for (const Object& o : a.objects) EXPECT_TRUE(o.mesh_source.empty()) << "a glTF scene's meshes have no description";
  Scene b = round_trip(a, dir);
  // Written as data: triangles inline, transforms as matrices.
  json saved = json::parse(read_text(dir + "/first.json"));
  EXPECT_EQ(saved["objects"][0]["mesh"]["type"], "triangles");
  EXPECT_EQ(saved["objects"][0]["mesh"]["positions"].size(), 3 * a.objects[0].mesh->positions.size());
  EXPECT_EQ(saved["objects"][1]["transform"]["matrix"].size(), 16u);
  // Triangles are data, not a description: none is kept.
  EXPECT_TRUE(b.objects[0].mesh_source.empty());
}

TEST(SceneWrite, SharedGltfSceneRoundTrips) {
  const std::string path = data_dir() + "/mesh/vsa_primitives_scene.gltf";
  round_trip(load_scene(path), scratch_dir());
}

// ---- a scene built in code ----------------------------------------------------------

Scene code_scene() {
  Scene s = cdsm_test::empty_scene("code scene");
  s.camera = cdsm_test::camera_at({0.1f, 2.3f, 6.7f}, {0, 0.3f, 0}, 96, 64);
  s.camera.fov_y_deg = 41.3f;
  s.shadows.epsilon = 0.0123f;
  s.shadows.resolution = 300;
  s.shadows.filtering = false;
  s.shadows.receiver = ReceiverLookup::SlopeBias;
  s.shadows.max_clusters = 3;
  s.shadows.d0 = 1.0f / 3.0f;
  s.shadows.layout = DsmLayout::Chunked;
  s.shadows.chunk_nodes = 48;
  s.shadows.method = ShadowMethod::FixedNodes;
  s.shadows.method_param = 8;
  s.shadows.rgb_maps = false;
  s.shadows.max_memory_mib = 4096;
  s.shadows.ambient_light = {0.1f, 0.2f, 0.30000001f};
  s.background = {0.01f, 0.02f, 0.03f};

  // A dense grid with awkward values, placed by a rotation (no voxel_size /
  // origin can say it) ...
  auto grid = std::make_shared<DenseGrid>();
  grid->nx = 3, grid->ny = 2, grid->nz = 2;
  grid->values = {0.0f, 1e-30f, 0.1f, 1.0f / 3.0f, 2.5f, 1e6f, 0.7f, 3e38f, 0.25f, 0.5f, 1.0f, 7.0f};
  grid->background = 0.125f;
  Volume fog;
  fog.name = "fog";
  fog.grid = grid;
  fog.index_to_object = make_transform({0.1f, 0.2f, 0.3f}, {0, 37, 0}, {0.05f, 0.05f, 0.07f});
  fog.transfer = {{0.0f, {0, 0, 0}, {1, 1, 1}}, {1.0f, {2.0f, 3.0f, 4.0f}, {0.9f, 0.8f, 0.7f}}};
  fog.shading = VolumeShading::Phong;
  fog.step_voxels = 0.75f;
  fog.gradient_scale = 2.0f;
  s.volumes.push_back(fog);
  // ... and one placed axis-aligned at an origin that is no round number.
  Volume haze = fog;
  haze.name = "";
  haze.index_to_object = Mat4{};
  haze.index_to_object.m[0][0] = 0.011f, haze.index_to_object.m[1][1] = 0.013f, haze.index_to_object.m[2][2] = 0.017f;
  haze.index_to_object.m[0][3] = -0.70399994f, haze.index_to_object.m[1][3] = 0.3f,
  haze.index_to_object.m[2][3] = 123.456f;
  s.volumes.push_back(haze);

  auto add = [&](const std::string& name, TriangleMesh mesh, Mat4 xf) -> Object& {
    Object o;
    o.name = name;
    o.mesh = std::make_shared<TriangleMesh>(std::move(mesh));
    o.transform = xf;
    s.objects.push_back(o);
    return s.objects.back();
  };
  add("ground", make_ground(8, 8), Mat4{}).casts_shadows = false;
  Object& box = add("box \"quoted\" é", make_box({0.3f, 0.5f, 0.7f}),
                    make_transform({0.5f, 0.25f, -0.3f}, {10, 33.3f, -71}, {-1, 1.5f, 0.8f}));
  box.surface.color = {0.9f, 0.1f, 0.2f};
  box.surface.opacity = 0.35f;
  box.surface.transmission_color = {0.3f, 0.6f, 1.0f};
  box.interior = InteriorKind::Constant;
  box.sigma = {1.5f, 2.0f, 2.5f};
  Object& ball = add("ball", make_sphere(0.3f, 13, 7), make_transform({-0.5f, 0.3f, 0.2f}, {0, 0, 0}, {1, 1, 1}));
  ball.surface.specular = 0.7f;
  ball.surface.shininess = 80;
  TriangleMesh open;  // no normals
  open.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, -0.0f}};
  open.indices = {0, 1, 2};
  add("open", open, Mat4{});
  Object& fog_obj = add("fog", make_volume_proxy(fog), Mat4{});
  fog_obj.interior = InteriorKind::Volume;
  fog_obj.volume = 0;
  fog_obj.surface.opacity = 0;
  Object& haze_obj = add("haze", make_box({1, 1, 1}), make_transform({0, 1, 0}, {0, 0, 0}, {1, 1, 1}));
  haze_obj.interior = InteriorKind::Volume;
  haze_obj.volume = 1;

  Light spot;
  spot.name = "key";
  spot.position = {2.2f, 4.6f, 2.4f};
  spot.direction = normalize(Vec3{-2.2f, -4.3f, -2.5f});
  spot.outer_cone_deg = 32.5f;
  spot.inner_cone_deg = 26;
  spot.color = {1.0f, 0.97f, 0.92f};
  spot.intensity = 1.1f;
  s.lights.push_back(spot);
  Light point;
  point.type = LightType::Point;
  point.position = {-1, 3, 1};
  point.direction = {0.6f, -0.8f, 0};  // unused by a point light, kept
  point.outer_cone_deg = 45;
  s.lights.push_back(point);
  return s;
}

TEST(SceneWrite, SceneBuiltInCodeRoundTrips) {
  const std::string dir = scratch_dir();
  Scene a = code_scene();
  Scene b = round_trip(a, dir);
  json saved = json::parse(read_text(dir + "/first.json"));
  // Data inline where nothing describes it; placements exactly.
  EXPECT_EQ(saved["volumes"][0]["grid"]["type"], "dense");
  EXPECT_TRUE(saved["volumes"][0].contains("index_to_object"));
  EXPECT_TRUE(saved["volumes"][1].contains("origin"));
  EXPECT_EQ(saved["objects"][3]["mesh"]["type"], "triangles");
  EXPECT_FALSE(saved["objects"][3]["mesh"].contains("normals"));
  EXPECT_EQ(saved["objects"][4]["interior"]["volume"], "fog");
  EXPECT_EQ(saved["objects"][5]["interior"]["volume"], 1);  // unnamed: by index
  // Short numbers where they read back exactly.
  EXPECT_NE(read_text(dir + "/first.json").find("\"epsilon\": 0.0123,"), std::string::npos);
  // A second round trip of the reloaded scene (descriptions now set) is
  // the same again.
  Scene c = round_trip(b, scratch_dir("2"));
  std::string why;
  EXPECT_TRUE(equal_scenes(a, c, &why)) << why;
}

TEST(SceneWrite, EqualScenesSeesEachKindOfDifference) {
  const Scene a = code_scene();
  std::string why;
  ASSERT_TRUE(equal_scenes(a, a, &why)) << why;
  auto expect_diff = [&](const char* at, const std::function<void(Scene&)>& edit) {
    Scene b = a;
    edit(b);
    EXPECT_FALSE(equal_scenes(a, b, &why)) << at;
    EXPECT_EQ(why.rfind(at, 0), 0u) << why;
  };
  expect_diff("/objects/1/transform/3", [](Scene& b) { b.objects[1].transform.m[0][3] = std::nextafter(0.5f, 1.0f); });
  expect_diff("/objects/2/mesh/positions/0", [](Scene& b) {
    auto m = std::make_shared<TriangleMesh>(*b.objects[2].mesh);
    m->positions[0].y = -m->positions[0].y;
    b.objects[2].mesh = m;
  });
  expect_diff("/volumes/0/grid/values/2", [](Scene& b) {
    auto g = std::make_shared<DenseGrid>(*b.volumes[0].grid);
    g->values[2] = 0.2f;
    b.volumes[0].grid = g;
  });
  expect_diff("/camera/up/1", [](Scene& b) { b.camera.up.y = -0.0f + 1.0f - 1e-7f; });
  expect_diff("/shadows/max_memory", [](Scene& b) { b.shadows.max_memory_mib = 1; });
  expect_diff("/lights/1/direction", [](Scene& b) { b.lights[1].direction.z = -0.0f; });
  expect_diff("/objects/0/mesh_source", [](Scene& b) { b.objects[0].mesh_source = "{}"; });
  expect_diff("/volumes/1/index_to_object", [](Scene& b) { b.volumes[1].index_to_object.m[2][3] += 1; });
}

// ---- descriptions ----------------------------------------------------------------------

TEST(SceneWrite, FilesBesideTheSceneStayFoundFromAnotherFolder) {
  const std::string root = scratch_dir();
  const std::string a = root + "/a", b = root + "/b/deeper";
  ASSERT_EQ(std::system(("mkdir -p '" + a + "' '" + b + "'").c_str()), 0);
  {
    std::ofstream raw(a + "/vol.raw", std::ios::binary);
    for (int i = 0; i < 2 * 3 * 4; ++i) raw.put(char(i * 10));
  }
  write_text(a + "/scene.json", R"({
    "camera": {"position": [0, 2, 6], "target": [0, 0, 0]},
    "volumes": [{"name": "v", "grid": {"type": "raw", "file": "vol.raw", "dims": [2, 3, 4], "spacing": [0.1, 0.2, 0.3]},
                 "origin": [-0.1, 0, 0.05], "transfer": [{"density": 0, "extinction": 1}]}],
    "objects": [{"name": "v", "interior": {"type": "volume", "volume": "v"}}],
    "lights": [{"type": "spot", "position": [0, 5, 0], "target": [0, 0, 0]}]})");
  Scene s = load_scene(a + "/scene.json");
  // The description names the file absolutely (found beside the scene).
  EXPECT_EQ(json::parse(s.volumes[0].grid_source)["file"], root + "/a/vol.raw");
  EXPECT_EQ(s.objects[0].mesh_source, R"({"type":"volume_box"})");
  save_scene(s, b + "/moved.json");
  json saved = json::parse(read_text(b + "/moved.json"));
  EXPECT_EQ(saved["volumes"][0]["grid"]["file"], "../../a/vol.raw");  // relative to the new folder
  EXPECT_FALSE(saved["volumes"][0].contains("voxel_size"));           // the raw grid's spacing says it
  Scene back = load_scene(b + "/moved.json");
  std::string why;
  EXPECT_TRUE(equal_scenes(s, back, &why)) << why;
}

TEST(SceneWrite, StaleDescriptionsGiveWayToData) {
  // A volume's proxy stays a description only while it still is the proxy.
  Scene s = parse_scene(R"({
    "camera": {"position": [0, 2, 6], "target": [0, 0, 0]},
    "volumes": [{"name": "v", "grid": {"type": "dense", "size": [2, 2, 2], "fill": 0.5}, "voxel_size": 0.1,
                 "transfer": [{"density": 0, "extinction": 1}]}],
    "objects": [{"name": "v", "interior": {"type": "volume", "volume": "v"}},
                {"name": "b", "mesh": {"type": "box", "size": 1}}],
    "lights": [{"type": "spot", "position": [0, 5, 0], "target": [0, 0, 0]}]})",
                        "stale.json", "");
  const std::string dir = scratch_dir();
  // The volume moves from its proxy object into the box: the proxy's
  // volume_box description no longer holds, its triangles are written.
  Scene t = s;
  t.objects[0].interior = InteriorKind::Constant;
  t.objects[0].sigma = {1, 1, 1};
  t.objects[0].volume = -1;
  t.objects[1].interior = InteriorKind::Volume;
  t.objects[1].volume = 0;
  save_scene(t, dir + "/t.json");
  json saved = json::parse(read_text(dir + "/t.json"));
  EXPECT_EQ(saved["objects"][0]["mesh"]["type"], "triangles");
  EXPECT_EQ(saved["objects"][1]["mesh"]["type"], "box");
  Scene back = load_scene(dir + "/t.json");
  std::string why;
  SceneComparer c;
  EXPECT_TRUE(c.mesh("/objects/0/mesh", t.objects[0].mesh.get(), back.objects[0].mesh.get())) << c.why;
  round_trip(back, scratch_dir("2"));
}

// ---- errors ---------------------------------------------------------------------------------

TEST(SceneWrite, BadPathsAreErrorsNamingThePath) {
  const Scene s = code_scene();
  const std::string dir = scratch_dir();
  expect_error([&] { save_scene(s, dir + "/missing/folder/x.json"); },
               {dir + "/missing/folder/x.json", "cannot create"});
  expect_error([&] { save_scene(s, dir); }, {dir, "is a directory"});
  expect_error([&] { save_scene(s, dir + "/x.gltf"); }, {dir + "/x.gltf", "JSON"});
  expect_error([&] { save_scene(s, dir + "/x.GLB"); }, {dir + "/x.GLB", "JSON"});
  expect_error([&] { save_scene(s, ""); }, {"no file name"});
  EXPECT_TRUE(files_in(dir).empty()) << "a refused save left files behind";
}

TEST(SceneWrite, ReplacesAnExistingFileWhole) {
  const std::string dir = scratch_dir();
  const std::string path = dir + "/scene.json";
  write_text(path, std::string(100000, 'x'));  // longer than the scene
  ASSERT_EQ(::chmod(path.c_str(), 0640), 0);
  save_scene(code_scene(), path);
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0640u) << "the file keeps its permissions";
  std::string why;
  EXPECT_TRUE(equal_scenes(code_scene(), load_scene(path), &why)) << why;
  EXPECT_EQ(files_in(dir), std::vector<std::string>{"scene.json"}) << "no temporary file left";
}

TEST(SceneWrite, SceneAFileCannotHoldIsRefusedAndTheTargetKept) {
  const std::string dir = scratch_dir();
  const std::string path = dir + "/keep.json";
  write_text(path, "old content");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  auto refused = [&](const std::function<void(Scene&)>& edit, const std::vector<std::string>& parts) {
    Scene s = code_scene();
    edit(s);
    std::vector<std::string> all = parts;
    all.insert(all.begin(), path);
    expect_error([&] { save_scene(s, path); }, all);
    EXPECT_EQ(read_text(path), "old content");
    EXPECT_EQ(files_in(dir), std::vector<std::string>{"keep.json"});
  };
  // validate_scene's ranges, at the output's field:
  refused([&](Scene& s) { s.objects[1].surface.opacity = nan; }, {"/objects/1/material/opacity"});
  refused([&](Scene& s) { s.camera.fov_y_deg = nan; }, {"/camera"});
  refused([&](Scene& s) { s.lights[0].position.y = nan; }, {"/lights/0/position"});
  // what only the reader checks:
  refused([&](Scene& s) { s.objects[2].transform.m[1][3] = nan; }, {"/objects/2/transform/matrix/7", "NaN"});
  refused([&](Scene& s) { s.objects[2].transform.m[3][0] = 1; }, {"/objects/2/transform", "0 0 0 1"});
  refused(
      [&](Scene& s) {
        auto m = std::make_shared<TriangleMesh>(*s.objects[3].mesh);
        m->positions[1].x = std::numeric_limits<float>::infinity();
        s.objects[3].mesh = m;
      },
      {"/objects/3/mesh/positions/3", "infinite"});
  refused(
      [&](Scene& s) {
        auto g = std::make_shared<DenseGrid>(*s.volumes[0].grid);
        g->values[4] = -1;
        s.volumes[0].grid = g;
      },
      {"/volumes/0/grid/values/4", "within [0, 3e+38]"});
  refused([&](Scene& s) { s.objects[1].transform.m[0][3] = 3.4e38f; }, {"/objects/1/transform/matrix/3", "3e+38"});
  refused([&](Scene& s) { s.objects[5].interior = InteriorKind::None; }, {"/volumes/1", "not used by any object"});
  refused([&](Scene& s) { s.volumes[1].name = "fog"; }, {"/volumes/1/name", "share the name 'fog'"});
  refused([&](Scene& s) { s.lights.clear(); }, {"/lights", "at least one light"});
  refused(
      [&](Scene& s) {
        s.volumes[0].grid = nullptr;
        s.volumes[0].sparse = std::make_shared<SparseGrid>();
      },
      {"/volumes/0/grid", "sparse grid without a description"});
}

// ---- the reader's additions ------------------------------------------------------------------

TEST(SceneWrite, ReaderChecksTrianglesAndMatrices) {
  auto scene_with = [](const std::string& object, const std::string& volume_extra = "") {
    return R"({"camera": {"position": [0, 2, 6], "target": [0, 0, 0]},
      "volumes": [{"name": "v", "grid": {"type": "dense", "size": [1, 1, 1]}, "transfer": [{"density": 0, "extinction": 1}])" +
           volume_extra + R"(}],
      "objects": [{"name": "v", "interior": {"type": "volume", "volume": "v"}}, )" +
           object + R"(],
      "lights": [{"type": "spot", "position": [0, 5, 0], "target": [0, 0, 0]}]})";
  };
  auto fails = [&](const std::string& text, const std::vector<std::string>& parts) {
    expect_error([&] { parse_scene(text, "r.json", ""); }, parts);
  };
  const std::string tri = R"({"type": "triangles", "positions": [0,0,0, 1,0,0, 0,1,0], "indices": [0, 1, 2]})";
  Scene ok = parse_scene(
      scene_with(R"({"mesh": )" + tri + R"(, "transform": {"matrix": [1,0,0,1, 0,1,0,2, 0,0,1,3, 0,0,0,1]}})"),
      "r.json", "");
  ASSERT_EQ(ok.objects[1].mesh->triangle_count(), 1u);
  EXPECT_EQ(ok.objects[1].transform.m[1][3], 2.0f);
  fails(scene_with(R"({"mesh": {"type": "triangles", "positions": [0,0,0, 1,0], "indices": []}})"),
        {"r.json: /objects/1/mesh/positions", "x, y, z per vertex"});
  fails(scene_with(R"({"mesh": {"type": "triangles", "positions": [0,0,0, 1,0,0, 0,1,0], "indices": [0, 1, 3]}})"),
        {"r.json: /objects/1/mesh/indices/2", "within [0, 3)"});
  fails(scene_with(R"({"mesh": {"type": "triangles", "positions": [0,0,0, 1,0,0, 0,1,0], "indices": [0, 1]}})"),
        {"r.json: /objects/1/mesh/indices", "3 indices per triangle"});
  fails(
      scene_with(
          R"({"mesh": {"type": "triangles", "positions": [0,0,0, 1,0,0, 0,1,0], "indices": [0, 1, 2], "normals": [0, 1, 0]}})"),
      {"r.json: /objects/1/mesh/normals", "one normal per vertex"});
  fails(scene_with(R"({"mesh": )" + tri + R"(, "transform": {"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0]}})"),
        {"r.json: /objects/1/transform/matrix", "16 numbers"});
  fails(scene_with(R"({"mesh": )" + tri + R"(, "transform": {"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,1,1]}})"),
        {"r.json: /objects/1/transform/matrix", "0 0 0 1"});
  fails(scene_with(R"({"mesh": )" + tri +
                   R"(, "transform": {"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], "scale": 2}})"),
        {"r.json: /objects/1/transform/scale", "unknown field"});
  fails(scene_with(R"({"mesh": )" + tri + "}",
                   R"(, "voxel_size": 0.1, "index_to_object": {"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]})"),
        {"r.json: /volumes/0", "not both"});
}

TEST(SceneWrite, UnitDirectionsAreKeptBitForBit) {
  // A direction already of unit length (a saved scene) is not normalized
  // again (that could move its last bits); others are normalized.
  Vec3 d{};
  bool moves = false;  // a unit vector that normalize() changes again
  for (int k = 1; k < 1000 && !moves; ++k) {
    d = normalize(Vec3{-2.2f * float(k), -4.3f, -2.5f + 0.01f * float(k)});
    const Vec3 again = normalize(d);
    moves = std::memcmp(&again, &d, sizeof d) != 0;
  }
  ASSERT_TRUE(moves);
  char text[512];
  std::snprintf(text, sizeof text,
                R"({"camera": {"position": [0, 2, 6], "target": [0, 0, 0]}, "objects": [],
      "lights": [{"type": "spot", "position": [0, 5, 0], "direction": [%.9g, %.9g, %.9g]},
                 {"type": "spot", "position": [0, 5, 0], "direction": [0, -2, 0]},
                 {"type": "point", "position": [0, 5, 0]}]})",
                d.x, d.y, d.z);
  Scene s = parse_scene(text, "d.json", "");
  EXPECT_EQ(std::memcmp(&s.lights[0].direction, &d, sizeof d), 0);
  EXPECT_EQ(s.lights[1].direction.y, -1.0f);
  EXPECT_EQ(s.lights[2].direction.y, -1.0f);  // the default, for a point light given none
}

}  // namespace
}  // namespace cdsm_test
