// The editor's state without a window (editor/state, STYLE.md 14): undo and
// redo of every kind of edit restore the document field by field,
// coalescing, the dirty flag, saving never over the opened file, TRS
// editing, and what each edit invalidates checked against a real
// ShadowSystem (CPU fragments): the maps it rebuilds and why, what it
// recompiles, and the image after a sequence of edits and undos equal bit
// for bit to a fresh system's.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "cdsm/error.h"
#include "cdsm/loaders.h"
#include "cdsm/procedural.h"
#include "cdsm/scene_io.h"
#include "cdsm/shadow_system.h"
#include "common/builders.h"
#include "editor/scene_equal.h"
#include "state/document.h"
#include "state/edit.h"
#include "state/history.h"
#include "state/system_binding.h"
#include "state/transform.h"

namespace cdsm_test {
namespace {

using namespace cdsm;
using namespace cdsm::editor;

std::string scratch_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string dir = std::string(CDSM_TEST_OUTPUT_DIR) + "/editor/" + info->test_suite_name() + "." + info->name();
  std::string cmd = "rm -rf '" + dir + "' && mkdir -p '" + dir + "'";
  if (std::system(cmd.c_str()) != 0) ADD_FAILURE() << "cannot create " << dir;
  return dir;
}

// A small scene: a receive-only ground, a translucent sphere (closest to
// both lights), an opaque box, a small receive-only tile, a coloured
// medium box and a dense volume in its own object; a spot and a point light.
Scene test_scene() {
  Scene s = cdsm_test::empty_scene("editor test scene");
  s.camera = cdsm_test::camera_at({0.5f, 3.0f, 5.5f}, {0, 0.3f, 0}, 64, 48);
  s.camera.far = 40;
  s.shadows.resolution = 64;
  s.shadows.epsilon = 0.01f;
  auto add = [&](const std::string& name, TriangleMesh m, Vec3 at) -> Object& {
    Object o;
    o.name = name;
    o.mesh = std::make_shared<TriangleMesh>(std::move(m));
    o.transform = make_transform(at, {0, 0, 0}, {1, 1, 1});
    s.objects.push_back(o);
    return s.objects.back();
  };
  add("ground", make_ground(8, 8), {0, 0, 0}).casts_shadows = false;              // 0
  Object& sphere = add("sphere", make_sphere(0.3f, 16, 8), {1.5f, 0.31f, 0.0f});  // 1
  sphere.surface.opacity = 0.4f;
  add("box", make_box({0.4f, 0.5f, 0.4f}), {-1.5f, 0.251f, 0.2f});                         // 2
  add("tile", make_box({0.3f, 0.02f, 0.3f}), {0.0f, 0.011f, 1.5f}).casts_shadows = false;  // 3
  Object& glass = add("glass", make_box({0.4f, 0.4f, 0.4f}), {-0.3f, 0.201f, -1.6f});      // 4
  glass.surface.opacity = 0.2f;
  glass.interior = InteriorKind::Constant;
  glass.sigma = {1.0f, 2.0f, 3.0f};
  auto grid = std::make_shared<DenseGrid>();
  grid->nx = grid->ny = grid->nz = 4;
  grid->values.resize(64);
  for (size_t i = 0; i < 64; ++i) grid->values[i] = float((i * 7) % 5) * 0.25f;
  Volume v;
  v.name = "puff";
  v.grid = grid;
  v.index_to_object = make_transform({0.05f, 0.05f, 0.05f}, {0, 0, 0}, {0.1f, 0.1f, 0.1f});
  v.transfer = {{0.0f, {0, 0, 0}, {1, 1, 1}}, {1.0f, {4, 4, 4}, {0.9f, 0.9f, 0.9f}}};
  s.volumes.push_back(v);
  Object& puff = add("puff", make_volume_proxy(v), {0.6f, 0.0f, -0.6f});  // 5
  puff.interior = InteriorKind::Volume;
  puff.volume = 0;
  puff.surface.opacity = 0.0f;
  Light spot;
  spot.name = "spot";
  spot.position = {1.5f, 4.0f, 0.3f};
  spot.direction = normalize(Vec3{-1.5f, -4.0f, -0.3f});
  spot.outer_cone_deg = 45;
  spot.inner_cone_deg = 40;
  s.lights.push_back(spot);
  Light point;
  point.name = "point";
  point.type = LightType::Point;
  point.position = {1.6f, 2.2f, 0.8f};
  point.color = {1.0f, 0.9f, 0.8f};
  point.intensity = 0.6f;
  s.lights.push_back(point);
  return s;
}

Document test_document() {
  Document d;
  d.scene = test_scene();
  return d;
}

// ---- undo / redo ----------------------------------------------------------------

// Every kind of edit: made on the document as it is.
std::vector<std::pair<std::string, std::function<Edit(const Document&)>>> every_kind() {
  return {
      {"settings",
       [](const Document& d) {
         ShadowSettings s = d.scene.shadows;
         s.epsilon = 0.05f;
         s.max_clusters = 3;
         return set_settings(d, s);
       }},
      {"camera",
       [](const Document& d) {
         Camera c = d.scene.camera;
         c.position.x += 0.5f;
         c.fov_y_deg = 50;
         return set_camera(d, c);
       }},
      {"background",
       [](const Document& d) {
         return set_background(d, {0.2f, 0.1f, 0.0f});
       }},
      {"light",
       [](const Document& d) {
         Light l = d.scene.lights[1];
         l.position.y = 3;
         l.color = {0.5f, 0.5f, 1.0f};
         return set_light(d, 1, l);
       }},
      {"add light",
       [](const Document& d) {
         Light l;
         l.name = "new";
         l.position = {-2, 3, 1};
         return add_light(d, l);
       }},
      {"add sun",  // the Lights panel's "add sun": a directional light with the sun's size
       [](const Document& d) {
         Light l;
         l.name = "sun";
         l.type = LightType::Directional;
         l.direction = normalize(Vec3{-0.5f, -0.57f, -0.63f});
         l.angular_diameter_deg = 0.53f;
         return add_light(d, l);
       }},
      {"aim sun",  // its elevation and azimuth sliders: a new direction
       [](const Document& d) {
         Light l = d.scene.lights.back();
         l.direction = normalize(Vec3{0.3f, -0.9f, 0.1f});
         return set_light(d, d.scene.lights.size() - 1, l);
       }},
      {"remove light", [](const Document& d) { return remove_light(d, 0); }},
      {"transform",
       [](const Document& d) {
         return set_transform(d, 2, make_transform({-1.4f, 0.251f, 0.3f}, {0, 30, 0}, {1, 1.2f, 1}));
       }},
      {"surface",
       [](const Document& d) {
         SurfaceMaterial m = d.scene.objects[1].surface;
         m.color = {0.1f, 0.9f, 0.2f};
         m.opacity = 0.7f;
         m.transmission_color = {1.0f, 0.5f, 0.5f};
         return set_surface(d, 1, m);
       }},
      {"interior",
       [](const Document& d) {
         return set_interior(d, 2, InteriorKind::Constant, {2, 2, 2}, -1);
       }},
      {"interior sigma",
       [](const Document& d) {
         return set_interior(d, 4, InteriorKind::Constant, {0.5f, 1, 2}, -1);
       }},
      {"casts shadows", [](const Document& d) { return set_casts_shadows(d, 3, true); }},
      {"transfer",
       [](const Document& d) {
         std::vector<TransferPoint> t = d.scene.volumes[0].transfer;
         t[1].extinction = {8, 6, 4};
         t.push_back({2.0f, {10, 10, 10}, {0.5f, 0.5f, 0.5f}});
         return set_transfer(d, 0, t);
       }},
  };
}

TEST(History, UndoAndRedoOfEveryKindRestoreTheScene) {
  for (const auto& [name, make] : every_kind()) {
    SCOPED_TRACE(name);
    Document doc = test_document();
    History h;
    const Scene before = doc.scene;
    std::string why;
    ASSERT_TRUE(h.apply(doc, make(doc), 0.0)) << h.last_refusal();
    EXPECT_FALSE(equal_scenes(before, doc.scene, &why)) << "the edit changed nothing";
    EXPECT_TRUE(doc.dirty);
    const Scene after = doc.scene;
    ASSERT_TRUE(h.undo(doc));
    EXPECT_TRUE(equal_scenes(before, doc.scene, &why)) << "undo: " << why;
    ASSERT_TRUE(h.redo(doc));
    EXPECT_TRUE(equal_scenes(after, doc.scene, &why)) << "redo: " << why;
    ASSERT_TRUE(h.undo(doc));
    EXPECT_TRUE(equal_scenes(before, doc.scene, &why)) << "undo again: " << why;
    EXPECT_FALSE(h.undo(doc));
  }
}

TEST(History, ASequenceOfEveryKindUndoesToTheStart) {
  Document doc = test_document();
  History h;
  std::vector<Scene> states{doc.scene};
  double t = 0.0;
  for (const auto& [name, make] : every_kind()) {
    ASSERT_TRUE(h.apply(doc, make(doc), t += 1.0)) << name << ": " << h.last_refusal();
    states.push_back(doc.scene);
  }
  EXPECT_EQ(h.size(), every_kind().size());
  std::string why;
  for (size_t k = states.size() - 1; k-- > 0;) {
    ASSERT_TRUE(h.undo(doc));
    EXPECT_TRUE(equal_scenes(states[k], doc.scene, &why)) << "after undoing to step " << k << ": " << why;
  }
  for (size_t k = 1; k < states.size(); ++k) {
    ASSERT_TRUE(h.redo(doc));
    EXPECT_TRUE(equal_scenes(states[k], doc.scene, &why)) << "after redoing step " << k << ": " << why;
  }
}

ShadowSettings with_epsilon(const Document& d, float eps) {
  ShadowSettings s = d.scene.shadows;
  s.epsilon = eps;
  return s;
}

TEST(History, ASliderDragIsOneStep) {
  Document doc = test_document();
  History h;
  // Within 0.5 s of each other: one step.
  for (int i = 1; i <= 10; ++i)
    ASSERT_TRUE(h.apply(doc, set_settings(doc, with_epsilon(doc, 0.01f * float(i + 1))), 0.1 * i));
  EXPECT_EQ(h.size(), 1u);
  EXPECT_EQ(doc.scene.shadows.epsilon, 0.11f);
  // Later than 0.5 s after the last: a new step.
  ASSERT_TRUE(h.apply(doc, set_settings(doc, with_epsilon(doc, 0.2f)), 1.6));
  EXPECT_EQ(h.size(), 2u);
  // Another field at once: a new step.
  ShadowSettings s = doc.scene.shadows;
  s.d0 = 0.5f;
  ASSERT_TRUE(h.apply(doc, set_settings(doc, s), 1.7));
  EXPECT_EQ(h.size(), 3u);
  ASSERT_TRUE(h.undo(doc));
  ASSERT_TRUE(h.undo(doc));
  EXPECT_EQ(doc.scene.shadows.epsilon, 0.11f);
  ASSERT_TRUE(h.undo(doc));
  EXPECT_EQ(doc.scene.shadows.epsilon, 0.01f);  // the whole drag at once
}

TEST(History, AGestureIsOneStepWhateverItsLength) {
  Document doc = test_document();
  History h;
  h.begin_gesture();
  for (int i = 0; i < 5; ++i) {
    Light l = doc.scene.lights[0];
    l.position.x += 0.25f;
    ASSERT_TRUE(h.apply(doc, set_light(doc, 0, l), 3.0 * i));  // seconds apart
  }
  h.end_gesture();
  EXPECT_EQ(h.size(), 1u);
  // After the gesture, the same key starts a new step even at once.
  Light l = doc.scene.lights[0];
  l.position.x += 0.25f;
  ASSERT_TRUE(h.apply(doc, set_light(doc, 0, l), 12.01));
  EXPECT_EQ(h.size(), 2u);
  // So does an undo: the next edit does not merge into the redone step.
  ASSERT_TRUE(h.undo(doc));
  ASSERT_TRUE(h.redo(doc));
  l.position.x += 0.25f;
  ASSERT_TRUE(h.apply(doc, set_light(doc, 0, l), 12.02));
  EXPECT_EQ(h.size(), 3u);
  ASSERT_TRUE(h.undo(doc));
  ASSERT_TRUE(h.undo(doc));
  ASSERT_TRUE(h.undo(doc));
  EXPECT_EQ(doc.scene.lights[0].position.x, test_scene().lights[0].position.x);
}

TEST(History, ADragBackToItsStartLeavesNoStep) {
  Document doc = test_document();
  History h;
  ASSERT_TRUE(h.apply(doc, set_settings(doc, with_epsilon(doc, 0.02f)), 0.0));
  ASSERT_TRUE(h.apply(doc, set_settings(doc, with_epsilon(doc, 0.01f)), 0.1));
  EXPECT_EQ(h.size(), 0u);
  // Structural edits never coalesce.
  Light l;
  ASSERT_TRUE(h.apply(doc, add_light(doc, l), 0.2));
  ASSERT_TRUE(h.apply(doc, add_light(doc, l), 0.3));
  EXPECT_EQ(h.size(), 2u);
  EXPECT_EQ(doc.scene.lights.size(), 4u);
}

TEST(History, ANewEditClearsRedo) {
  Document doc = test_document();
  History h;
  ASSERT_TRUE(h.apply(doc, set_background(doc, {1, 0, 0}), 0.0));
  ASSERT_TRUE(h.apply(doc, set_casts_shadows(doc, 2, false), 1.0));
  ASSERT_TRUE(h.undo(doc));
  EXPECT_TRUE(h.can_redo());
  ASSERT_TRUE(h.apply(doc, set_casts_shadows(doc, 1, false), 2.0));
  EXPECT_FALSE(h.can_redo());
  EXPECT_FALSE(h.redo(doc));
  EXPECT_TRUE(doc.scene.objects[2].casts_shadows);
}

TEST(History, PendingEditsReplayWhatChanged) {
  Document doc = test_document();
  History h;
  ASSERT_TRUE(h.apply(doc, set_casts_shadows(doc, 2, false), 0.0));
  ASSERT_TRUE(h.undo(doc));
  ASSERT_TRUE(h.redo(doc));
  std::vector<Edit> p = h.take_pending();
  ASSERT_EQ(p.size(), 3u);
  EXPECT_FALSE(std::get<change::CastsShadows>(p[0].what).after);
  EXPECT_TRUE(std::get<change::CastsShadows>(p[1].what).after);
  EXPECT_FALSE(std::get<change::CastsShadows>(p[2].what).after);
  EXPECT_TRUE(h.take_pending().empty());
  // A coalesced edit still replays its own change.
  ASSERT_TRUE(h.apply(doc, set_settings(doc, with_epsilon(doc, 0.02f)), 5.0));
  ASSERT_TRUE(h.apply(doc, set_settings(doc, with_epsilon(doc, 0.03f)), 5.1));
  p = h.take_pending();
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(std::get<change::Settings>(p[1].what).before.epsilon, 0.02f);
  EXPECT_EQ(std::get<change::Settings>(p[1].what).after.epsilon, 0.03f);
}

TEST(History, DirtyFlag) {
  Document doc = test_document();
  History h;
  EXPECT_FALSE(doc.dirty);
  EXPECT_FALSE(h.apply(doc, set_settings(doc, doc.scene.shadows), 0.0)) << "a no-op is not an edit";
  EXPECT_FALSE(doc.dirty);
  EXPECT_EQ(h.size(), 0u);
  ASSERT_TRUE(h.apply(doc, set_background(doc, {0, 0, 1}), 0.0));
  EXPECT_TRUE(doc.dirty);
  std::string why;
  ASSERT_TRUE(save_document(doc, scratch_dir() + "/saved.json", false, &why)) << why;
  EXPECT_FALSE(doc.dirty);
  ASSERT_TRUE(h.undo(doc));
  EXPECT_TRUE(doc.dirty);
}

TEST(History, RefusedEditsChangeNothing) {
  Document doc = test_document();
  History h;
  const Scene before = doc.scene;
  auto refused = [&](const Edit& e, const std::string& part) {
    EXPECT_FALSE(h.apply(doc, e, 0.0));
    EXPECT_NE(h.last_refusal().find(part), std::string::npos) << h.last_refusal();
    std::string why;
    EXPECT_TRUE(equal_scenes(before, doc.scene, &why)) << why;
    EXPECT_EQ(h.size(), 0u);
    EXPECT_FALSE(doc.dirty);
  };
  refused(set_light(doc, 7, Light{}), "light 7 does not exist");
  refused(remove_light(doc, 2), "light 2 does not exist");
  refused(set_transform(doc, 99, Mat4{}), "object 99");
  Mat4 nan;
  nan.m[0][3] = std::nanf("");
  refused(set_transform(doc, 1, nan), "NaN");
  refused(set_interior(doc, 2, InteriorKind::Volume, {0, 0, 0}, 0), "interior of object 5 already");
  refused(set_interior(doc, 2, InteriorKind::Volume, {0, 0, 0}, 3), "volume 3 does not exist");
  refused(set_interior(doc, 5, InteriorKind::None, {0, 0, 0}, 0), "volume 0 'puff' fills this object");
  refused(set_interior(doc, 5, InteriorKind::Constant, {1, 1, 1}, 0), "cannot be taken out");
  refused(set_transfer(doc, 0, {}), "1 to");
  refused(set_transfer(doc, 0, {{1.0f, {1, 1, 1}, {1, 1, 1}}, {0.5f, {1, 1, 1}, {1, 1, 1}}}), "sorted");
  Document full = doc;
  while (full.scene.lights.size() < size_t(kMaxLights)) full.scene.lights.push_back(Light{});
  EXPECT_FALSE(h.apply(full, add_light(full, Light{}), 0.0));
  EXPECT_NE(h.last_refusal().find("at most"), std::string::npos);
}

// ---- documents ----------------------------------------------------------------------

TEST(Document, SavingNeverOverwritesTheOpenedFileUnlessAsked) {
  const std::string dir = scratch_dir();
  const std::string opened = dir + "/scene.json";
  save_scene(test_scene(), opened);
  Document doc = open_document(opened);
  EXPECT_EQ(doc.path, opened);
  EXPECT_FALSE(doc.dirty);
  const std::string original = [&] {
    std::ifstream in(opened);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }();
  History h;
  ASSERT_TRUE(h.apply(doc, set_background(doc, {0.3f, 0.3f, 0.3f}), 0.0));
  std::string why;
  // The same file by its name, a relative alias and a link: refused.
  ASSERT_EQ(::symlink(opened.c_str(), (dir + "/link.json").c_str()), 0);
  for (const std::string& same : {opened, dir + "/./scene.json", dir + "/link.json"}) {
    EXPECT_FALSE(save_document(doc, same, false, &why)) << same;
    EXPECT_NE(why.find("opened from"), std::string::npos) << why;
    EXPECT_TRUE(doc.dirty);
  }
  std::ifstream in(opened);
  std::stringstream now;
  now << in.rdbuf();
  EXPECT_EQ(now.str(), original) << "the opened file changed";
  // Another name: saved, reloads equal.
  ASSERT_TRUE(save_document(doc, dir + "/other.json", false, &why)) << why;
  EXPECT_EQ(doc.saved_path, dir + "/other.json");
  EXPECT_FALSE(doc.dirty);
  EXPECT_TRUE(equal_scenes(doc.scene, open_document(dir + "/other.json").scene, &why)) << why;
  // Saving again there is no overwrite of the opened file.
  ASSERT_TRUE(save_document(doc, dir + "/other.json", false, &why)) << why;
  // Asked: the opened file is overwritten.
  ASSERT_TRUE(save_document(doc, opened, true, &why)) << why;
  EXPECT_TRUE(equal_scenes(doc.scene, open_document(opened).scene, &why)) << why;
  // Errors come back as a refusal naming the path.
  EXPECT_FALSE(save_document(doc, dir + "/no/such/dir/x.json", false, &why));
  EXPECT_NE(why.find(dir + "/no/such/dir/x.json"), std::string::npos) << why;
  EXPECT_FALSE(save_document(doc, dir + "/x.glb", false, &why));
}

TEST(Document, OpensJsonAndGltf) {
  Document d = open_document(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/default.json");
  EXPECT_GT(d.scene.objects.size(), 5u);
  EXPECT_THROW(open_document(scratch_dir() + "/missing.json"), Error);
  const std::string gltf = data_dir() + "/mesh/vsa_primitives_scene.gltf";
  Document g = open_document(gltf);
  EXPECT_GT(g.scene.objects.size(), 3u);
  std::string why;
  ASSERT_TRUE(save_document(g, scratch_dir() + "/from_gltf.json", false, &why)) << why;
}

// ---- translate / rotate / scale -------------------------------------------------------------

TEST(Trs, DecomposeGivesBackWhatComposeWasGiven) {
  const Trs cases[] = {
      {{0, 0, 0}, {0, 0, 0}, {1, 1, 1}},
      {{-0.95f, 0.0f, 0.15f}, {0, 25, 0}, {0.13f, 0.13f, 0.13f}},
      {{1.45f, 0.351f, -0.55f}, {0, 30, 0}, {1, 1, 1}},
      {{0.5f, 0.25f, -0.3f}, {10, 33.3f, -71}, {1, 1.5f, 0.8f}},
      {{0, 0, 0}, {-45, 60, 170}, {2, 0.5f, 3}},
      {{3, 2, 1}, {12.5f, -80, 0.25f}, {0.02f, 0.02f, 0.02f}},
      {{0, 1, 0}, {0, 0, 0}, {-1, 1, 1}},   // mirrored
      {{0, 1, 0}, {0, 45, 0}, {1, -2, 1}},  // mirrored in y
      {{0, 0, 0}, {90, 0, 0}, {1, 1, 1}},
      {{0, 0, 0}, {0, 0, 179.5f}, {1.25f, 1.25f, 1.25f}},
  };
  for (const Trs& t : cases) {
    const Mat4 m = compose(t);
    const Trs d = decompose(m);
    const Mat4 again = compose(d);
    EXPECT_EQ(std::memcmp(&m, &again, sizeof m), 0)
        << "rotate " << t.rotate_deg.x << " " << t.rotate_deg.y << " " << t.rotate_deg.z << " scale " << t.scale.x
        << " " << t.scale.y << " " << t.scale.z << " -> " << d.rotate_deg.x << " " << d.rotate_deg.y << " "
        << d.rotate_deg.z << " scale " << d.scale.x << " " << d.scale.y << " " << d.scale.z;
    EXPECT_EQ(std::memcmp(&d.translate, &t.translate, sizeof(Vec3)), 0);
  }
  // The values themselves where the matrix does not mirror (mirrors can be
  // said several ways).
  const Trs t{{0.5f, 0.25f, -0.3f}, {10, 33.3f, -71}, {1, 1.5f, 0.8f}};
  const Trs d = decompose(compose(t));
  EXPECT_EQ(d.rotate_deg.x, 10.0f);
  EXPECT_EQ(d.rotate_deg.y, 33.3f);
  EXPECT_EQ(d.rotate_deg.z, -71.0f);
  EXPECT_EQ(d.scale.y, 1.5f);
  EXPECT_EQ(d.scale.z, 0.8f);
  const Trs mirrored = decompose(compose({{0, 1, 0}, {0, 0, 0}, {-1, 1, 1}}));
  EXPECT_EQ(mirrored.scale.x, -1.0f);
  EXPECT_EQ(mirrored.rotate_deg.y, 0.0f);
}

TEST(Trs, AHintKeepsADragGoing) {
  // Y past 90: of the two Euler triples, (0, 91, 0) and (180, 89, 180),
  // only the first composes to the matrix exactly, so it is the answer.
  const Mat4 m = compose({{0, 0, 0}, {0, 91, 0}, {1, 1, 1}});
  const Trs plain = decompose(m);
  EXPECT_EQ(plain.rotate_deg.x, 0.0f);
  EXPECT_EQ(plain.rotate_deg.y, 91.0f);
  EXPECT_EQ(plain.rotate_deg.z, 0.0f);
  // A matrix no short decimals make (a glTF node's, say): without a hint
  // the triple with Y within [-90, 90]; with the panel's last values, the
  // one the drag is on.
  Mat4 odd = m;
  odd.m[0][0] = std::nextafter(odd.m[0][0], 1.0f);
  const Trs far = decompose(odd);
  EXPECT_NEAR(far.rotate_deg.y, 89.0f, 1e-3f);
  EXPECT_NEAR(std::fabs(far.rotate_deg.x), 180.0f, 1e-3f);
  const Trs near = decompose(odd, Trs{{0, 0, 0}, {0, 90.5f, 0}, {1, 1, 1}});
  EXPECT_NEAR(near.rotate_deg.x, 0.0f, 1e-3f);
  EXPECT_NEAR(near.rotate_deg.y, 91.0f, 1e-3f);
  EXPECT_NEAR(near.rotate_deg.z, 0.0f, 1e-3f);
  // Angles stay near the hint by whole turns when that is exact too.
  const Trs turned = decompose(compose({{0, 0, 0}, {0, 0, 0}, {1, 1, 1}}), Trs{{0, 0, 0}, {0, 359, 0}, {1, 1, 1}});
  EXPECT_TRUE(turned.rotate_deg.y == 0.0f || turned.rotate_deg.y == 360.0f);
}

TEST(Trs, OtherMatricesGiveTheNearestTrs) {
  // A gimbal-locked rotation and a sheared matrix: finite values, the
  // rotation kept (the shear cannot be).
  const Mat4 locked = compose({{0, 0, 0}, {30, 90, 0}, {1, 1, 1}});
  const Mat4 back = compose(decompose(locked));
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(back.m[i][j], locked.m[i][j], 1e-5f);
  Mat4 shear = compose({{1, 2, 3}, {0, 20, 0}, {1, 1, 1}});
  shear.m[0][1] += 0.3f;
  const Trs d = decompose(shear);
  EXPECT_TRUE(std::isfinite(d.rotate_deg.x) && std::isfinite(d.rotate_deg.y) && std::isfinite(d.rotate_deg.z));
  EXPECT_EQ(d.translate.z, 3.0f);
  // A collapsed axis: scale 0 there.
  Mat4 flat = compose({{0, 0, 0}, {0, 0, 0}, {1, 0, 2}});
  EXPECT_EQ(decompose(flat).scale.y, 0.0f);
}

// ---- invalidation against a real shadow system ---------------------------------------------

struct MapKey {
  int light, slot;
  bool operator<(const MapKey& o) const { return light != o.light ? light < o.light : slot < o.slot; }
};

std::set<MapKey> holding(const std::vector<ShadowSystem::MapInfo>& maps, int object) {
  std::set<MapKey> out;
  for (const auto& m : maps)
    if (std::find(m.members.begin(), m.members.end(), object) != m.members.end()) out.insert({m.light, m.slot});
  return out;
}

std::string keys_text(const std::set<MapKey>& s) {
  std::string t;
  for (const MapKey& k : s) t += " " + std::to_string(k.light) + "/" + std::to_string(k.slot);
  return t.empty() ? " (none)" : t;
}

// A document, its history, a shadow system bound to it, updated once.
struct Bench {
  Document doc = test_document();
  History history;
  ShadowSystem system;
  std::unique_ptr<SystemBinding> binding;
  double t = 0.0;

  static SystemOptions options() {
    SystemOptions o;
    o.fragments = FragmentSource::Cpu;
    o.source = "editor test";
    return o;
  }
  explicit Bench(const ShadowSettings* settings = nullptr) : system(options()) {
    if (settings) doc.scene.shadows = *settings;
    binding = std::make_unique<SystemBinding>(system, doc.scene);
    FrameStats st;
    system.update(&st);
  }

  // Applies the edit (or undo / redo), replays it on the system, updates,
  // and checks what was rebuilt and recompiled against invalidation_of.
  void check_pending(const std::string& what) {
    SCOPED_TRACE(what);
    const std::vector<ShadowSystem::MapInfo> before = system.maps();
    std::vector<Edit> pending = history.take_pending();
    ASSERT_EQ(pending.size(), 1u);
    const Edit& e = pending[0];
    binding->apply(e, doc.scene);
    const Invalidation inv = invalidation_of(e);
    FrameStats st;
    system.update(&st);
    const std::vector<ShadowSystem::MapInfo> after = system.maps();
    std::set<MapKey> rebuilt;
    for (const MapRebuild& r : st.update.rebuilds) rebuilt.insert({int(r.light), int(r.map)});
    ASSERT_EQ(rebuilt.size(), st.maps_rebuilt);
    const uint32_t* why = st.update.rebuilt_by_reason;
    auto count = [&](RebuildReason r) { return why[int(r)]; };
    using Maps = Invalidation::Maps;
    switch (inv.maps) {
      case Maps::None: EXPECT_EQ(st.maps_rebuilt, 0u) << inv.describe() << "; rebuilt" << keys_text(rebuilt); break;
      case Maps::All:
        EXPECT_EQ(st.maps_rebuilt, after.size()) << inv.describe();
        EXPECT_EQ(count(RebuildReason::Settings), st.maps_rebuilt);
        break;
      case Maps::Lights: {
        std::set<MapKey> expected;
        for (const auto& m : after)
          if (m.light >= inv.light_first && m.light <= inv.light_last) expected.insert({m.light, m.slot});
        EXPECT_EQ(keys_text(rebuilt), keys_text(expected)) << inv.describe();
        EXPECT_EQ(count(RebuildReason::Light) + count(RebuildReason::New), st.maps_rebuilt);
        break;
      }
      case Maps::Object: {
        std::set<MapKey> expected = holding(before, inv.object);
        for (const MapKey& k : holding(after, inv.object)) expected.insert(k);
        EXPECT_EQ(keys_text(rebuilt), keys_text(expected)) << inv.describe();
        EXPECT_EQ(count(RebuildReason::Settings) + count(RebuildReason::Light) + count(RebuildReason::New), 0u);
        break;
      }
      case Maps::Views: {
        for (const MapRebuild& r : st.update.rebuilds)
          EXPECT_TRUE(r.reason == RebuildReason::Members || r.reason == RebuildReason::Frustum ||
                      r.reason == RebuildReason::New)
              << to_string(r.reason);
        break;
      }
    }
    using Compile = Invalidation::Compile;
    EXPECT_EQ(st.update.full_compiles, inv.compile == Compile::Structure ? 1u : 0u) << inv.describe();
    if (inv.compile != Compile::Structure) {  // a full compile recompiles every object
      EXPECT_EQ(st.update.objects_compiled, inv.compile == Compile::Object ? 1u : 0u) << inv.describe();
    }
    EXPECT_EQ(st.update.volumes_compiled, inv.compile == Compile::Volume ? 1u : 0u) << inv.describe();
    maps_rebuilt_last = st.maps_rebuilt;
  }
  uint32_t maps_rebuilt_last = 0;

  void edit(const Edit& e, const std::string& what) {
    ASSERT_TRUE(history.apply(doc, e, t += 1.0)) << what << ": " << history.last_refusal();
    check_pending(what);
  }
  void undo(const std::string& what) {
    ASSERT_TRUE(history.undo(doc));
    check_pending("undo " + what);
  }
};

TEST(Invalidation, EachKindRebuildsWhatItSays) {
  Bench b;
  Document& d = b.doc;
  auto settings = [&](const std::function<void(ShadowSettings&)>& f) {
    ShadowSettings s = d.scene.shadows;
    f(s);
    return set_settings(d, s);
  };
  // Settings: map settings rebuild every map; lookup settings none.
  b.edit(settings([](ShadowSettings& s) { s.epsilon = 0.05f; }), "epsilon");
  EXPECT_EQ(invalidation_of(b.history.last()->inverse()).maps, Invalidation::Maps::All);
  EXPECT_EQ(b.maps_rebuilt_last, 7u);  // a spot map and six cube faces
  b.edit(settings([](ShadowSettings& s) { s.resolution = 48; }), "resolution");
  b.edit(settings([](ShadowSettings& s) { s.layout = DsmLayout::Chunked; }), "layout");
  b.edit(settings([](ShadowSettings& s) { s.filtering = false; }), "filtering");
  EXPECT_EQ(invalidation_of(*b.history.last()).maps, Invalidation::Maps::None);
  b.edit(settings([](ShadowSettings& s) { s.bias_constant = 0.001f; }), "bias");
  b.edit(settings([](ShadowSettings& s) { s.receiver = ReceiverLookup::SlopeBias; }), "receiver");
  b.edit(settings([](ShadowSettings& s) { s.ambient_light = {0.2f, 0.2f, 0.2f}; }), "ambient");
  b.edit(settings([](ShadowSettings& s) { s.d0 = 0.5f; }), "d0 without clusters");
  // The camera: fixed maps do not follow it.
  Camera c = d.scene.camera;
  c.position = {-1.0f, 2.5f, 5.0f};
  b.edit(set_camera(d, c), "camera");
  EXPECT_EQ(invalidation_of(*b.history.last()).maps, Invalidation::Maps::None);
  b.edit(set_background(d, {0.3f, 0.2f, 0.1f}), "background");
  // Lights: colour, intensity and inner cone nothing; moving one its maps.
  Light l = d.scene.lights[0];
  l.color = {1.0f, 0.5f, 0.5f};
  l.intensity = 2.0f;
  l.inner_cone_deg = 30.0f;
  b.edit(set_light(d, 0, l), "spot colour");
  l.position.x += 0.2f;
  b.edit(set_light(d, 0, l), "spot moved");
  EXPECT_EQ(b.maps_rebuilt_last, 1u);
  Light p = d.scene.lights[1];
  p.position.z += 0.1f;
  b.edit(set_light(d, 1, p), "point moved");
  EXPECT_EQ(b.maps_rebuilt_last, 6u);
  p.direction = {1, 0, 0};
  b.edit(set_light(d, 1, p), "point direction (unused)");
  // Adding a light builds its maps; removing one in the middle rebuilds
  // nothing; undoing that puts it back in its place: it and the lights
  // after it are new to the system.
  Light extra;
  extra.position = {-2.0f, 3.0f, 1.0f};
  extra.direction = normalize(Vec3{2, -3, -1});
  b.edit(add_light(d, extra), "add light");
  EXPECT_EQ(b.maps_rebuilt_last, 1u);
  b.edit(remove_light(d, 1), "remove the point light");
  b.undo("remove the point light");
  EXPECT_EQ(b.maps_rebuilt_last, 6u);  // its cube faces; the light after it keeps its map
  EXPECT_EQ(d.scene.lights[1].name, "point");
  // Objects: a caster's maps; a receive-only object none.
  b.edit(set_transform(d, 2, make_transform({-1.45f, 0.251f, 0.25f}, {0, 10, 0}, {1, 1, 1})), "box moved");
  b.edit(set_transform(d, 3, make_transform({0.1f, 0.011f, 1.4f}, {0, 0, 0}, {1, 1, 1})), "tile moved");
  EXPECT_EQ(invalidation_of(*b.history.last()).maps, Invalidation::Maps::None);
  SurfaceMaterial m = d.scene.objects[1].surface;
  m.opacity = 0.6f;
  m.transmission_color = {1.0f, 0.8f, 0.6f};
  b.edit(set_surface(d, 1, m), "sphere surface");
  m = d.scene.objects[3].surface;
  m.color = {1, 0, 0};
  b.edit(set_surface(d, 3, m), "tile surface");
  b.edit(set_interior(d, 4, InteriorKind::Constant, {0.5f, 0.5f, 0.5f}, -1), "glass sigma");
  b.edit(set_interior(d, 1, InteriorKind::Constant, {2, 2, 2}, -1), "sphere interior");
  b.edit(set_casts_shadows(d, 2, false), "box stops casting");
  b.edit(set_casts_shadows(d, 3, true), "tile starts casting");
  std::vector<TransferPoint> tf = d.scene.volumes[0].transfer;
  tf[1].extinction = {9, 9, 9};
  b.edit(set_transfer(d, 0, tf), "transfer");
  b.undo("transfer");
  b.edit(set_interior(d, 2, InteriorKind::Constant, {1, 1, 1}, -1), "box interior (not casting)");
  EXPECT_EQ(invalidation_of(*b.history.last()).maps, Invalidation::Maps::None);
}

TEST(Invalidation, ClusteredMapsFollowTheirMembersAndTheView) {
  ShadowSettings s = test_scene().shadows;
  s.max_clusters = 4;
  s.d0 = 0.05f;
  Bench b(&s);
  Document& d = b.doc;
  const std::vector<ShadowSystem::MapInfo> maps = b.system.maps();
  ASSERT_GT(std::count_if(maps.begin(), maps.end(), [](const auto& m) { return m.light == 0; }), 1)
      << "the spot light's casters form several clusters";
  // Moving the box (not the caster nearest to a light, inside the bounds)
  // rebuilds the maps of its clusters only.
  b.edit(set_transform(d, 2, make_transform({-1.45f, 0.251f, 0.25f}, {0, 0, 0}, {1, 1, 1})), "box moved");
  EXPECT_LT(b.maps_rebuilt_last, maps.size());
  SurfaceMaterial m = d.scene.objects[4].surface;
  m.opacity = 0.5f;
  b.edit(set_surface(d, 4, m), "glass surface");
  EXPECT_LT(b.maps_rebuilt_last, maps.size());
  // The camera and the clustering settings: maps whose clusters change.
  Camera c = d.scene.camera;
  c.position = {-3.0f, 2.0f, 4.0f};
  b.edit(set_camera(d, c), "camera");
  EXPECT_EQ(invalidation_of(*b.history.last()).maps, Invalidation::Maps::Views);
  ShadowSettings t = d.scene.shadows;
  t.d0 = 0.5f;
  b.edit(set_settings(d, t), "d0");
  t.max_clusters = 2;
  b.edit(set_settings(d, t), "clusters");
  t.epsilon = 0.03f;
  b.edit(set_settings(d, t), "epsilon");
  EXPECT_EQ(invalidation_of(*b.history.last()).maps, Invalidation::Maps::All);
}

TEST(SystemBinding, EditsAndUndosRenderLikeAFreshSystem) {
  Bench b;
  Document& d = b.doc;
  double t = 0.0;
  auto apply = [&](const Edit& e) { ASSERT_TRUE(b.history.apply(d, e, t += 1.0)) << b.history.last_refusal(); };
  auto replay = [&] {
    for (const Edit& e : b.history.take_pending()) b.binding->apply(e, d.scene);
  };
  ShadowSettings s = d.scene.shadows;
  s.epsilon = 0.05f;
  apply(set_settings(d, s));
  Light extra;
  extra.position = {-2.0f, 3.0f, 1.0f};
  extra.direction = normalize(Vec3{2, -3, -1});
  apply(add_light(d, extra));
  apply(remove_light(d, 0));
  apply(set_transform(d, 1, make_transform({1.3f, 0.31f, 0.2f}, {0, 0, 0}, {1, 1, 1})));
  replay();
  b.system.render();  // the intermediate state is built and drawn
  SurfaceMaterial m = d.scene.objects[2].surface;
  m.color = {0.2f, 0.3f, 0.9f};
  m.opacity = 0.5f;
  apply(set_surface(d, 2, m));
  apply(set_interior(d, 4, InteriorKind::Constant, {3, 1, 0.5f}, -1));
  apply(set_casts_shadows(d, 3, true));
  std::vector<TransferPoint> tf = d.scene.volumes[0].transfer;
  tf[1].extinction = {2, 5, 9};
  apply(set_transfer(d, 0, tf));
  Camera c = d.scene.camera;
  c.position.x -= 1.0f;
  apply(set_camera(d, c));
  replay();
  b.system.render();
  ASSERT_TRUE(b.history.undo(d));  // camera
  ASSERT_TRUE(b.history.undo(d));  // transfer
  ASSERT_TRUE(b.history.undo(d));  // casts shadows
  replay();
  b.system.render();
  ASSERT_TRUE(b.history.undo(d));  // interior
  ASSERT_TRUE(b.history.undo(d));  // surface
  ASSERT_TRUE(b.history.undo(d));  // transform
  ASSERT_TRUE(b.history.undo(d));  // remove light 0: back in its place
  ASSERT_TRUE(b.history.redo(d));  // ... and removed again
  ASSERT_TRUE(b.history.undo(d));
  ASSERT_TRUE(b.history.redo(d));  // transform
  replay();
  std::string why;
  EXPECT_TRUE(equal_scenes(b.system.scene(), d.scene, &why)) << "the system's scene: " << why;
  const Image edited = b.system.render();

  ShadowSystem fresh(Bench::options());
  SystemBinding bind(fresh, d.scene);
  const Image clean = fresh.render();
  ASSERT_EQ(edited.rgb.size(), clean.rgb.size());
  size_t differ = 0;
  for (size_t i = 0; i < clean.rgb.size(); ++i)
    differ += std::memcmp(&edited.rgb[i], &clean.rgb[i], sizeof(float)) != 0;
  EXPECT_EQ(differ, 0u) << "of " << clean.rgb.size() << " channel values";
  // And the scene is not trivially dark: shadows of several kinds show.
  float lo = 1e9f, hi = -1e9f;
  for (float v : clean.rgb) lo = std::min(lo, v), hi = std::max(hi, v);
  EXPECT_GT(hi - lo, 0.1f);
}

// Dragging a transfer-function point on the histogram plot (the editor's
// Objects panel): density between its neighbours, extinction not below 0
// and scaled in every channel alike; the result is a valid set_transfer.
TEST(TransferDrag, StaysSortedAndNonNegative) {
  const std::vector<TransferPoint> tf = {
      {0.0f, {0, 0, 0}, {1, 1, 1}}, {0.2f, {2, 1, 0.5f}, {1, 1, 1}}, {0.8f, {8, 8, 8}, {1, 1, 1}}};
  std::vector<TransferPoint> d = drag_transfer_point(tf, 1, 0.1f, 2.0f);  // right and up
  EXPECT_FLOAT_EQ(d[1].density, 0.3f);
  EXPECT_FLOAT_EQ(d[1].extinction.x, 4.0f);  // largest channel 2 -> 4, others alike
  EXPECT_FLOAT_EQ(d[1].extinction.y, 2.0f);
  EXPECT_FLOAT_EQ(d[1].extinction.z, 1.0f);
  d = drag_transfer_point(tf, 1, 5.0f, -100.0f);  // past its right neighbour, below zero
  EXPECT_FLOAT_EQ(d[1].density, 0.8f);
  EXPECT_FLOAT_EQ(d[1].extinction.x, 0.0f);
  d = drag_transfer_point(tf, 1, -5.0f, 0.0f);  // past its left neighbour
  EXPECT_FLOAT_EQ(d[1].density, 0.0f);
  d = drag_transfer_point(tf, 0, 0.0f, 3.0f);  // a black point becomes grey
  EXPECT_FLOAT_EQ(d[0].extinction.x, 3.0f);
  EXPECT_FLOAT_EQ(d[0].extinction.z, 3.0f);
  d = drag_transfer_point(tf, 2, 1.0f, 0.0f);  // the last point has no right neighbour
  EXPECT_FLOAT_EQ(d[2].density, 1.8f);
  EXPECT_EQ(drag_transfer_point(tf, 7, 1.0f, 1.0f)[2].density, tf[2].density);  // no such point: unchanged
  const float nan = std::nanf("");
  EXPECT_EQ(drag_transfer_point(tf, 1, nan, 0.0f)[1].density, tf[1].density);  // NaN deltas: unchanged
  Document doc = test_document();
  std::vector<TransferPoint> t = doc.scene.volumes[0].transfer;
  for (size_t i = 0; i < t.size(); ++i) t = drag_transfer_point(t, i, 10.0f * (i % 2 ? -1.0f : 1.0f), -1.0f);
  EXPECT_TRUE(set_transfer(doc, 0, t).refused.empty()) << "still sorted";
}

}  // namespace
}  // namespace cdsm_test
