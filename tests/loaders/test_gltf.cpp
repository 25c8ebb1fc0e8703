// glTF 2.0: the shared meshes and scene, a .glb written here by tinygltf
// (hierarchy, mirroring, lights, camera, materials), unsupported features,
// and broken files made by truncating or editing good ones.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "cdsm/scene_io.h"
#include "cdsm/procedural.h"
#include "cdsm/renderer.h"
#include "scene_compile.h"
#include "loader_test_util.h"
#include "common/system_frame.h"

namespace cdsm_test {
namespace {

using namespace cdsm;
using nlohmann::json;

TEST(Gltf, SharedMeshesHaveTheManifestCounts) {
  struct Case {
    const char* file;
    size_t tris;
    bool closed;
  } cases[] = {{"mesh/khronos_Box/Box.gltf", 12, true},
               {"mesh/vsa_teapot.gltf", 9128, false},  // open lid and spout seams
               {"mesh/vsa_torusknot.gltf", 2880, true},
               {"mesh/vsa_geosphere.gltf", 1280, true},
               {"mesh/vsa_primitives_scene.gltf", 3636, false}};  // merged overlapping cubes share faces
  for (const Case& c : cases) {
    TriangleMesh m = load_gltf_mesh(data_path(c.file));
    EXPECT_EQ(m.triangle_count(), c.tris) << c.file;
    EXPECT_EQ(m.normals.size(), m.positions.size()) << c.file;
    if (c.closed) {
      EXPECT_TRUE(is_closed(m)) << c.file;
      EXPECT_GT(signed_volume(m, Mat4{}), 0.0) << c.file << " faces inwards";
    }
  }
  EXPECT_FALSE(is_closed(load_gltf_mesh(data_path("mesh/vsa_teapot.gltf"))));
}

TEST(Gltf, PrimitivesSceneAsAWholeScene) {
  Scene s = load_scene(data_path("mesh/vsa_primitives_scene.gltf"));
  ASSERT_EQ(s.objects.size(), 6u);
  size_t tris = 0;
  for (const Object& o : s.objects) {
    tris += o.mesh->triangle_count();
    EXPECT_TRUE(is_closed(*o.mesh)) << o.name;
    EXPECT_GT(signed_volume(*o.mesh, o.transform), 0.0) << o.name;
  }
  EXPECT_EQ(tris, 3636u);
  EXPECT_EQ(s.lights.size(), 1u);  // the default spot light
  // Cube_1's material: baseColorFactor [0, 0.8, 0.0057, 1], roughness 0.5.
  for (const Object& o : s.objects)
    if (o.name == "Cube_1") {
      EXPECT_NEAR(o.surface.color.y, 0.8f, 1e-6f);
      EXPECT_EQ(o.surface.opacity, 1.0f);
    }
}

// Cube_1 is a child of Sphere_1: its global transform is S1 * C1 (scale and
// translation only), so its world box is the accessor's box under both.
TEST(Gltf, NodeHierarchyTransforms) {
  std::string path = data_path("mesh/vsa_primitives_scene.gltf");
  json j = json::parse(read_text(path));
  auto trs = [&](const json& n) {
    Vec3 t{0, 0, 0}, s{1, 1, 1};
    if (n.contains("translation")) t = {n["translation"][0], n["translation"][1], n["translation"][2]};
    if (n.contains("scale")) s = {n["scale"][0], n["scale"][1], n["scale"][2]};
    return make_transform(t, {0, 0, 0}, s);
  };
  const json& acc = j["accessors"][0];  // Cube_1's POSITION
  Mat4 g = trs(j["nodes"][5]) * trs(j["nodes"][0]);
  Vec3 lo = g.point({acc["min"][0], acc["min"][1], acc["min"][2]});
  Vec3 hi = g.point({acc["max"][0], acc["max"][1], acc["max"][2]});
  for (const std::string& key : {std::string("Cube_1"), std::string("0")}) {
    TriangleMesh m = load_gltf_mesh(path, key);
    EXPECT_EQ(m.triangle_count(), 288u);
    Box3 b = world_bounds(m, Mat4{});
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(b.lo[a], lo[a], 1e-4f) << key << " axis " << a;
      EXPECT_NEAR(b.hi[a], hi[a], 1e-4f) << key << " axis " << a;
    }
  }
  expect_error([&] { load_gltf_mesh(path, "Cube_9"); }, {path, "no node 'Cube_9'", "Cube_1"});
}

// ---- a .glb written by tinygltf ----------------------------------------------

// A unit cube (outward CCW) in buffer 0: positions then uint16 indices.
void add_cube_mesh(tinygltf::Model& m) {
  const float p[8][3] = {{-.5f, -.5f, -.5f}, {.5f, -.5f, -.5f}, {-.5f, .5f, -.5f}, {.5f, .5f, -.5f},
                         {-.5f, -.5f, .5f},  {.5f, -.5f, .5f},  {-.5f, .5f, .5f},  {.5f, .5f, .5f}};
  const uint16_t idx[36] = {0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
                            2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5};
  tinygltf::Buffer buf;
  buf.data.resize(sizeof(p) + sizeof(idx));
  std::memcpy(buf.data.data(), p, sizeof(p));
  std::memcpy(buf.data.data() + sizeof(p), idx, sizeof(idx));
  m.buffers.push_back(buf);
  tinygltf::BufferView pv, iv;
  pv.buffer = 0, pv.byteOffset = 0, pv.byteLength = sizeof(p);
  iv.buffer = 0, iv.byteOffset = sizeof(p), iv.byteLength = sizeof(idx);
  m.bufferViews = {pv, iv};
  tinygltf::Accessor pa, ia;
  pa.bufferView = 0, pa.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT, pa.count = 8, pa.type = TINYGLTF_TYPE_VEC3;
  pa.minValues = {-.5, -.5, -.5}, pa.maxValues = {.5, .5, .5};
  ia.bufferView = 1, ia.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, ia.count = 36,
  ia.type = TINYGLTF_TYPE_SCALAR;
  m.accessors = {pa, ia};
  tinygltf::Primitive prim;
  prim.attributes["POSITION"] = 0;
  prim.indices = 1;
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  tinygltf::Mesh mesh;
  mesh.name = "cube";
  mesh.primitives = {prim};
  m.meshes = {mesh};
}

tinygltf::Value object(std::map<std::string, tinygltf::Value> o) { return tinygltf::Value(o); }
tinygltf::Value array(std::vector<double> v) {
  tinygltf::Value::Array a;
  for (double x : v) a.push_back(tinygltf::Value(x));
  return tinygltf::Value(a);
}

// Nodes: 0 "rig" (translate 1,2,3; rotate 90 deg about y) -> 1 "big" (scale
// 2, cube, blend material); 2 "mirror" (scale -1,1,1, cube, glass);
// 3 "key" spot light; 4 "fill" point light; 5 "cam" camera.
tinygltf::Model fixture_model() {
  tinygltf::Model m;
  m.asset.version = "2.0";
  add_cube_mesh(m);
  // Materials: 0 blend alpha 0.4; 1 transmission 0.5 + volume.
  tinygltf::Material blend;
  blend.name = "blend";
  blend.alphaMode = "BLEND";
  blend.pbrMetallicRoughness.baseColorFactor = {0.2, 0.4, 0.6, 0.4};
  tinygltf::Material glass;
  glass.name = "glass";
  glass.pbrMetallicRoughness.baseColorFactor = {0.9, 0.6, 0.3, 1.0};
  glass.extensions["KHR_materials_transmission"] = object({{"transmissionFactor", tinygltf::Value(0.5)}});
  glass.extensions["KHR_materials_volume"] =
      object({{"attenuationDistance", tinygltf::Value(2.0)}, {"attenuationColor", array({0.5, 0.25, 1.0})}});
  m.materials = {blend, glass};
  m.meshes[0].primitives[0].material = 0;
  tinygltf::Mesh glass_cube = m.meshes[0];
  glass_cube.primitives[0].material = 1;
  m.meshes.push_back(glass_cube);
  m.extensionsUsed = {"KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_volume"};

  tinygltf::Node rig, big, mirror, key, fill, cam;
  rig.name = "rig";
  rig.translation = {1, 2, 3};
  rig.rotation = {0, std::sin(M_PI / 4), 0, std::cos(M_PI / 4)};
  rig.children = {1};
  big.name = "big";
  big.scale = {2, 2, 2};
  big.mesh = 0;
  mirror.name = "mirror";
  mirror.scale = {-1, 1, 1};
  mirror.translation = {-3, 0, 0};
  mirror.mesh = 1;
  tinygltf::Light spot, point;
  spot.type = "spot";
  spot.name = "key";
  spot.color = {1, 0.5, 0.25};
  spot.intensity = 200;
  spot.spot.outerConeAngle = 0.5;
  spot.spot.innerConeAngle = 0.25;
  point.type = "point";
  point.intensity = 50;
  m.lights = {spot, point};
  key.name = "key";
  key.translation = {0, 10, 0};
  key.rotation = {-std::sin(M_PI / 4), 0, 0, std::cos(M_PI / 4)};  // -90 deg about x: -z -> -y
  key.extensions["KHR_lights_punctual"] = object({{"light", tinygltf::Value(0)}});
  fill.name = "fill";
  fill.translation = {5, 5, 5};
  fill.extensions["KHR_lights_punctual"] = object({{"light", tinygltf::Value(1)}});
  tinygltf::Camera c;
  c.type = "perspective";
  c.perspective.yfov = 0.8;
  c.perspective.znear = 0.1;
  c.perspective.zfar = 100;
  c.perspective.aspectRatio = 1.5;
  m.cameras = {c};
  cam.name = "cam";
  cam.translation = {0, 1, 10};
  cam.camera = 0;
  m.nodes = {rig, big, mirror, key, fill, cam};
  tinygltf::Scene sc;
  sc.nodes = {0, 2, 3, 4, 5};
  m.scenes = {sc};
  m.defaultScene = 0;
  return m;
}

std::string write_model(const tinygltf::Model& m, const std::string& path, bool binary) {
  tinygltf::TinyGLTF w;
  EXPECT_TRUE(w.WriteGltfSceneToFile(&m, path, false, true, false, binary)) << path;
  return path;
}

TEST(Gltf, GlbSceneWithLightsCameraAndMaterials) {
  std::string dir = scratch_dir();
  std::string glb = write_model(fixture_model(), dir + "/fixture.glb", true);
  ASSERT_EQ(read_bytes(glb).size() > 12 && std::memcmp(read_bytes(glb).data(), "glTF", 4) == 0, true);
  WarningCapture warnings;
  Scene s = load_scene(glb);
  EXPECT_TRUE(warnings.lines.empty()) << warnings.all();
  ASSERT_EQ(s.objects.size(), 2u);
  const Object& big = s.objects[0];
  const Object& mir = s.objects[1];
  EXPECT_EQ(big.name, "big");
  // rig * big: a 2-unit cube centred at (1, 2, 3).
  Box3 b = world_bounds(*big.mesh, big.transform);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(b.hi[a] - b.lo[a], 2.0f, 1e-5f);
    EXPECT_NEAR(b.center()[a], (Vec3{1, 2, 3})[a], 1e-5f);
  }
  // The rotation: the cube's local +x face ends up facing -z.
  Vec3 x = big.transform.vector({1, 0, 0});
  EXPECT_NEAR(x.z, -2.0f, 1e-5f);
  EXPECT_NEAR(big.surface.opacity, 0.4f, 1e-6f);
  EXPECT_NEAR(big.surface.color.z, 0.6f, 1e-6f);
  EXPECT_EQ(big.interior, InteriorKind::None);
  // The mirrored glass cube keeps glTF's winding in mesh space (outward
  // there); compile_object flips it under the mirroring transform, once (the
  // compiled world triangles below face outwards). Its attenuation is a
  // constant interior, -ln(c)/d per channel.
  EXPECT_TRUE(is_closed(*mir.mesh));
  EXPECT_LT(det3(mir.transform), 0.0f);
  EXPECT_GT(signed_volume(*mir.mesh), 0.0);
  EXPECT_NEAR(mir.surface.opacity, 0.5f, 1e-6f);
  // Transmission 0.5 of an opaque tinted material: the transmitted half is
  // filtered by the base colour, f = ((1 - a) + a t c) / (1 - a (1 - t)) = c.
  EXPECT_NEAR(mir.surface.transmission_color.x, 0.9f, 1e-6f);
  EXPECT_NEAR(mir.surface.transmission_color.y, 0.6f, 1e-6f);
  EXPECT_NEAR(mir.surface.transmission_color.z, 0.3f, 1e-6f);
  // Blend without transmission: coverage only, a white filter.
  EXPECT_EQ(big.surface.transmission_color.x, 1.0f);
  EXPECT_EQ(big.surface.transmission_color.y, 1.0f);
  EXPECT_EQ(big.surface.transmission_color.z, 1.0f);
  ASSERT_EQ(mir.interior, InteriorKind::Constant);
  // Per channel, no averaging: sigma_k = -ln(attenuationColor_k) / attenuationDistance.
  EXPECT_NEAR(mir.sigma.x, float(std::log(2.0) / 2.0), 1e-5f);
  EXPECT_NEAR(mir.sigma.y, float(std::log(4.0) / 2.0), 1e-5f);
  EXPECT_NEAR(mir.sigma.z, 0.0f, 1e-6f);
  // Lights: intensities relative to the brightest; the spot points down.
  ASSERT_EQ(s.lights.size(), 2u);
  const Light& key = s.lights[0];
  EXPECT_EQ(key.type, LightType::Spot);
  EXPECT_NEAR(key.position.y, 10.0f, 1e-5f);
  EXPECT_NEAR(key.direction.y, -1.0f, 1e-5f);
  EXPECT_NEAR(key.outer_cone_deg, 0.5f * 180.0f / float(M_PI), 1e-3f);
  EXPECT_NEAR(key.inner_cone_deg, 0.25f * 180.0f / float(M_PI), 1e-3f);
  EXPECT_NEAR(key.intensity, 1.0f, 1e-6f);
  EXPECT_NEAR(key.color.y, 0.5f, 1e-6f);
  EXPECT_EQ(s.lights[1].type, LightType::Point);
  EXPECT_NEAR(s.lights[1].intensity, 0.25f, 1e-6f);
  // Camera.
  EXPECT_NEAR(s.camera.position.z, 10.0f, 1e-5f);
  EXPECT_NEAR(s.camera.target.z, 9.0f, 1e-5f);
  EXPECT_NEAR(s.camera.fov_y_deg, 0.8f * 180.0f / float(M_PI), 1e-3f);
  EXPECT_EQ(s.camera.width, 720);
  EXPECT_EQ(s.camera.height, 480);
  // It compiles (closed glass keeps its interior) and renders.
  SceneBuffers sb = compiled_scene(s);
  EXPECT_EQ(sb.objects[1].interior, InteriorKind::Constant);
  for (uint32_t o = 0; o < 2; ++o) {
    double v = 0.0;
    for (uint32_t t = sb.objects[o].first_tri; t < sb.objects[o].first_tri + sb.objects[o].tri_count; ++t)
      v += double(dot(sb.tri_vertices[3 * t], cross(sb.tri_vertices[3 * t + 1], sb.tri_vertices[3 * t + 2]))) / 6.0;
    EXPECT_GT(v, 0.0) << "object " << o << ": compiled world triangles face inwards";
  }

  // The same model as .gltf with an external buffer file, as a mesh reference.
  std::string gltf = write_model(fixture_model(), dir + "/fixture.gltf", false);
  TriangleMesh all = load_gltf_mesh(gltf);
  EXPECT_EQ(all.triangle_count(), 24u);
  EXPECT_TRUE(is_closed(all));
  EXPECT_GT(signed_volume(all, Mat4{}), 0.0);
}

// A glass cube (KHR_materials_volume) under a mirroring node renders like
// the reference and like the same cube unmirrored — also with the camera
// inside it.
TEST(Gltf, MirroredNodeRendersLikeTheReferenceAndUnmirrored) {
  std::string dir = scratch_dir();
  Image images[2];
  for (int mirrored = 0; mirrored < 2; ++mirrored)
    for (bool eye_inside : {false, true}) {
      tinygltf::Model m = fixture_model();
      m.nodes[2].scale = {mirrored ? -1.5 : 1.5, 1.5, 1.5};  // "mirror": the glass cube at (-3, 0, 0)
      m.scenes[0].nodes = {2};                               // the glass cube only
      std::string path = write_model(m, dir + "/mirror" + std::to_string(mirrored) + ".glb", true);
      Scene s = load_scene(path);
      ASSERT_EQ(s.objects.size(), 1u);
      ASSERT_EQ(s.objects[0].interior, InteriorKind::Constant);
      s.objects.push_back(Object{});
      s.objects.back().name = "ground";
      s.objects.back().mesh = std::make_shared<TriangleMesh>(make_ground(20, 20, 0.1f));
      s.objects.back().transform = make_transform({0, -1.0f, 0}, {0, 0, 0}, {1, 1, 1});
      Light l;
      l.position = {-2.0f, 6.0f, 1.5f};
      l.direction = normalize(Vec3{-1.0f, -6.0f, -1.5f});
      l.outer_cone_deg = 35.0f;
      l.inner_cone_deg = 30.0f;
      s.lights = {l};
      s.camera.position = eye_inside ? Vec3{-2.9f, 0.1f, 0.2f} : Vec3{-1.0f, 1.5f, 5.0f};
      s.camera.target = eye_inside ? Vec3{-2.5f, -1.0f, -2.0f} : Vec3{-3.0f, 0.0f, 0.0f};
      s.camera.width = 64;
      s.camera.height = 48;
      s.shadows.resolution = 256;
      const ComparedFrame frame = compared_render(s);
      const FrameStats& st = frame.stats;
      std::printf("[ mirror ] glTF %s%s: %.2f dB against the reference, T mean %.4f\n", mirrored ? "mirrored" : "plain",
                  eye_inside ? ", eye inside" : "", st.image.psnr, st.transmittance.mean);
      EXPECT_GE(st.image.psnr, 40.0) << mirrored << eye_inside;
      EXPECT_LE(st.transmittance.mean, 0.02) << mirrored << eye_inside;
      EXPECT_EQ(st.unmatched_fragments, 0u) << mirrored << eye_inside;
      if (!eye_inside) images[mirrored] = frame.image;
    }
  EXPECT_GE(compare_images(images[0], images[1]).psnr, 50.0);
}

TEST(Gltf, UnsupportedFeaturesAreListedOnce) {
  std::string dir = scratch_dir();
  tinygltf::Model m = fixture_model();
  m.materials[0].pbrMetallicRoughness.baseColorTexture.index = 0;
  m.materials[0].emissiveFactor = {1, 0, 0};
  m.materials[1].extensions["KHR_materials_clearcoat"] = object({{"clearcoatFactor", tinygltf::Value(1.0)}});
  m.lights[1].type = "directional";
  m.lights[0].range = 10;
  tinygltf::Image img;
  img.uri = "missing.png";
  m.images = {img};
  tinygltf::Texture tex;
  tex.source = 0;
  m.textures = {tex};
  std::string path = write_model(m, dir + "/unsupported.gltf", false);
  WarningCapture warnings;
  Scene s = load_scene(path);
  ASSERT_EQ(warnings.lines.size(), 1u) << warnings.all();
  const std::string& w = warnings.lines[0];
  for (const char* part : {"unsupported glTF features", "textures (material 0 'blend')", "emission",
                           "extension KHR_materials_clearcoat", "light range", "'key' (node 3)"})
    EXPECT_NE(w.find(part), std::string::npos) << part << " not in: " << w;
  // KHR_lights_punctual's directional lights load (the sun): not listed,
  // pointing down their node's -z, their intensity scaled apart from the
  // spot and point lights' (lux, not candela).
  EXPECT_EQ(w.find("directional"), std::string::npos) << w;
  ASSERT_EQ(s.lights.size(), 2u);
  const Light& sun = s.lights[1];
  EXPECT_EQ(sun.type, LightType::Directional);
  EXPECT_EQ(sun.name, "fill");
  EXPECT_NEAR(sun.direction.z, -1.0f, 1e-6f) << "the fill node is not rotated: its -z";
  EXPECT_FLOAT_EQ(sun.intensity, 1.0f) << "the brightest directional light is 1";
}

// A KHR_lights_punctual directional light (the sun) renders: the fixture's
// glass cube over a ground, lit by a directional light alone, against the
// reference's parallel shadow rays.
// KHR_lights_punctual has no light size: 0 unless the light's extras give
// one ("radius" for spot and point lights, "angular_diameter" for the
// sun); a bad one is an error naming the node and the key.
TEST(Gltf, LightSizeFromExtras) {
  std::string dir = scratch_dir();
  tinygltf::Model m = fixture_model();
  ASSERT_NE(m.lights[1].type, "directional");
  // The largest size among the loaded lights (light 1 is the one given one).
  const auto largest = [](const Scene& s, bool sun) {
    float most = 0.0f;
    for (const Light& l : s.lights) most = std::max(most, sun ? l.angular_diameter_deg : l.radius);
    return most;
  };
  EXPECT_EQ(largest(load_scene(write_model(m, dir + "/plain.glb", true)), false), 0.0f);
  tinygltf::Value::Object extras;
  extras["radius"] = tinygltf::Value(0.12);
  m.lights[1].extras = tinygltf::Value(extras);
  EXPECT_FLOAT_EQ(largest(load_scene(write_model(m, dir + "/sized.glb", true)), false), 0.12f);
  m.lights[1].type = "directional";
  extras.clear();
  extras["angular_diameter"] = tinygltf::Value(0.53);
  m.lights[1].extras = tinygltf::Value(extras);
  EXPECT_FLOAT_EQ(largest(load_scene(write_model(m, dir + "/sun_sized.glb", true)), true), 0.53f);
  extras["angular_diameter"] = tinygltf::Value(-1.0);
  m.lights[1].extras = tinygltf::Value(extras);
  const std::string bad = write_model(m, dir + "/bad.glb", true);
  try {
    load_scene(bad);
    ADD_FAILURE() << "a negative angular diameter must be an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("extras.angular_diameter"), std::string::npos) << e.what();
  }
}

TEST(Gltf, DirectionalLightRendersLikeTheReference) {
  std::string dir = scratch_dir();
  tinygltf::Model m = fixture_model();
  m.lights[1].type = "directional";
  m.nodes[4].rotation = {-std::sin(M_PI / 6), 0, 0, std::cos(M_PI / 6)};  // -60 deg about x: -z tilts down
  m.scenes[0].nodes = {2, 4};                                             // the glass cube and the sun
  std::string path = write_model(m, dir + "/sun.glb", true);
  Scene s = load_scene(path);
  ASSERT_EQ(s.lights.size(), 1u);
  ASSERT_EQ(s.lights[0].type, LightType::Directional);
  EXPECT_NEAR(s.lights[0].direction.y, -std::sin(float(M_PI) / 3), 1e-5f);
  s.objects.push_back(Object{});
  s.objects.back().name = "ground";
  s.objects.back().mesh = std::make_shared<TriangleMesh>(make_ground(20, 20, 0.1f));
  s.objects.back().transform = make_transform({0, -1.0f, 0}, {0, 0, 0}, {1, 1, 1});
  s.camera.position = {-1.0f, 2.5f, 5.0f};
  s.camera.target = {-3.0f, -1.0f, -1.0f};
  s.objects.back().casts_shadows = false;  // the sun's map over the cube alone
  s.camera.near = 0.05f;                   // (the loader's default camera frames the cube alone)
  s.camera.far = 100.0f;
  s.camera.width = 64;
  s.camera.height = 48;
  s.shadows.resolution = 256;
  const FrameStats st = compared_render(s).stats;
  std::printf("[ gltf sun ] %llu lookups, %.2f dB against the reference, T mean %.4f\n",
              (unsigned long long)st.transmittance.points, st.image.psnr, st.transmittance.mean);
  EXPECT_GT(st.transmittance.points, 1000u) << "the sun lights the ground";
  EXPECT_GE(st.image.psnr, 40.0);
  EXPECT_LE(st.transmittance.mean, 0.02);
}

// ---- broken files ------------------------------------------------------------

std::string box_dir(const std::string& dir) {
  write_bytes(dir + "/Box0.bin", read_bytes(data_path("mesh/khronos_Box/Box0.bin")));
  return dir;
}

// Box.gltf edited as JSON; the string "@INF@" becomes the number 1e999
// (which JSON readers take as infinity).
std::string edited_box(const std::string& dir, const std::string& name, const std::function<void(json&)>& edit) {
  json j = json::parse(read_text(data_path("mesh/khronos_Box/Box.gltf")));
  edit(j);
  std::string text = j.dump();
  for (size_t at; (at = text.find("\"@INF@\"")) != std::string::npos;) text.replace(at, 7, "1e999");
  write_text(dir + "/" + name, text);
  return dir + "/" + name;
}

TEST(GltfBad, TruncatedGlb) {
  std::string dir = scratch_dir();
  std::string glb = write_model(fixture_model(), dir + "/good.glb", true);
  size_t size = read_bytes(glb).size();
  for (size_t n : {size_t(0), size_t(3), size_t(11), size_t(12), size_t(20), size / 3, size / 2, size - 40, size - 1}) {
    std::string cut = truncated_copy(glb, n, dir + "/cut" + std::to_string(n) + ".glb");
    expect_error([&] { load_scene(cut); }, {cut});
    expect_error([&] { load_gltf_mesh(cut); }, {cut});
  }
}

TEST(GltfBad, CorruptJson) {
  std::string dir = box_dir(scratch_dir());
  std::string text = read_text(data_path("mesh/khronos_Box/Box.gltf"));
  for (size_t n : {size_t(1), text.size() / 2, text.size() - 2}) {
    std::string p = dir + "/cut" + std::to_string(n) + ".gltf";
    write_text(p, text.substr(0, n));
    expect_error([&] { load_gltf_mesh(p); }, {p, "invalid glTF"});
  }
  write_text(dir + "/empty.gltf", "");
  expect_error([&] { load_scene(dir + "/empty.gltf"); }, {dir + "/empty.gltf"});
}

// A text .gltf cut inside its 223,000-character base64 buffer: one error
// line of reasonable length (the parser's context is capped), naming the
// file and where the JSON broke.
TEST(GltfBad, TruncatedBase64GivesAShortError) {
  std::string dir = scratch_dir();
  std::string text = read_text(data_path("mesh/vsa_teapot.gltf"));
  size_t at = text.find("base64,");
  ASSERT_NE(at, std::string::npos);
  std::string p = dir + "/cut_in_base64.gltf";
  write_text(p, text.substr(0, at + 100000));
  try {
    load_scene(p);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    std::string m = e.what();
    EXPECT_NE(m.find(p), std::string::npos) << m.substr(0, 300);
    EXPECT_NE(m.find("invalid glTF"), std::string::npos) << m.substr(0, 300);
    EXPECT_LE(m.size(), p.size() + 400) << m.substr(0, 600);
    EXPECT_EQ(m.find('\n'), std::string::npos) << "one line";
  }
}

TEST(GltfBad, ReferencesOutsideTheirData) {
  std::string dir = box_dir(scratch_dir());
  auto check = [&](const std::string& name, const std::function<void(json&)>& edit, std::vector<std::string> parts) {
    std::string p = edited_box(dir, name, edit);
    parts.insert(parts.begin(), p);
    expect_error([&] { load_gltf_mesh(p); }, parts);
    expect_error([&] { load_scene(p); }, parts);
  };
  check("acc_count.gltf", [](json& j) { j["accessors"][2]["count"] = 25; },
        {"accessor 2", "reads past the end of buffer view 1"});
  check("acc_offset.gltf", [](json& j) { j["accessors"][1]["byteOffset"] = 1 << 20; }, {"accessor 1", "past the end"});
  check("view_len.gltf", [](json& j) { j["bufferViews"][0]["byteLength"] = 100; },
        {"buffer view 0", "outside buffer 0"});
  check("view_buf.gltf", [](json& j) { j["bufferViews"][1]["buffer"] = 3; }, {"buffer 3"});
  check("bad_index.gltf", [](json& j) { j["meshes"][0]["primitives"][0]["indices"] = 9; },
        {"accessor", "out of bounds"});
  check("bad_attr.gltf", [](json& j) { j["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 0; },
        {"is not VEC3 of FLOAT"});
  check("bad_mesh.gltf", [](json& j) { j["nodes"][1]["mesh"] = 4; }, {"mesh 4", "does not exist"});
  check("bad_child.gltf", [](json& j) { j["nodes"][1]["children"] = {0}; }, {"cycle"});
  check("inf_json.gltf", [](json& j) { j["nodes"][0]["matrix"][0] = "@INF@"; }, {"invalid glTF", "overflow"});
  check("inf_matrix.gltf", [](json& j) { j["nodes"][0]["matrix"][5] = 1e39; }, {"(node 0)", "NaN or infinite"});
  check("inf_scale.gltf", [](json& j) { j["nodes"][1]["scale"] = {1.0, 1e39, 1.0}; }, {"(node 1)", "NaN or infinite"});
  check("draco.gltf", [](json& j) { j["extensionsRequired"] = {"KHR_draco_mesh_compression"}; },
        {"KHR_draco_mesh_compression"});
  // An index beyond the vertices: patch the first uint16 index in the buffer.
  std::vector<char> bin = read_bytes(dir + "/Box0.bin");
  bin[576] = char(0xff), bin[577] = char(0x00);
  write_bytes(dir + "/Box0.bin", bin);
  check("bad_vertex.gltf", [](json&) {}, {"index 0 is 255", "24 vertices"});
  // The buffer file missing.
  std::remove((dir + "/Box0.bin").c_str());
  check("no_bin.gltf", [](json&) {}, {"Box0.bin"});
}

TEST(GltfBad, NaNInTheData) {
  std::string dir = scratch_dir();
  tinygltf::Model m = fixture_model();
  float nan = std::nanf("");
  std::memcpy(m.buffers[0].data.data() + 4 * 3 * 5 + 4, &nan, 4);  // vertex 5, y
  std::string p = write_model(m, dir + "/nan.glb", true);
  expect_error([&] { load_scene(p); }, {p, "POSITION", "element 5", "NaN"});
  m = fixture_model();
  m.nodes[0].translation = {0, 1e39, 0};  // infinite as a float
  p = write_model(m, dir + "/inf_node.glb", true);
  expect_error([&] { load_scene(p); }, {p, "'rig' (node 0)", "NaN or infinite"});
}

// Normals are optional: NaN, infinite or zero-length ones (files exported
// by other tools have them) are recomputed from the geometry with one
// warning naming the file, mesh, primitive and count (issue "No silent wrong
// answers", item 10). NaN positions stay an error (above).
TEST(Gltf, BadNormalsAreRecomputedWithAWarning) {
  std::string dir = scratch_dir();
  tinygltf::Model m = fixture_model();
  // Per-vertex normals of the 8 cube corners (outward diagonals), three bad.
  std::vector<float> n(24);
  const float c[8][3] = {{-1, -1, -1}, {1, -1, -1}, {-1, 1, -1}, {1, 1, -1},
                         {-1, -1, 1},  {1, -1, 1},  {-1, 1, 1},  {1, 1, 1}};
  for (int v = 0; v < 8; ++v)
    for (int k = 0; k < 3; ++k) n[size_t(3 * v + k)] = c[v][k] / std::sqrt(3.0f);
  n[3 * 2 + 1] = std::nanf("");                       // vertex 2: NaN
  n[3 * 5 + 0] = INFINITY;                            // vertex 5: infinite
  n[3 * 7 + 0] = n[3 * 7 + 1] = n[3 * 7 + 2] = 0.0f;  // vertex 7: zero
  tinygltf::Buffer& buf = m.buffers[0];
  size_t at = buf.data.size();
  buf.data.resize(at + n.size() * 4);
  std::memcpy(buf.data.data() + at, n.data(), n.size() * 4);
  tinygltf::BufferView nv;
  nv.buffer = 0, nv.byteOffset = at, nv.byteLength = n.size() * 4;
  m.bufferViews.push_back(nv);
  tinygltf::Accessor na;
  na.bufferView = int(m.bufferViews.size() - 1), na.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT, na.count = 8;
  na.type = TINYGLTF_TYPE_VEC3;
  m.accessors.push_back(na);
  for (tinygltf::Mesh& me : m.meshes) me.primitives[0].attributes["NORMAL"] = int(m.accessors.size() - 1);
  std::string p = write_model(m, dir + "/bad_normals.glb", true);
  WarningCapture warnings;
  Scene s = load_scene(p);
  ASSERT_EQ(s.objects.size(), 2u);
  // One warning per primitive that had bad normals (both meshes share the data).
  ASSERT_EQ(warnings.lines.size(), 2u) << warnings.all();
  for (const std::string& w : warnings.lines) {
    EXPECT_NE(w.find(p), std::string::npos) << w;
    EXPECT_NE(w.find("primitive 0"), std::string::npos) << w;
    EXPECT_NE(w.find("3 normals"), std::string::npos) << w;
    EXPECT_NE(w.find("recomputed"), std::string::npos) << w;
  }
  EXPECT_NE(warnings.all().find("mesh 0 'cube'"), std::string::npos) << warnings.all();
  for (const Object& o : s.objects) {
    ASSERT_EQ(o.mesh->normals.size(), 8u);
    for (size_t v = 0; v < 8; ++v) {
      Vec3 nv3 = o.mesh->normals[v];
      ASSERT_TRUE(is_finite(nv3)) << v;
      EXPECT_NEAR(length(nv3), 1.0f, 1e-5f) << v;
      // Outward: along the corner's diagonal (area-weighted face normals).
      Vec3 d = normalize(o.mesh->positions[v]);
      EXPECT_GT(dot(nv3, d), 0.5f) << v;
    }
    EXPECT_NEAR(o.mesh->normals[0].x, -1.0f / std::sqrt(3.0f), 1e-6f) << "good normals are kept";
  }
  // It compiles and renders.
  SceneBuffers sb = compiled_scene(s);
  for (const Vec3& nv3 : sb.tri_normals) EXPECT_TRUE(is_finite(nv3));
}

// glTF values outside their range (issue "Reliability"): a camera aspect
// ratio of 1e10 (a 1x480 image through an out-of-range conversion before),
// and a scene's glTF mesh reference naming the empty node.
TEST(GltfBad, ValuesOutsideTheirRange) {
  std::string dir = scratch_dir();
  for (double aspect : {1e10, 1e-5}) {
    tinygltf::Model m = fixture_model();
    m.cameras[0].perspective.aspectRatio = aspect;
    std::string p = write_model(m, dir + "/aspect.glb", true);
    expect_error([&] { load_scene(p); }, {p, "aspectRatio", "outside [0.01, 100]"});
  }
  std::string glb = write_model(fixture_model(), dir + "/ok.glb", true);
  const std::string scene = std::string(R"({"camera": {"position": [0, 2, 6], "target": [0, 0, 0]},
    "objects": [{"name": "m", "mesh": {"type": "gltf", "file": ")") +
                            glb + R"(", "node": ""}}],
    "lights": [{"type": "point", "position": [0, 3, 0]}]})";
  expect_error([&] { parse_scene(scene, dir + "/s.json", dir); }, {"/objects/0/mesh/node", "names no node"});
  // A .glb header of version 1 (binary glTF 1.0; tinygltf read it as 2),
  // and a glTF 1.0 asset.
  std::vector<char> bytes = read_bytes(glb);
  bytes[4] = 1;
  write_bytes(dir + "/v1.glb", bytes);
  expect_error([&] { load_scene(dir + "/v1.glb"); }, {dir + "/v1.glb", "header says version 1", "only binary glTF 2"});
  tinygltf::Model old = fixture_model();
  old.asset.version = "1.0";
  std::string p1 = write_model(old, dir + "/old.gltf", false);
  expect_error([&] { load_scene(p1); }, {p1, "asset.version is '1.0'"});
}

TEST(GltfBad, NoMeshes) {
  std::string dir = scratch_dir();
  tinygltf::Model m = fixture_model();
  m.nodes[1].mesh = -1;
  m.nodes[2].mesh = -1;
  std::string p = write_model(m, dir + "/nomesh.glb", true);
  expect_error([&] { load_scene(p); }, {p, "no triangle meshes"});
  expect_error([&] { load_gltf_mesh(p); }, {p, "no triangle meshes"});
  write_text(dir + "/bare.gltf", R"({"asset": {"version": "2.0"}})");
  expect_error([&] { load_scene(dir + "/bare.gltf"); }, {dir + "/bare.gltf", "no triangle meshes"});
  expect_error([&] { load_scene(dir + "/missing.glb"); }, {dir + "/missing.glb"});
}

TEST(GltfBad, MeshReferenceFromAScene) {
  std::string dir = scratch_dir();
  const std::string scene = R"({"camera": {"position": [0, 1, 5], "target": [0, 0, 0]},
    "objects": [{"name": "k", "mesh": {"type": "gltf", "file": "$SHARED/mesh/vsa_torusknot.gltf", "node": "%NODE%"}}],
    "lights": [{"type": "point", "position": [0, 4, 0]}]})";
  auto with = [&](const std::string& node) {
    std::string s = scene;
    s.replace(s.find("%NODE%"), 6, node);
    return s;
  };
  Scene s = parse_scene(with("default"), dir + "/s.json", dir);
  EXPECT_EQ(s.objects[0].mesh->triangle_count(), 2880u);
  expect_error([&] { parse_scene(with("nope"), dir + "/s.json", dir); },
               {dir + "/s.json: /objects/0/mesh/file", "vsa_torusknot.gltf", "no node 'nope'"});
}

}  // namespace
}  // namespace cdsm_test
