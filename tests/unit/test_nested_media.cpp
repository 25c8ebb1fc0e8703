// More nested media than the segment walker's set holds (issue 25, hard
// case b; kMaxEnclosing = 16). Constant media beyond the set are summed and
// taken off at their exits: 16, 17 and 20 nested translucent boxes and 20
// nested spheres keep every medium, in the maps within eps + 0.005 of the
// reference. A volume entering a full set takes the place of a constant
// medium; only a volume inside 16 other volumes is left out, and then the
// frame says so (FrameStats::enclosing_overflow and a warning).
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "cdsm/loaders.h"
#include "cdsm/renderer.h"
#include "map_probe.h"

using namespace cdsm;
using namespace cdsm_test;

namespace {

// Half-size of the i-th nested object (0 outermost).
float half_size(int i) { return 1.0f - 0.045f * float(i); }

// A spot from above onto nested objects at the origin, a camera looking at them.
Scene nested_scene(const std::string& name) {
  Scene s = empty_scene(name);
  s.camera.position = {0.3f, 3.0f, 3.5f};
  s.camera.target = {0, 0, 0};
  s.camera.width = 48;
  s.camera.height = 36;
  s.lights.push_back(spot_light({0.05f, 5.0f, 0.03f}, {-0.05f, -5.0f, -0.03f}, 20, 15));
  s.shadows.resolution = 64;
  s.shadows.epsilon = 0.01f;
  return s;
}

// Extinction of the i-th of n nested media: the innermost is dense, so
// leaving it out shows.
float nested_sigma(int i, int n) { return i + 1 == n ? 4.0f : 0.05f; }

// n nested translucent boxes (or spheres) of constant media.
Scene nested_media(int n, bool spheres) {
  Scene s = nested_scene(std::to_string(n) + (spheres ? " nested spheres" : " nested boxes"));
  for (int i = 0; i < n; ++i) {
    const float r = half_size(i);
    Object o = surface_object("shell " + std::to_string(i), spheres ? make_sphere(r, 32, 16) : make_box(vec3(2.0f * r)),
                              Mat4{}, 0.02f);
    o.interior = InteriorKind::Constant;
    o.sigma = vec3(nested_sigma(i, n));
    s.objects.push_back(o);
  }
  return s;
}

// Volume i of n nested ones: a 4^3 grid of density 1 (extinction
// nested_sigma(i, n)) filling a box of half-size half_size(i).
void add_nested_volume(Scene& s, int i, int n) {
  auto g = std::make_shared<DenseGrid>();
  g->nx = g->ny = g->nz = 4;
  g->values.assign(64, 1.0f);
  Volume v;
  v.name = "volume " + std::to_string(i);
  v.grid = g;
  const float voxel = 2.0f * half_size(i) / 4.0f;
  v.index_to_object = make_transform(vec3(-1.5f * voxel), {0, 0, 0}, vec3(voxel));
  v.transfer = {TransferPoint{0.0f, vec3(0.0f), {1, 1, 1}}, TransferPoint{1.0f, vec3(nested_sigma(i, n)), {1, 1, 1}}};
  s.volumes.push_back(v);
  Object o;
  o.name = v.name;
  o.interior = InteriorKind::Volume;
  o.volume = int32_t(s.volumes.size() - 1);
  o.mesh = share(make_volume_proxy(s.volumes.back()));
  o.surface.opacity = 0.0f;
  s.objects.push_back(o);
}

MapError expect_map_right(const std::string& what, const Scene& scene) {
  const MapError m = map_error_along_rays(scene, 4.0f, 0.02f);  // rays through the innermost object
  std::printf(
      "[ nested ] %-40s %zu points: map error p99 %.4f max %.4f (at %.3f of the chord: map T %.4f, "
      "reference %.4f)\n",
      what.c_str(), m.points, m.p99, m.max, m.worst_depth, m.map_at_worst, m.exact_at_worst);
  EXPECT_LE(m.max, scene.shadows.epsilon + 0.005) << what;
  return m;
}

// The frame's count of volumes left out, and its warnings naming them.
FrameStats render_stats(const Scene& scene) {
  Renderer r;
  RenderOptions opt;
  opt.fragments = FragmentSource::Cpu;
  FrameStats st;
  r.render(scene, opt, &st);
  return st;
}

bool warns_of_left_out_volumes(const FrameStats& st) {
  for (const std::string& w : st.warnings)
    if (w.find(std::to_string(st.enclosing_overflow) + " entries") != std::string::npos &&
        w.find("left out") != std::string::npos)
      return true;
  return false;
}

}  // namespace

TEST(NestedMedia, ConstantMediaNestToAnyDepth) {
  for (int n : {16, 17, 20}) {
    const Scene s = nested_media(n, false);
    expect_map_right(s.source, s);
    const FrameStats st = render_stats(s);
    EXPECT_EQ(st.enclosing_overflow, 0u) << s.source;
    EXPECT_FALSE(warns_of_left_out_volumes(st)) << s.source;
  }
  const Scene spheres = nested_media(20, true);
  expect_map_right(spheres.source, spheres);
}

// 16 nested constant media and a volume inside them (17 deep): the volume
// takes the place of a constant medium in the set, which is summed.
TEST(NestedMedia, AVolumeInsideSixteenConstantMedia) {
  Scene s = nested_media(16, false);
  s.source = "16 nested boxes and a volume";
  add_nested_volume(s, 16, 17);
  expect_map_right(s.source, s);
  const FrameStats st = render_stats(s);
  EXPECT_EQ(st.enclosing_overflow, 0u);
  EXPECT_FALSE(warns_of_left_out_volumes(st));
}

// Volumes need their identity (they are marched): 16 nested volumes are
// right; in 17 the innermost is left out, counted and warned about.
TEST(NestedMedia, VolumesBeyondSixteenAreLeftOutAndWarned) {
  Scene s16 = nested_scene("16 nested volumes");
  for (int i = 0; i < 16; ++i) add_nested_volume(s16, i, 16);
  expect_map_right(s16.source, s16);
  const FrameStats st16 = render_stats(s16);
  EXPECT_EQ(st16.enclosing_overflow, 0u);
  EXPECT_FALSE(warns_of_left_out_volumes(st16));

  Scene s17 = nested_scene("17 nested volumes");
  for (int i = 0; i < 17; ++i) add_nested_volume(s17, i, 17);
  const MapError m = map_error_along_rays(s17, 4.0f, 0.02f);
  std::printf("[ nested ] %-40s %zu points: map error max %.4f (the innermost volume left out)\n", s17.source.c_str(),
              m.points, m.max);
  const FrameStats st17 = render_stats(s17);
  EXPECT_GT(st17.enclosing_overflow, 0u);
  EXPECT_TRUE(warns_of_left_out_volumes(st17));
  for (const std::string& w : st17.warnings) std::printf("[ nested ] warning: %s\n", w.c_str());
}
