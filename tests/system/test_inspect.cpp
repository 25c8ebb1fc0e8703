// What the editor reads of a shadow system: the maps' frusta, members and
// memory, per-texel node counts and opacity, one texel's stored visibility
// function against the uncompressed one (within epsilon: the wedge's
// guarantee, seen from outside), the two-phase update run off the owning
// thread with its progress, and a cancellable reference render.
#include <gtest/gtest.h>

#include <cmath>
#include <atomic>
#include <thread>

#include "cdsm/error.h"
#include "cdsm/procedural.h"
#include "cdsm/renderer.h"
#include "cdsm/scene_io.h"
#include "cdsm/shadow_system.h"
#include "common/builders.h"
#include "frame_snapshot.h"
#include "scene_sync.h"

using namespace cdsm;

namespace {

Scene shipped(const std::string& name, int res = 128) {
  Scene s = load_scene(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/" + name + ".json");
  s.camera.width = 96;
  s.camera.height = 64;
  s.shadows.resolution = res;
  return s;
}

SystemOptions cpu_options() {
  SystemOptions o;
  o.fragments = FragmentSource::Cpu;
  return o;
}

TEST(Inspect, MapsDescribeTheirFrustaMembersAndNodes) {
  Scene scene = shipped("default");
  scene.shadows.max_clusters = 3;
  scene.shadows.d0 = 0.05f;
  ShadowSystem sys(cpu_options());
  sync_scene(sys, scene);
  FrameStats st;
  sys.update(&st);
  const std::vector<ShadowSystem::MapInfo> maps = sys.maps();
  ASSERT_EQ(maps.size(), st.memory.maps);
  ASSERT_GE(maps.size(), 2u);
  uint64_t nodes = 0, members = 0;
  for (size_t k = 0; k < maps.size(); ++k) {
    const ShadowSystem::MapInfo& m = maps[k];
    EXPECT_EQ(m.light, 0);
    EXPECT_EQ(m.slot, int(k));
    EXPECT_TRUE(m.rebuilt);
    const std::vector<uint32_t> counts = sys.map_node_counts(int(k));
    ASSERT_EQ(counts.size(), size_t(m.res) * m.res);
    uint64_t sum = 0;
    uint32_t mx = 0;
    for (uint32_t c : counts) sum += c, mx = std::max(mx, c);
    EXPECT_EQ(sum, m.nodes);
    EXPECT_EQ(mx, m.max_nodes);
    nodes += sum;
    members += m.members.size();
    // The frustum's apex is the light: near corners close to it, far ones beyond.
    for (int c = 0; c < 4; ++c) {
      EXPECT_LT(length(m.corners[c] - scene.lights[0].position), length(m.corners[c + 4] - scene.lights[0].position));
    }
    // Opacity at the far end of the map: every texel's last value.
    const std::vector<float> far_alpha = sys.map_alpha(int(k), 1e30f);
    float most = 0.0f;
    for (float a : far_alpha) most = std::max(most, a);
    EXPECT_GT(most, 0.5f) << "map " << k << " holds casters";
  }
  EXPECT_EQ(nodes, st.memory.nodes);
  size_t casters = 0;
  for (const Object& o : scene.objects) casters += o.casts_shadows;
  EXPECT_EQ(members, casters) << "each caster in exactly one cluster";
  EXPECT_THROW(sys.map_node_counts(int(maps.size())), Error);
  // Nothing changed: nothing rebuilt.
  sys.update(&st);
  for (const auto& m : sys.maps()) EXPECT_FALSE(m.rebuilt);
}

// A ground point in the smoke's shadow: the stored nodes stay within
// epsilon of the same light ray walked with epsilon 0.
TEST(Inspect, TexelWithinEpsilonOfTheUncompressedRay) {
  for (float eps : {0.01f, 0.1f}) {
    Scene scene = shipped("default");
    scene.shadows.epsilon = eps;
    ShadowSystem sys(cpu_options());
    sync_scene(sys, scene);
    sys.update();
    // The smoke stands at (0.05, 0, -0.95); the light at (2.2, 4.6, 2.4): its
    // shadow falls behind it, away from the light.
    const Vec3 smoke{0.05f, 0.6f, -0.95f}, light = scene.lights[0].position;
    const Vec3 d = normalize(smoke - light);
    const Vec3 ground = light + d * (light.y / -d.y);
    const ShadowSystem::TexelInspection t = sys.inspect_texel(0, ground);
    ASSERT_TRUE(t.found) << t.why;
    EXPECT_FALSE(t.nodes.empty());
    EXPECT_GT(t.exact.size(), t.nodes.size()) << "the uncompressed ray has more samples";
    EXPECT_GT(t.exact.back().alpha.x, 0.05f) << "the ray crosses smoke";
    EXPECT_LE(t.max_deviation, eps + 1e-5f);
    EXPECT_GT(t.max_deviation, eps * 0.2f) << "compression used its budget";
    std::printf("[ inspect  ] eps %.2f: %zu nodes vs %zu samples, max deviation %.5f\n", eps, t.nodes.size(),
                t.exact.size(), t.max_deviation);
  }
  Scene scene = shipped("default");
  ShadowSystem sys(cpu_options());
  sync_scene(sys, scene);
  sys.update();
  EXPECT_FALSE(sys.inspect_texel(3, {0, 0, 0}).found);
  EXPECT_FALSE(sys.inspect_texel(0, {0, 100, 0}).found);  // behind the light's cone
}

// The editor's alpha(z) view follows the receiver rule (DESIGN.md §8): a
// casting slab under a glass box resting 1 mm above it — the texel's nodes
// name the objects of their steps, the slab's own step is the one left
// out, and the slab reads the glass's two faces (1 - 0.55^2).
TEST(Inspect, TexelShowsWhatTheSurfaceReceives) {
  Scene scene;
  scene.source = "glass on slab";
  cdsm_test::add_surface(scene, "slab", make_ground(8, 8, 0.3f), {0, 0, 0}, 1.0f);
  cdsm_test::add_surface(scene, "glass", make_box({1, 1, 1}), {0, 0.501f, 0}, 0.45f);
  Light l;
  l.position = {0.2f, 6, 0.1f};
  l.direction = normalize(Vec3{-0.2f, -6, -0.1f});
  scene.lights.push_back(l);
  scene.shadows.resolution = 256;
  ShadowSystem sys(cpu_options());
  sync_scene(sys, scene);
  sys.update();
  const Vec3 p{0.05f, 0.0f, -0.1f};
  const ShadowSystem::TexelInspection t = sys.inspect_texel(0, p, 0, {0, 1, 0});
  ASSERT_TRUE(t.found) << t.why;
  ASSERT_TRUE(t.receiver);
  ASSERT_GE(t.own_node, 0);
  ASSERT_LT(size_t(t.own_node), t.nodes.size());
  EXPECT_EQ(t.nodes[size_t(t.own_node)].object, 0) << "the slab's own step";
  int glass_steps = 0;
  for (const ShadowSystem::AlphaSample& a : t.nodes) glass_steps += a.object == 1;
  EXPECT_EQ(glass_steps, 2) << "the glass's entry and exit";
  EXPECT_NEAR(t.received.x, 1.0f - 0.55f * 0.55f, 1e-4f);
  EXPECT_NEAR(t.receiver_depth, t.nodes[size_t(t.own_node)].z, 1e-3f * t.receiver_depth);
  // A receive-only view of the same point (no object): no own step, the
  // slab's own surface (entered by the light, like the point) lies beside it.
  const ShadowSystem::TexelInspection u = sys.inspect_texel(0, p);
  EXPECT_FALSE(u.receiver);
  EXPECT_EQ(u.own_node, -1);
}

// build() on a worker thread while the owner only reads progress; then
// publish() on the owner: the same maps and image as update().
TEST(Inspect, BuildOffTheOwningThread) {
  Scene scene = shipped("teapot_omni");
  ShadowSystem a(cpu_options()), b(cpu_options());
  sync_scene(a, scene);
  sync_scene(b, scene);
  FrameStats sa, sb;
  std::atomic<bool> done{false};
  std::thread worker([&] {
    a.build(&sa);
    done = true;
  });
  uint32_t most_built = 0;
  while (!done) {  // the owner reads only the progress meanwhile
    const ShadowSystem::BuildProgress p = a.build_progress();
    EXPECT_LE(p.built, p.to_build == 0 ? 0u : p.to_build);
    most_built = std::max(most_built, p.built);
    std::this_thread::yield();
  }
  worker.join();
  a.publish(&sa);
  b.update(&sb);
  EXPECT_EQ(sa.maps_rebuilt, sb.maps_rebuilt);
  EXPECT_EQ(a.build_progress().built, sa.maps_rebuilt);
  EXPECT_EQ(a.build_progress().to_build, sa.maps_rebuilt);
  const Image ia = a.render(), ib = b.render();
  EXPECT_EQ(ia.rgb, ib.rgb);
}

TEST(Inspect, ReferenceRenderReportsProgressAndCancels) {
  Scene scene = shipped("primitives");
  scene.camera.width = 48;
  scene.camera.height = 32;
  Renderer r;
  RenderOptions opt;
  opt.fragments = FragmentSource::Cpu;
  opt.compare_reference = true;
  RenderProgress progress;
  opt.progress = &progress;
  FrameStats st;
  r.render(scene, opt, &st);
  EXPECT_EQ(progress.fraction.load(), 1.0f);
  EXPECT_TRUE(st.has_reference);
  RenderProgress cancelled;
  cancelled.cancel = true;
  opt.progress = &cancelled;
  try {
    r.render(scene, opt, &st);
    ADD_FAILURE() << "a cancelled reference render must throw";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cancelled"), std::string::npos) << e.what();
  }
  EXPECT_LT(cancelled.fraction.load(), 0.5f);
}

}  // namespace
