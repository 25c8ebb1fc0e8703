// The persistent shadow system (cdsm/shadow_system.h): every kind of edit
// costs what it touches — asserted through the update counters — and an
// edited system renders exactly what a fresh one renders for the same
// final state.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <set>

#include "cdsm/error.h"
#include "cdsm/procedural.h"
#include "cdsm/renderer.h"
#include "cdsm/scene_io.h"
#include "cdsm/shadow_system.h"
#include "backend/exec_backend.h"
#include "exec/host_exec.h"
#include "frame_snapshot.h"
#include "scene_sync.h"

using namespace cdsm;

namespace {

Scene shipped(const std::string& name, int width = 160, int height = 120, int res = 128) {
  Scene s = load_scene(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/" + name + ".json");
  s.camera.width = width;
  s.camera.height = height;
  s.shadows.resolution = res;
  return s;
}

// Every object, volume and light of `scene` added to `sys`.
void add_scene(ShadowSystem& sys, const Scene& scene) {
  std::vector<VolumeHandle> vols;
  for (const Volume& v : scene.volumes) vols.push_back(sys.add_volume(v));
  for (const Object& o : scene.objects)
    sys.add_object(o, o.interior == InteriorKind::Volume ? vols[size_t(o.volume)] : VolumeHandle{});
  for (const Light& l : scene.lights) sys.add_light(l);
  sys.set_camera(scene.camera);
  sys.set_settings(scene.shadows);
  sys.set_background(scene.background);
}

size_t index_of(const Scene& s, const std::string& name) {
  for (size_t i = 0; i < s.objects.size(); ++i)
    if (s.objects[i].name == name) return i;
  ADD_FAILURE() << "no object " << name;
  return 0;
}

// The maps of light `li` whose members include object `oi` (by index).
std::set<uint32_t> maps_with(ShadowSystem& sys, uint32_t li, uint32_t oi) {
  const ShadowFrame& f = FrameSnapshot(sys).frame();
  std::set<uint32_t> out;
  const LightData& ld = f.setup.lights[li];
  for (uint32_t k = 0; k < ld.map_count; ++k) {
    const MapPlan& p = f.setup.maps[ld.first_map + k];
    for (uint32_t m : p.members)
      if (m == oi) out.insert(k);
  }
  return out;
}

// A system on the CPU threads with CPU fragments (what the executor
// counters and the failure injection need), `keep` its fragment lists.
SystemOptions cpu_options(bool keep_lists) {
  SystemOptions o;
  o.fragments = FragmentSource::Cpu;
  o.backend = Backend::Cpu;
  o.keep_fragment_lists = keep_lists;
  return o;
}

// The default scene small (96 x 64, 64^2 maps) in four clusters: the
// frame-structure tests' rebuilds.
Scene four_clusters() {
  Scene scene = shipped("default", 96, 64, 64);
  scene.shadows.max_clusters = 4;
  scene.shadows.d0 = 0.02f;
  return scene;
}

bool same_pixels(const Image& a, const Image& b) {
  return a.width == b.width && a.height == b.height && a.rgb.size() == b.rgb.size() &&
         std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)) == 0;
}

TEST(ShadowSystem, NothingChangedCompilesUploadsAndRebuildsNothing) {
  ShadowSystem sys;
  add_scene(sys, shipped("default"));
  FrameStats st;
  sys.render(&st);
  EXPECT_EQ(st.update.full_compiles, 1u);
  EXPECT_EQ(st.update.volumes_compiled, 2u);  // smoke and steam
  EXPECT_GT(st.maps_rebuilt, 0u);
  EXPECT_EQ(st.update.rebuilt_by_reason[int(RebuildReason::New)], st.maps_rebuilt);
  if (st.fragment_source == "gl") {
    EXPECT_GT(st.update.gl_upload_bytes, 0u);
  }
  const uint32_t maps = st.maps_rebuilt;
  sys.render(&st);
  EXPECT_EQ(st.update.full_compiles, 0u);
  EXPECT_EQ(st.update.objects_compiled, 0u);
  EXPECT_EQ(st.update.volumes_compiled, 0u);
  EXPECT_EQ(st.update.gl_upload_bytes, 0u);
  EXPECT_EQ(st.maps_rebuilt, 0u);
  EXPECT_EQ(st.maps_reused, maps);
  EXPECT_EQ(st.update.maps_freed, 0u);
}

TEST(ShadowSystem, CameraMoveRebuildsNoMapAndCompilesNothing) {
  ShadowSystem sys;
  Scene s = shipped("default");
  add_scene(sys, s);
  FrameStats st;
  Image first = sys.render(&st);
  for (int step = 1; step <= 3; ++step) {
    Camera c = s.camera;
    const float a = 0.0174533f * float(step);  // 1 degree per frame around the target
    Vec3 d = c.position - c.target;
    c.position = c.target + Vec3{d.x * std::cos(a) - d.z * std::sin(a), d.y, d.x * std::sin(a) + d.z * std::cos(a)};
    sys.set_camera(c);
    Image img = sys.render(&st);
    EXPECT_EQ(st.update.full_compiles + st.update.objects_compiled + st.update.volumes_compiled, 0u);
    EXPECT_EQ(st.update.gl_upload_bytes, 0u);
    EXPECT_EQ(st.maps_rebuilt, 0u) << "an unclustered spot's map does not depend on the camera";
    EXPECT_FALSE(same_pixels(img, first)) << "the view moved";
  }
}

TEST(ShadowSystem, MovedObjectRebuildsOnlyItsMapsAndUploadsOnlyItsTriangles) {
  ShadowSystem sys;
  Scene s = shipped("sparse");
  ASSERT_EQ(s.shadows.max_clusters, 4);
  add_scene(sys, s);
  FrameStats st;
  sys.render(&st);
  const uint32_t maps = st.maps_rebuilt;
  ASSERT_GE(maps, 2u) << "sparse.json clusters into several maps";
  const size_t oi = index_of(s, "teapot3");
  const std::set<uint32_t> before = maps_with(sys, 0, uint32_t(oi));
  Mat4 t = s.objects[oi].transform;
  t.m[0][3] += 0.05f;  // a small nudge: the object stays in its cluster
  const ObjectHandle h = sys.objects()[oi];
  sys.set_transform(h, t);
  sys.render(&st);
  EXPECT_EQ(st.update.full_compiles, 0u);
  EXPECT_EQ(st.update.objects_compiled, 1u);
  EXPECT_EQ(st.update.bvh_refits + st.update.bvh_rebuilds, 1u);
  const std::set<uint32_t> after = maps_with(sys, 0, uint32_t(oi));
  std::set<uint32_t> affected = before;
  affected.insert(after.begin(), after.end());
  EXPECT_GE(st.maps_rebuilt, 1u);
  EXPECT_LE(st.maps_rebuilt, affected.size()) << "only the maps it was in or is in now";
  for (const MapRebuild& r : st.update.rebuilds) {
    EXPECT_TRUE(affected.count(r.map)) << "map " << r.map << " rebuilt without the moved object";
    EXPECT_NE(r.reason, RebuildReason::Settings);
    EXPECT_NE(r.reason, RebuildReason::Light);
  }
  EXPECT_EQ(st.maps_rebuilt + st.maps_reused, uint32_t(FrameSnapshot(sys).frame().maps.size()));
  if (st.fragment_source == "gl") {
    const uint64_t tris = s.objects[oi].mesh->triangle_count();
    EXPECT_EQ(st.update.gl_upload_bytes, tris * 48) << "its triangles' vertices and facing normals only";
  }
}

TEST(ShadowSystem, ContentMoveRebuildsTheMapThoughItsFrustumStays) {
  // One unclustered spot: moving the ball inside the scene box keeps the
  // map's frustum, so only the ball's content generation tells the map is stale.
  ShadowSystem sys;
  Scene s = shipped("default");
  add_scene(sys, s);
  sys.render();
  const size_t ball = index_of(s, "ball");
  s.objects[ball].transform.m[0][3] += 0.05f;
  sys.set_transform(sys.objects()[ball], s.objects[ball].transform);
  FrameStats st;
  Image moved = sys.render(&st);
  ASSERT_EQ(st.maps_rebuilt, 1u);
  EXPECT_EQ(st.update.rebuilds[0].reason, RebuildReason::Content);
  EXPECT_EQ(st.update.objects_compiled, 1u);
  ShadowSystem fresh;
  add_scene(fresh, s);
  EXPECT_TRUE(same_pixels(moved, fresh.render()));
}

TEST(ShadowSystem, MaterialEditRebuildsOnlyMapsContainingTheObjectAndTouchesNoGeometry) {
  ShadowSystem sys;
  Scene s = shipped("sparse");
  add_scene(sys, s);
  FrameStats st;
  sys.render(&st);
  const size_t oi = index_of(s, "glass5");
  const std::set<uint32_t> with = maps_with(sys, 0, uint32_t(oi));
  ASSERT_FALSE(with.empty());
  SurfaceMaterial m = s.objects[oi].surface;
  m.opacity = 0.9f;
  sys.set_surface(sys.objects()[oi], m);
  sys.render(&st);
  EXPECT_EQ(st.update.full_compiles + st.update.objects_compiled + st.update.volumes_compiled, 0u);
  EXPECT_EQ(st.update.bvh_refits + st.update.bvh_rebuilds, 0u);
  EXPECT_EQ(st.update.gl_upload_bytes, 0u);
  EXPECT_EQ(st.maps_rebuilt, with.size());
  EXPECT_EQ(st.update.rebuilt_by_reason[int(RebuildReason::Content)], st.maps_rebuilt);
  for (const MapRebuild& r : st.update.rebuilds) EXPECT_TRUE(with.count(r.map));
}

TEST(ShadowSystem, EpsilonChangeRebuildsEveryMapButCompilesNoGeometry) {
  ShadowSystem sys;
  Scene s = shipped("default");
  add_scene(sys, s);
  FrameStats st;
  sys.render(&st);
  const uint32_t maps = st.maps_rebuilt;
  s.shadows.epsilon = 0.05f;
  sys.set_settings(s.shadows);
  sys.render(&st);
  EXPECT_EQ(st.update.full_compiles + st.update.objects_compiled + st.update.volumes_compiled, 0u);
  EXPECT_EQ(st.update.gl_upload_bytes, 0u);
  EXPECT_EQ(st.maps_rebuilt, maps);
  EXPECT_EQ(st.update.rebuilt_by_reason[int(RebuildReason::Settings)], maps);
  EXPECT_EQ(st.update.maps_freed, maps);
  // A lookup setting (filtering) rebuilds nothing.
  s.shadows.filtering = false;
  sys.set_settings(s.shadows);
  sys.render(&st);
  EXPECT_EQ(st.maps_rebuilt, 0u);
}

// SystemOptions::keep_fragment_lists: an epsilon edit rebuilds every map
// from the kept light-view lists, a content edit drops them; both render
// what a fresh system renders.
TEST(ShadowSystem, KeptFragmentListsServeEpsilonEditsAndNeverOutliveAContentEdit) {
  Scene s = shipped("default");
  s.shadows.max_clusters = 4;
  SystemOptions o;
  o.keep_fragment_lists = true;
  ShadowSystem sys(o);
  add_scene(sys, s);
  FrameStats st;
  sys.render(&st);
  const uint32_t maps = st.maps_rebuilt;
  ASSERT_GE(maps, 2u);
  EXPECT_EQ(st.update.fragment_lists_reused, 0u);
  EXPECT_GT(st.update.fragment_cache_bytes, 0u);
  // The backend holds a kept copy per map and the camera's lists, nothing else.
  const ShadowBackend& backend = FrameSnapshot(sys).backend();
  EXPECT_EQ(backend.map_store().lists, maps + 1);
  EXPECT_EQ(backend.map_store().list_bytes - st.update.fragment_cache_bytes,
            (uint64_t(s.camera.width) * uint64_t(s.camera.height) + 1) * sizeof(uint32_t) +
                st.camera_fragments * sizeof(Fragment));
  auto fresh = [](const Scene& scene) {
    ShadowSystem f;
    add_scene(f, scene);
    FrameStats fs;
    Image img = f.render(&fs);
    EXPECT_EQ(fs.update.fragment_cache_bytes, 0u) << "kept only when asked";
    return img;
  };

  s.shadows.epsilon = 0.05f;
  sys.set_settings(s.shadows);
  Image a = sys.render(&st);
  EXPECT_EQ(st.maps_rebuilt, maps);
  EXPECT_EQ(st.update.fragment_lists_reused, maps);
  EXPECT_TRUE(same_pixels(a, fresh(s))) << "maps from kept lists";

  // A settings edit that rebuilds nothing keeps them too.
  s.shadows.filtering = false;
  sys.set_settings(s.shadows);
  sys.render(&st);
  EXPECT_EQ(st.maps_rebuilt, 0u);
  EXPECT_GT(st.update.fragment_cache_bytes, 0u);
  s.shadows.epsilon = 0.02f;
  sys.set_settings(s.shadows);
  sys.render(&st);
  EXPECT_EQ(st.update.fragment_lists_reused, maps);

  // A content edit (an object moved) drops them: every list is rasterized again.
  const size_t ball = index_of(s, "ball");
  s.objects[ball].transform.m[0][3] += 0.05f;
  sys.set_transform(sys.objects()[ball], s.objects[ball].transform);
  s.shadows.epsilon = 0.01f;
  sys.set_settings(s.shadows);
  a = sys.render(&st);
  EXPECT_EQ(st.update.fragment_lists_reused, 0u);
  EXPECT_TRUE(same_pixels(a, fresh(s))) << "after a move";
  EXPECT_EQ(backend.map_store().lists, maps + 1) << "the dropped lists were freed";
}

// A frame whose build fails anywhere (here: a failure injected into the
// executor at each allocation and launch in turn) leaves no map and no
// fragment list behind in the backend, and the next frame renders what a
// fresh system renders.
TEST(ShadowSystem, AFailedBuildLeavesNothingBehind) {
  Scene s = shipped("default", 48, 36, 48);
  s.shadows.max_clusters = 4;
  const SystemOptions o = cpu_options(true);
  ShadowSystem sys(o);
  add_scene(sys, s);
  sys.render();
  auto* host = dynamic_cast<exec::ExecBackend<exec::HostExec>*>(&SystemHooks::backend(sys));
  ASSERT_NE(host, nullptr);
  const float eps[2] = {0.02f, 0.04f};
  Image want[2];
  for (int i = 0; i < 2; ++i) {
    Scene f = s;
    f.shadows.epsilon = eps[i];
    ShadowSystem fresh(o);
    add_scene(fresh, f);
    want[i] = fresh.render();
  }
  int failures = 0;
  for (int64_t k = 0; k < 1000; ++k) {
    SCOPED_TRACE("failure injected at call " + std::to_string(k));
    s.shadows.epsilon = eps[k % 2];
    sys.set_settings(s.shadows);
    host->executor().fail_after = k;
    bool failed = false;
    try {
      sys.update();
    } catch (const std::exception& e) {
      failed = true;
      EXPECT_NE(std::string(e.what()).find("injected failure"), std::string::npos) << e.what();
    }
    host->executor().fail_after = -1;
    if (failed) {
      ++failures;
      const MapStoreStats m = host->map_store();
      EXPECT_EQ(m.maps, 0u) << "maps left in the store";
      EXPECT_EQ(m.lists, 1u) << "only the last render's camera lists";
    }
    EXPECT_TRUE(same_pixels(sys.render(), want[k % 2]));
    if (!failed) break;  // past the frame's last call
  }
  // At least the three launches of each of the four builds (the warm
  // frames allocate nothing: lists and store keep their capacity).
  EXPECT_GE(failures, 12) << "every step of four builds was reached";
}

// A moved object after warm-up (issue 45 item 4): its map is freed (the
// store compacts: the maps move inside the arrays) and built again without
// an allocation; the frame waits for the executor once, for the light
// pass's counters (CPU threads cast each ray once, on the host; the GPU's
// cast reads its scan's total: one more there).
TEST(ShadowSystem, AMovedObjectAfterWarmUpAllocatesNothing) {
  const Scene scene = four_clusters();
  ShadowSystem sys(cpu_options(false));
  add_scene(sys, scene);
  FrameStats st;
  sys.update(&st);
  ASSERT_EQ(st.maps_rebuilt, 4u);
  size_t caster = 0;
  while (!scene.objects[caster].casts_shadows) ++caster;
  for (int f = 0; f < 6; ++f) {
    Mat4 t = scene.objects[caster].transform;
    t.m[0][3] += 0.01f * float(f % 2 ? -1 : 1);
    sys.set_transform(sys.objects()[caster], t);
    sys.update(&st);
    ASSERT_EQ(st.maps_rebuilt, 1u) << "frame " << f;
    if (f < 2) continue;  // the first moves may still grow the store
    EXPECT_EQ(st.counters.backend_allocations, 0u) << "frame " << f;
    EXPECT_EQ(st.counters.host_syncs, 1u) << "frame " << f;
  }
  EXPECT_GT(SystemHooks::backend(sys).map_store().compactions, 0u) << "the moved object's map left a hole";
}

TEST(ShadowSystem, MovedLightRebuildsOnlyItsMaps) {
  ShadowSystem sys;
  Scene s = shipped("teapot_omni");
  ASSERT_EQ(s.lights.size(), 2u);
  add_scene(sys, s);
  FrameStats st;
  sys.render(&st);
  const uint32_t light1_maps = FrameSnapshot(sys).frame().setup.lights[1].map_count;
  Light l = s.lights[1];
  l.position = l.position + Vec3{0.1f, 0.0f, 0.0f};
  sys.set_light(sys.lights()[1], l);
  sys.render(&st);
  EXPECT_EQ(st.update.full_compiles + st.update.objects_compiled, 0u);
  EXPECT_EQ(st.maps_rebuilt, light1_maps);
  for (const MapRebuild& r : st.update.rebuilds) {
    EXPECT_EQ(r.light, 1u);
    EXPECT_EQ(r.reason, RebuildReason::Light);
  }
  // Colour and intensity change the shading, not the maps.
  l.intensity *= 2.0f;
  sys.set_light(sys.lights()[1], l);
  sys.render(&st);
  EXPECT_EQ(st.maps_rebuilt, 0u);
}

TEST(ShadowSystem, EditedStepByStepRendersBitIdenticallyToAFreshBuild) {
  Scene s = shipped("default");
  ShadowSystem edited;
  // Start from a different state: one object missing, another moved, a
  // material and a light changed, epsilon different; then edit towards `s`.
  Scene start = s;
  const size_t ball = index_of(s, "ball"), pane = index_of(s, "amber pane");
  start.objects.erase(start.objects.begin() + ptrdiff_t(ball));
  add_scene(edited, start);
  edited.set_settings([&] {
    ShadowSettings x = s.shadows;
    x.epsilon = 0.1f;
    return x;
  }());
  edited.render();
  // The ball back, at the end (where it is in `s` after the same reorder).
  Scene want = start;
  want.objects.push_back(s.objects[ball]);
  const ObjectHandle ball_h = edited.add_object(s.objects[ball]);
  edited.render();
  const ObjectHandle pane_h = edited.objects()[index_of(want, "amber pane")];
  Mat4 shifted = s.objects[pane].transform;
  shifted.m[1][3] += 0.3f;
  edited.set_transform(pane_h, shifted);
  edited.render();
  SurfaceMaterial red = s.objects[pane].surface;
  red.color = {1, 0, 0};
  edited.set_surface(pane_h, red);
  edited.render();
  edited.set_transform(pane_h, s.objects[pane].transform);
  edited.set_surface(pane_h, s.objects[pane].surface);
  edited.set_transform(ball_h, s.objects[ball].transform);
  edited.set_settings(s.shadows);
  FrameStats st;
  Image a = edited.render(&st);
  EXPECT_GT(st.maps_rebuilt, 0u);

  ShadowSystem fresh;
  add_scene(fresh, want);
  Image b = fresh.render();
  EXPECT_TRUE(same_pixels(a, b)) << "an edited system renders what a fresh one does";
}

TEST(ShadowSystem, RendererDiffsSceneValuesByIdentity) {
  Renderer r;
  Scene s = shipped("default");
  RenderOptions opt;
  FrameStats st;
  Image a = r.render(s, opt, &st);
  EXPECT_EQ(st.update.full_compiles, 1u);
  Image b = r.render(s, opt, &st);
  EXPECT_EQ(st.update.full_compiles + st.update.objects_compiled + st.update.volumes_compiled, 0u);
  EXPECT_EQ(st.maps_rebuilt, 0u);
  EXPECT_TRUE(same_pixels(a, b));
  // A copy of the scene value shares meshes and grids: still nothing to do.
  Scene copy = s;
  r.render(copy, opt, &st);
  EXPECT_EQ(st.update.volumes_compiled, 0u);
  EXPECT_EQ(st.maps_rebuilt, 0u);
  // One moved object: compiled alone.
  copy.objects[index_of(copy, "ball")].transform.m[0][3] += 0.1f;
  r.render(copy, opt, &st);
  EXPECT_EQ(st.update.full_compiles, 0u);
  EXPECT_EQ(st.update.objects_compiled, 1u);
  EXPECT_GE(st.maps_rebuilt, 1u);
  // The same scene, rendered by a fresh renderer: identical pixels.
  Renderer fresh;
  EXPECT_TRUE(same_pixels(r.render(copy, opt), fresh.render(copy, opt)));
}

TEST(ShadowSystem, VolumeEditCompilesThatVolumeOnlyAndMatchesAFreshBuild) {
  Scene s = shipped("default");
  ShadowSystem sys;
  add_scene(sys, s);
  FrameStats st;
  sys.render(&st);
  // The first volume (smoke) gets a denser transfer function: its voxels
  // are compiled again, the other volume's data moves down behind it.
  const size_t smoke = index_of(s, "smoke");
  const int32_t vi = s.objects[smoke].volume;
  ASSERT_EQ(vi, 0) << "the edited volume lies before the other one";
  for (TransferPoint& p : s.volumes[size_t(vi)].transfer) p.extinction *= 3.0f;
  sys.set_volume(sys.volumes()[size_t(vi)], s.volumes[size_t(vi)]);
  Image a = sys.render(&st);
  EXPECT_EQ(st.update.volumes_compiled, 1u);
  EXPECT_EQ(st.update.full_compiles + st.update.objects_compiled, 0u);
  EXPECT_EQ(st.update.gl_upload_bytes, 0u);
  EXPECT_EQ(st.maps_rebuilt, 1u);
  EXPECT_EQ(st.update.rebuilt_by_reason[int(RebuildReason::Content)], 1u);
  ShadowSystem fresh;
  add_scene(fresh, s);
  EXPECT_TRUE(same_pixels(a, fresh.render())) << "both volumes read their own data after the edit";
}

TEST(ShadowSystem, RemovedVolumeFreesItsVoxelsAndKeepsTheOthersRight) {
  Scene s = shipped("default");
  ShadowSystem sys;
  add_scene(sys, s);
  FrameStats st;
  sys.render(&st);
  const uint64_t with = st.update.scene_bytes;
  const size_t smoke = index_of(s, "smoke");
  const VolumeHandle vol = sys.volumes()[size_t(s.objects[smoke].volume)];
  ASSERT_TRUE(vol);
  sys.remove_object(sys.objects()[smoke]);
  sys.remove_volume(vol);
  Image a = sys.render(&st);
  EXPECT_LT(st.update.scene_bytes, with) << "the removed volume's voxels are freed";
  Scene without = s;
  without.objects.erase(without.objects.begin() + ptrdiff_t(smoke));
  without.volumes.erase(without.volumes.begin() + s.objects[smoke].volume);
  for (Object& o : without.objects)
    if (o.interior == InteriorKind::Volume && o.volume > s.objects[smoke].volume) --o.volume;
  ShadowSystem fresh;
  add_scene(fresh, without);
  EXPECT_TRUE(same_pixels(a, fresh.render())) << "the remaining volume reads its own voxels";
}

TEST(ShadowSystem, AddingAndRemovingAThousandTimesLeavesMemoryWhereItStarted) {
  // A small scene, so a thousand cycles (two updates each) stay quick.
  Scene base;
  base.source = "add_remove";
  base.camera.width = 64;
  base.camera.height = 48;
  base.shadows.resolution = 32;
  Object ground;
  ground.name = "ground";
  ground.mesh = std::make_shared<TriangleMesh>(make_ground(6, 6));
  base.objects.push_back(ground);
  Object box;
  box.name = "box";
  box.mesh = std::make_shared<TriangleMesh>(make_box({0.5f, 0.5f, 0.5f}));
  box.transform = make_transform({-0.8f, 0.25f, 0}, {0, 0, 0}, {1, 1, 1});
  box.surface.opacity = 0.5f;
  base.objects.push_back(box);
  Light spot;
  spot.position = {0, 4, 0};
  base.lights.push_back(spot);
  Object ball;
  ball.name = "ball";
  ball.mesh = std::make_shared<TriangleMesh>(make_sphere(0.4f, 16, 8));
  ball.transform = make_transform({0.8f, 0.4f, 0}, {0, 0, 0}, {1, 1, 1});
  ball.interior = InteriorKind::Constant;
  ball.sigma = vec3(2.0f);
  ball.surface.opacity = 0.0f;

  ShadowSystem sys;
  add_scene(sys, base);
  FrameStats st;
  sys.update(&st);
  // One cycle first: pools and GL buffers reach their working size.
  ObjectHandle h = sys.add_object(ball);
  sys.update(&st);
  sys.remove_object(h);
  sys.update(&st);
  const UpdateStats start = st.update;
  for (int i = 0; i < 1000; ++i) {
    h = sys.add_object(ball);
    sys.update(&st);
    ASSERT_EQ(st.update.full_compiles, 1u);
    ASSERT_EQ(st.maps_rebuilt, 1u);
    sys.remove_object(h);
    sys.update(&st);
  }
  EXPECT_EQ(st.update.scene_bytes, start.scene_bytes);
  EXPECT_EQ(st.update.map_live_bytes, start.map_live_bytes);
  EXPECT_LE(st.update.map_store_bytes, start.map_store_bytes + start.map_store_bytes / 3)
      << "holes of freed maps stay below a quarter of the store (compaction)";
  EXPECT_EQ(st.update.gl_scene_bytes, start.gl_scene_bytes);
  // The system holds nothing of the removed mesh: with the test's own
  // reference dropped, it is gone.
  const std::weak_ptr<const TriangleMesh> mesh = ball.mesh;
  ball.mesh.reset();
  EXPECT_TRUE(mesh.expired()) << "the removed mesh is released";
}

TEST(ShadowSystem, PoppingIsMeasuredOnlyWhenAskedAndKeepsReplacedMapsOneFrame) {
  Scene s = shipped("sparse");
  Renderer r;
  RenderOptions opt;
  FrameStats st;
  r.render(s, opt, &st);
  s.shadows.epsilon = 0.05f;  // every map replaced
  r.render(s, opt, &st);
  EXPECT_FALSE(st.popping.measured) << "off unless asked";
  opt.measure_popping = true;
  r.render(s, opt, &st);
  const uint64_t live = st.update.map_live_bytes;
  s.shadows.epsilon = 0.2f;
  r.render(s, opt, &st);
  ASSERT_TRUE(st.popping.measured);
  EXPECT_GT(st.popping.points, 0u);
  EXPECT_GT(st.popping.max, 0.0) << "a coarser epsilon changes transmittance somewhere";
  EXPECT_GT(st.update.map_live_bytes, live / 4) << "the replaced maps are alive for the probe";
  const uint32_t maps = st.maps_rebuilt;
  const uint64_t with_kept = st.update.map_live_bytes;
  r.render(s, opt, &st);  // nothing changed: the kept maps are freed now
  EXPECT_EQ(st.maps_rebuilt, 0u);
  EXPECT_EQ(st.update.maps_freed, maps);
  EXPECT_LT(st.update.map_live_bytes, with_kept);
  EXPECT_FALSE(st.popping.measured) << "no map changed";
}

TEST(ShadowSystem, BadEditsAreRefusedByNameAndTheStateSurvives) {
  Scene s = shipped("default");
  ShadowSystem sys;
  add_scene(sys, s);
  const Image before = sys.render();
  const size_t ball = index_of(s, "ball");
  const ObjectHandle h = sys.objects()[ball];
  // A NaN transform is refused at the call, naming the object.
  Mat4 bad = s.objects[ball].transform;
  bad.m[0][3] = std::nanf("");
  try {
    sys.set_transform(h, bad);
    ADD_FAILURE() << "a NaN transform was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'ball'"), std::string::npos) << e.what();
  }
  // Handles of removed or foreign things, a volume still in use.
  EXPECT_THROW(sys.set_surface(ObjectHandle{987654}, s.objects[ball].surface), Error);
  const VolumeHandle smoke_volume = sys.volumes()[size_t(s.objects[index_of(s, "smoke")].volume)];
  EXPECT_THROW(sys.remove_volume(smoke_volume), Error);
  // Content that fails to compile: update() throws naming it, the previous
  // compiled state stays, and removing the object heals the system.
  auto broken = std::make_shared<TriangleMesh>(*s.objects[ball].mesh);
  broken->positions[3].y = std::nanf("");
  Object o = s.objects[ball];
  o.name = "broken";
  o.mesh = broken;
  const ObjectHandle b = sys.add_object(o);
  try {
    sys.render();
    ADD_FAILURE() << "a NaN vertex compiled";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'broken'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("vertex 3"), std::string::npos) << e.what();
  }
  sys.remove_object(b);
  EXPECT_TRUE(same_pixels(sys.render(), before)) << "the system renders its last good state";
  // A NaN transmission colour through the API (no scene-file validation on
  // this path): refused at update, naming the object.
  SurfaceMaterial nan_tint = s.objects[ball].surface;
  nan_tint.transmission_color.y = std::nanf("");
  sys.set_surface(h, nan_tint);
  try {
    sys.update();
    ADD_FAILURE() << "a NaN transmission colour compiled";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("transmission_color"), std::string::npos) << e.what();
  }
}

// An engine's empty level: update() on a system with nothing registered is
// valid and builds nothing; removing everything frees every map.
TEST(ShadowSystem, AnEmptySystemIsAFreeNoOp) {
  ShadowSystem sys;
  FrameStats st;
  EXPECT_NO_THROW(sys.update(&st));
  EXPECT_EQ(st.maps_rebuilt, 0u);
  EXPECT_EQ(st.update.full_compiles, 0u);
  EXPECT_TRUE(FrameSnapshot(sys).frame().maps.empty());
  add_scene(sys, shipped("default", 64, 48, 32));
  sys.update(&st);
  const uint32_t built = st.maps_rebuilt;
  ASSERT_GT(built, 0u);
  for (const LightHandle& l : sys.lights()) sys.remove_light(l);
  for (const ObjectHandle& o : sys.objects()) sys.remove_object(o);
  sys.update(&st);
  EXPECT_EQ(st.maps_rebuilt, 0u);
  EXPECT_EQ(st.update.maps_freed, built);
  EXPECT_TRUE(FrameSnapshot(sys).frame().maps.empty());
  sys.update(&st);
  EXPECT_EQ(st.update.maps_freed, 0u);
}

// Handles are slots with generations (engine/src/slot_map.h): a removed
// thing's handle is refused as removed, also after its slot is reused by a
// new thing; a value never given out is refused as foreign; the things
// after a removed one keep their handles, and gl_light_index /
// gl_object_id follow them to their new places.
TEST(ShadowSystem, HandlesStayValidAcrossRemovalsAndStaleOnesAreNamed) {
  Scene s = shipped("default", 64, 48, 32);
  ShadowSystem sys;
  add_scene(sys, s);
  const Light key = s.lights[0];
  const LightHandle l0 = sys.lights()[0];
  const LightHandle l1 = sys.add_light(key);
  const LightHandle l2 = sys.add_light(key);
  const std::vector<ObjectHandle> objs = sys.objects();
  ASSERT_GE(objs.size(), 3u);
  const size_t n = objs.size();
  sys.update();

  const auto message = [](const std::function<void()>& f) {
    try {
      f();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  sys.remove_light(l0);
  EXPECT_EQ(sys.gl_light_index(l1), 0);
  EXPECT_EQ(sys.gl_light_index(l2), 1);
  Light moved = key;
  moved.position.x += 1.0f;
  sys.set_light(l2, moved);
  EXPECT_EQ(sys.scene().lights[1].position.x, moved.position.x) << "l2's edit reached its new place";
  EXPECT_EQ(sys.scene().lights[0].position.x, key.position.x);
  std::string e = message([&] { sys.set_light(l0, key); });
  EXPECT_NE(e.find("light handle"), std::string::npos) << e;
  EXPECT_NE(e.find("removed from this system"), std::string::npos) << e;

  // The first object removed: the others keep their handles, their ids move.
  const Object first = s.objects[0];
  sys.remove_object(objs[0]);
  for (size_t i = 1; i < n; ++i) {
    EXPECT_EQ(sys.objects()[i - 1], objs[i]);
    if (s.objects[i].casts_shadows) {
      EXPECT_EQ(sys.gl_object_id(objs[i]), uint32_t(i - 1));
    }
  }
  // A new object reuses the freed slot with a new generation: the old
  // handle stays refused and does not reach the new object.
  const ObjectHandle again = sys.add_object(first);
  EXPECT_FALSE(again == objs[0]);
  EXPECT_EQ(again.id & 0xffffffffu, objs[0].id & 0xffffffffu) << "the freed slot is reused";
  e = message([&] { sys.set_casts_shadows(objs[0], false); });
  EXPECT_NE(e.find("object handle " + std::to_string(objs[0].id)), std::string::npos) << e;
  EXPECT_NE(e.find("removed from this system"), std::string::npos) << e;
  EXPECT_TRUE(sys.scene().objects.back().casts_shadows == first.casts_shadows) << "the new object untouched";
  e = message([&] { sys.set_casts_shadows(ObjectHandle{uint64_t(7) << 32 | 999}, false); });
  EXPECT_NE(e.find("does not name an object of this system"), std::string::npos) << e;
  e = message([&] { sys.remove_volume(VolumeHandle{0}); });
  EXPECT_NE(e.find("volume handle 0 does not name"), std::string::npos) << e;

  // The counters of the cost table: removing and re-adding is one full
  // compile of the objects there are; an edit through a kept handle after
  // it compiles only that object.
  FrameStats st;
  sys.update(&st);
  EXPECT_EQ(st.update.full_compiles, 1u);
  EXPECT_EQ(st.update.objects_compiled, uint32_t(n));
  Mat4 t = s.objects[n - 1].transform;
  t.m[0][3] += 0.01f;
  sys.set_transform(objs[n - 1], t);
  sys.update(&st);
  EXPECT_EQ(st.update.full_compiles, 0u);
  EXPECT_EQ(st.update.objects_compiled, 1u);
}

}  // namespace

// Frame data stays where it was made (issue 26 item 3), counted in
// FrameStats::update (host <-> backend bytes; on CPU threads the copies the
// backend still makes): an unchanged frame moves nothing; a camera move
// only the image back; a moved object only its triangles and the BVH nodes
// its move changed; an epsilon edit with kept fragment lists nothing into
// the backend.
TEST(ShadowSystem, HostBackendBytesFollowWhatChanged) {
  Scene scene = shipped("default", 96, 64, 64);
  ShadowSystem sys(cpu_options(true));
  add_scene(sys, scene);
  FrameStats first;
  sys.update(&first);
  const SceneBuffers& sb = FrameSnapshot(sys).compiled();
  uint64_t scene_bytes = (sb.tri_vertices.size() + sb.tri_normals.size()) * sizeof(Vec3) + sb.tri_object.size() * 4 +
                         sb.objects.size() * sizeof(ObjectData) + sb.volumes.size() * sizeof(VolumeData) +
                         (sb.voxels.size() + sb.macro_max.size()) * 4 + sb.nano_pool.size() * sizeof(GridBlock) +
                         sb.bvh.size() * sizeof(BvhNode) + sb.bvh_prims.size() * 4;
  EXPECT_GE(first.update.host_to_backend_bytes, scene_bytes) << "the first frame uploads the scene";

  FrameStats again;
  sys.update(&again);
  EXPECT_EQ(again.update.host_to_backend_bytes, 0u) << "nothing changed";
  EXPECT_EQ(again.update.backend_to_host_bytes, 0u) << "nothing changed";

  // The camera moves: maps stay (one cluster), the image comes back.
  Camera cam = scene.camera;
  cam.position = cam.position + Vec3{0.3f, 0.0f, 0.0f};
  sys.set_camera(cam);
  FrameStats moved_camera;
  Image img = sys.render(&moved_camera);
  EXPECT_EQ(moved_camera.maps_rebuilt, 0u);
  EXPECT_EQ(moved_camera.update.host_to_backend_bytes, 0u) << "the camera's fragment lists are used where they are";
  EXPECT_EQ(moved_camera.update.backend_to_host_bytes, img.rgb.size() * sizeof(float) + 4 * sizeof(uint32_t))
      << "the image and the walk's four counters";

  // One object moves (twice: the first refit after a build also tightens
  // every box the build left): its triangles (vertices and normals) and the
  // BVH nodes whose boxes changed go to the backend, nothing else.
  const size_t oi = index_of(scene, "teapot");
  const ObjectData od = sb.objects[oi];
  Object teapot = scene.objects[oi];
  for (int step = 1; step <= 2; ++step) {
    const std::vector<BvhNode> bvh_before = sb.bvh;
    sys.set_transform(
        sys.objects()[oi],
        make_transform({0.05f * float(step), 0.0f, 0.02f}, {0, 10.0f * float(step), 0}, {1, 1, 1}) * teapot.transform);
    FrameStats moved;
    sys.update(&moved);
    ASSERT_EQ(moved.update.bvh_refits, 1u);
    ASSERT_EQ(sb.bvh.size(), bvh_before.size());
    uint64_t nodes = 0;
    for (size_t i = 0; i < sb.bvh.size(); ++i) nodes += std::memcmp(&sb.bvh[i], &bvh_before[i], sizeof(BvhNode)) != 0;
    ASSERT_GT(nodes, 0u);
    if (step == 2) {
      EXPECT_LT(nodes, sb.bvh.size() / 2) << "a move changes its own branches of the tree";
    }
    const uint64_t tris = uint64_t(od.tri_count) * 3 * sizeof(Vec3) * (sb.tri_normals.empty() ? 1 : 2);
    EXPECT_EQ(moved.update.host_to_backend_bytes, tris + nodes * sizeof(BvhNode))
        << "move " << step << ": " << od.tri_count << " triangles, " << nodes << " BVH nodes of " << sb.bvh.size();
  }

  // Epsilon: every map rebuilt from its kept fragment lists, nothing into the backend.
  ShadowSettings s = scene.shadows;
  s.epsilon = 0.03f;
  sys.set_settings(s);
  FrameStats eps;
  sys.update(&eps);
  EXPECT_GT(eps.maps_rebuilt, 0u);
  EXPECT_EQ(eps.update.fragment_lists_reused, eps.maps_rebuilt);
  EXPECT_EQ(eps.update.host_to_backend_bytes, 0u);
}

// What a frame asks of the machine (issue 45 item 6), counted on CPU threads
// as the CUDA executor counts it: a frame with nothing to rebuild — nothing
// changed, the same camera and settings set again, a camera orbit that moves
// no cluster — waits for, allocates, launches and moves nothing.
TEST(ShadowSystem, SteadyFramesWaitAllocateLaunchAndMoveNothing) {
  Scene scene = shipped("default", 96, 64, 64);
  ShadowSystem sys(cpu_options(false));
  add_scene(sys, scene);
  FrameStats cold;
  sys.update(&cold);
  ASSERT_GT(cold.maps_rebuilt, 0u);
  EXPECT_GT(cold.counters.backend_allocations, 0u) << "the first frame allocates its stores";
  EXPECT_GT(cold.counters.launches, 0u);
  EXPECT_GT(cold.times.total_ms, 0.0) << "update() times itself";
  EXPECT_EQ(cold.backend, "cpu");

  auto expect_free = [](const FrameStats& st, const char* what) {
    EXPECT_EQ(st.maps_rebuilt, 0u) << what;
    EXPECT_EQ(st.update.full_compiles + st.update.objects_compiled + st.update.volumes_compiled, 0u) << what;
    EXPECT_EQ(st.counters.host_syncs, 0u) << what;
    EXPECT_EQ(st.counters.backend_allocations, 0u) << what;
    EXPECT_EQ(st.counters.launches, 0u) << what;
    EXPECT_EQ(st.counters.gl_readbacks, 0u) << what;
    EXPECT_EQ(st.counters.gl_allocations, 0u) << what;
    EXPECT_EQ(st.update.host_to_backend_bytes, 0u) << what;
    EXPECT_EQ(st.update.backend_to_host_bytes, 0u) << what;
    EXPECT_GT(st.times.total_ms, 0.0) << what;
  };
  FrameStats st;
  sys.update(&st);
  expect_free(st, "nothing changed");
  EXPECT_EQ(st.update.frames_planned, 0u);

  sys.set_camera(scene.camera);
  sys.set_settings(scene.shadows);
  sys.update(&st);
  expect_free(st, "the same camera and settings again");
  EXPECT_EQ(st.update.frames_planned, 0u) << "an engine sets its camera every frame: the same one changes nothing";

  for (int step = 1; step <= 3; ++step) {
    Camera c = scene.camera;
    const float a = 0.0174533f * float(step);  // 1 degree per frame around the target
    const Vec3 d = c.position - c.target;
    c.position = c.target + Vec3{d.x * std::cos(a) - d.z * std::sin(a), d.y, d.x * std::sin(a) + d.z * std::cos(a)};
    sys.set_camera(c);
    sys.update(&st);
    expect_free(st, "camera orbit, no cluster moved");
  }
}
// A rebuild after warm-up (issue 45 items 3, 4 and 6): four maps rebuilt
// (an epsilon edit over four clusters) allocate nothing (the store, emptied
// of the maps they replace, keeps its capacity; the light pass's scratch
// only grows), upload nothing (the kept fragment lists are where the
// executor reads them) and read back only the light pass's counters, once.
TEST(ShadowSystem, ARebuildAfterWarmUpAllocatesNothing) {
  const Scene scene = four_clusters();
  ShadowSystem sys(cpu_options(true));
  add_scene(sys, scene);
  FrameStats st;
  sys.update(&st);
  const uint32_t maps = st.maps_rebuilt;
  ASSERT_EQ(maps, 4u) << "four clusters";
  for (int i = 1; i <= 3; ++i) {  // the first rebuild may still grow the scratch
    ShadowSettings s = scene.shadows;
    s.epsilon = scene.shadows.epsilon * (i % 2 ? 0.5f : 1.0f);
    sys.set_settings(s);
    sys.update(&st);
    ASSERT_EQ(st.maps_rebuilt, maps);
    ASSERT_EQ(st.update.fragment_lists_reused, maps);
    if (i == 1) continue;
    EXPECT_EQ(st.counters.backend_allocations, 0u) << "rebuild " << i;
    EXPECT_EQ(st.counters.gl_allocations, 0u) << "rebuild " << i;
    EXPECT_EQ(st.update.host_to_backend_bytes, 0u) << "rebuild " << i;
    EXPECT_GT(st.counters.launches, 0u);
    // Every map walked before a count is read, then one read of all four
    // maps' counters (issue 45 item 3): one synchronization in the frame.
    EXPECT_EQ(st.counters.host_syncs, 1u) << "rebuild " << i;
    EXPECT_EQ(st.update.backend_to_host_bytes, maps * sizeof(exec::BuildCounters))
        << "only the build counters come back";
  }
}
