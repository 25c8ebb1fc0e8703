// The segment walker (hd/segments.h, DESIGN.md §2.3): bracket matching of
// entries and exits per object, unmatched ends ignored, an eye inside
// objects, and the bounded enclosing set counting what it drops.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "cdsm/renderer.h"
#include "scene/fragments.h"
#include "hd/segments.h"
#include "unit_util.h"

using namespace cdsm;
using namespace cdsm_test;

namespace {

struct SurfaceCall {
  float t;
  uint32_t object;
  bool front;
};
struct SegmentCall {
  float t0, t1;
  float sigma;
  int volumes;
};

// Records what the walker reports.
struct Recorder {
  const SceneView& s;
  std::vector<SurfaceCall> surfaces;
  std::vector<SegmentCall> segments;
  bool surface(float t, uint32_t tri, bool front) {
    surfaces.push_back({t, s.tri_object[tri], front});
    return true;
  }
  bool segment(float t0, float t1, const SegmentMedia& m) {
    segments.push_back({t0, t1, m.sigma.x, m.volume_count});  // grey media here
    return true;
  }
};

Object box_with_sigma(const std::string& name, float size, float sigma, Vec3 at = {0, 0, 0}) {
  Object o = surface_object(name, make_box({size, size, size}), translation(at));
  o.interior = InteriorKind::Constant;
  o.sigma = vec3(sigma);
  return o;
}

// Objects: 0 outer box (+-2, sigma 1), 1 inner box (+-1, sigma 10), 2 an
// open box (its +x face removed, sigma 1000) at x = 10.
SceneBuffers walker_scene() {
  Scene s = empty_scene("walker");
  s.objects.push_back(box_with_sigma("outer", 4.0f, 1.0f));
  s.objects.push_back(box_with_sigma("inner", 2.0f, 10.0f));
  TriangleMesh open = make_box({2, 2, 2});
  // Remove the +x face: the two triangles whose vertices all have x = +1.
  std::vector<uint32_t> kept;
  for (size_t t = 0; t < open.indices.size(); t += 3) {
    bool px = true;
    for (int k = 0; k < 3; ++k) px = px && open.positions[open.indices[t + k]].x > 0.5f;
    if (!px) kept.insert(kept.end(), open.indices.begin() + long(t), open.indices.begin() + long(t) + 3);
  }
  open.indices = kept;
  Object o = surface_object("open", open, translation({10, 0, 0}));
  o.interior = InteriorKind::Constant;
  o.sigma = vec3(1000.0f);
  s.objects.push_back(o);
  return compiled_scene(s);
}

// The real fragments of one ray (all hits up to tmax), shuffled: the walker sorts.
std::vector<Fragment> ray_fragments(const SceneView& s, Vec3 org, Vec3 dir, uint32_t seed, float tmax = 3.0e38f) {
  std::vector<Fragment> f;
  for_each_hit(s, ObjectMask{}, org, dir, 0.0f, tmax,
               [&](uint32_t tri, const TriHit& h) { f.push_back(make_fragment(h.t, tri, h.front)); });
  std::mt19937 rng(seed);
  std::shuffle(f.begin(), f.end(), rng);
  return f;
}

Recorder walk(const SceneView& s, std::vector<Fragment> frags, const std::vector<uint32_t>& inside, WalkStats& st,
              float t_end = 100.0f) {
  Recorder r{s, {}, {}};
  walk_ray(s, Span<Fragment>{frags.data(), frags.size()}, Span<const uint32_t>{inside.data(), inside.size()}, 0.0f,
           t_end, r, st);
  return r;
}

// Removes the fragments of `object` with the given facing.
std::vector<Fragment> without(const SceneView& s, std::vector<Fragment> f, uint32_t object, bool front) {
  f.erase(
      std::remove_if(f.begin(), f.end(),
                     [&](const Fragment& x) { return s.tri_object[frag_prim(x)] == object && frag_front(x) == front; }),
      f.end());
  return f;
}

const Vec3 kOrg{-5.0f, 0.1f, 0.3f};  // off the faces' diagonals
const Vec3 kDirX{1, 0, 0};

}  // namespace

TEST(SegmentWalker, NestedBoxesMatchLikeBrackets) {
  SceneBuffers sb = walker_scene();
  SceneView sv = sb.view();
  WalkStats st;
  Recorder r = walk(sv, ray_fragments(sv, kOrg, kDirX, 1u, 8.0f), {}, st);
  ASSERT_EQ(r.surfaces.size(), 4u);
  const uint32_t obj[4] = {0, 1, 1, 0};
  const bool front[4] = {true, true, false, false};
  const float t[4] = {3, 4, 6, 7};
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(r.surfaces[size_t(i)].object, obj[i]) << i;
    EXPECT_EQ(r.surfaces[size_t(i)].front, front[i]) << i;
    EXPECT_FLOAT_EQ(r.surfaces[size_t(i)].t, t[i]) << i;
  }
  ASSERT_EQ(r.segments.size(), 3u);
  EXPECT_FLOAT_EQ(r.segments[0].t0, 3.0f);
  EXPECT_FLOAT_EQ(r.segments[0].t1, 4.0f);
  EXPECT_FLOAT_EQ(r.segments[0].sigma, 1.0f);
  EXPECT_FLOAT_EQ(r.segments[1].t0, 4.0f);
  EXPECT_FLOAT_EQ(r.segments[1].t1, 6.0f);
  EXPECT_FLOAT_EQ(r.segments[1].sigma, 11.0f);
  EXPECT_FLOAT_EQ(r.segments[2].t0, 6.0f);
  EXPECT_FLOAT_EQ(r.segments[2].t1, 7.0f);
  EXPECT_FLOAT_EQ(r.segments[2].sigma, 1.0f);
  EXPECT_EQ(st.unmatched, 0u);
  EXPECT_EQ(st.enclosing_overflow, 0u);
}

// An entry whose exit is missing (a one-ulp silhouette tie) is ignored:
// the rest of the ray is not left inside that object.
TEST(SegmentWalker, UnmatchedEntryIgnored) {
  SceneBuffers sb = walker_scene();
  SceneView sv = sb.view();
  WalkStats st;
  Recorder r = walk(sv, without(sv, ray_fragments(sv, kOrg, kDirX, 2u, 8.0f), 1, false), {}, st);
  EXPECT_EQ(r.surfaces.size(), 3u);
  EXPECT_EQ(st.unmatched, 1u);
  float covered = 0.0f;
  for (const SegmentCall& s : r.segments) {
    EXPECT_FLOAT_EQ(s.sigma, 1.0f) << "the inner box's interior must not be entered";
    EXPECT_GE(s.t0, 3.0f);
    EXPECT_LE(s.t1, 7.0f) << "nothing is inside after the last exit";
    covered += s.t1 - s.t0;
  }
  EXPECT_FLOAT_EQ(covered, 4.0f);
}

// An exit without an entry is ignored too (it must not close anything).
TEST(SegmentWalker, UnmatchedExitIgnored) {
  SceneBuffers sb = walker_scene();
  SceneView sv = sb.view();
  WalkStats st;
  Recorder r = walk(sv, without(sv, ray_fragments(sv, kOrg, kDirX, 3u, 8.0f), 0, true), {}, st);
  EXPECT_EQ(st.unmatched, 1u);
  ASSERT_EQ(r.segments.size(), 1u);
  EXPECT_FLOAT_EQ(r.segments[0].t0, 4.0f);
  EXPECT_FLOAT_EQ(r.segments[0].t1, 6.0f);
  EXPECT_FLOAT_EQ(r.segments[0].sigma, 10.0f);
}

// An open mesh has no interior: its surfaces are reported, no segment is.
TEST(SegmentWalker, OpenMeshHasNoInterior) {
  SceneBuffers sb = walker_scene();
  SceneView sv = sb.view();
  ASSERT_EQ(sv.objects[2].flags & kObjClosed, 0u);
  for (Vec3 dir : {Vec3{1, 0, 0}, Vec3{-1, 0, 0}}) {
    Vec3 org{dir.x > 0 ? 5.0f : 15.0f, 0.1f, 0.3f};
    WalkStats st;
    Recorder r = walk(sv, ray_fragments(sv, org, dir, 4u, 8.0f), {}, st);
    EXPECT_EQ(r.surfaces.size(), 1u);
    EXPECT_TRUE(r.segments.empty()) << "open mesh produced a segment of sigma " << r.segments[0].sigma;
  }
  // Through the open box and then the nested pair.
  WalkStats st;
  Recorder r = walk(sv, ray_fragments(sv, {15.0f, 0.1f, 0.3f}, {-1, 0, 0}, 5u), {}, st);
  EXPECT_EQ(r.surfaces.size(), 5u);
  ASSERT_EQ(r.segments.size(), 3u);
  EXPECT_FLOAT_EQ(r.segments[0].sigma, 1.0f);
  EXPECT_FLOAT_EQ(r.segments[1].sigma, 11.0f);
  EXPECT_FLOAT_EQ(r.segments[2].sigma, 1.0f);
  EXPECT_FLOAT_EQ(r.segments[0].t0, 13.0f);
  EXPECT_FLOAT_EQ(r.segments[2].t1, 17.0f);
}

// The eye inside both boxes: the set decided once per view (parity ray)
// starts the walk, and exits close it.
TEST(SegmentWalker, EyeInsideObjects) {
  SceneBuffers sb = walker_scene();
  SceneView sv = sb.view();
  Vec3 org{0.2f, 0.1f, 0.3f};
  std::vector<uint32_t> inside = objects_containing(sv, org, ObjectMask{});
  std::sort(inside.begin(), inside.end());
  ASSERT_EQ(inside, (std::vector<uint32_t>{0u, 1u}));
  WalkStats st;
  Recorder r = walk(sv, ray_fragments(sv, org, kDirX, 6u), inside, st);
  ASSERT_EQ(r.segments.size(), 2u);
  EXPECT_FLOAT_EQ(r.segments[0].t0, 0.0f);
  EXPECT_FLOAT_EQ(r.segments[0].t1, 0.8f);
  EXPECT_FLOAT_EQ(r.segments[0].sigma, 11.0f);
  EXPECT_FLOAT_EQ(r.segments[1].t0, 0.8f);
  EXPECT_FLOAT_EQ(r.segments[1].t1, 1.8f);
  EXPECT_FLOAT_EQ(r.segments[1].sigma, 1.0f);
  EXPECT_EQ(st.unmatched, 0u);
  // The ray ends inside the outer box: the last segment runs to t_end.
  WalkStats st2;
  Recorder r2 = walk(sv, ray_fragments(sv, org, kDirX, 7u), inside, st2, 1.5f);
  ASSERT_EQ(r2.segments.size(), 2u);
  EXPECT_FLOAT_EQ(r2.segments[1].t1, 1.5f);
  // Inside the open box the parity ray says nothing: it has no interior.
  std::vector<uint32_t> in_open = objects_containing(sv, {10.0f, 0.1f, 0.3f}, ObjectMask{});
  EXPECT_TRUE(std::find(in_open.begin(), in_open.end(), 2u) == in_open.end());
}

// Twenty nested boxes with constant media: the set holds kMaxEnclosing;
// the entries beyond are summed (EnclosingOverflow) and taken off at their
// exits, so every segment carries the media of every shell around it
// (issue 25 b). Nothing is left out, so nothing is counted, and the exits
// of the summed shells are not unmatched.
TEST(SegmentWalker, EnclosingSetOverflowSummed) {
  Scene s = empty_scene("nested");
  const int n = 20;
  for (int i = 0; i < n; ++i)  // shell i (0 outermost, half-size n - i) has sigma 2^-i
    s.objects.push_back(box_with_sigma("b" + std::to_string(i), 2.0f * float(n - i), std::ldexp(1.0f, -i)));
  SceneBuffers sb = compiled_scene(s);
  SceneView sv = sb.view();
  WalkStats st;
  Recorder r = walk(sv, ray_fragments(sv, {-25.0f, 0.1f, 0.3f}, kDirX, 8u), {}, st, 100.0f);
  EXPECT_EQ(r.surfaces.size(), size_t(2 * n));
  EXPECT_EQ(st.enclosing_overflow, 0u) << "constant media are summed, not left out";
  EXPECT_EQ(st.unmatched, 0u) << "exits of summed shells are not unmatched fragments";
  ASSERT_EQ(r.segments.size(), size_t(2 * n - 1));
  for (const SegmentCall& c : r.segments) {
    const float x = 0.5f * (c.t0 + c.t1) - 25.0f;  // the segment's middle; shell i encloses |x| < n - i
    float expect = 0.0f;                           // (sums of powers of two: exact in any order)
    for (int i = 0; i < n && std::fabs(x) < float(n - i); ++i) expect += std::ldexp(1.0f, -i);
    EXPECT_FLOAT_EQ(c.sigma, expect) << "segment at x = " << x;
  }
  // After the last exit nothing remains inside.
  for (const SegmentCall& c : r.segments) EXPECT_LE(c.t1, 45.0f);

  EnclosingSet set;
  for (uint32_t o = 0; o < uint32_t(kMaxEnclosing); ++o) EXPECT_TRUE(set.enter(o));
  EXPECT_TRUE(set.enter(3u)) << "re-entering a member nests, no slot needed";
  EXPECT_FALSE(set.enter(100u));
  EXPECT_EQ(set.count, kMaxEnclosing);
  EXPECT_TRUE(set.exit(3u));
  EXPECT_NE(set.find(3u), -1) << "entered twice: still inside after one exit";
  EXPECT_TRUE(set.exit(3u));
  EXPECT_EQ(set.find(3u), -1);
  EXPECT_FALSE(set.exit(100u));
}

// More objects on a ray than the bracket matcher's table (kMaxRayObjects):
// 40 constant-sigma boxes in a row; the ray meets boxes 39, 38, ... in turn,
// and box 34 (among the first eight it meets, which a single pass over the
// table would not track) lacks its exit fragment. Its entry is ignored
// exactly as with few objects: no medium follows it, every other box keeps
// its own segment, and the extra pass is counted.
TEST(SegmentWalker, MoreObjectsThanTheMatcherTracks) {
  Scene s = empty_scene("row");
  const int n = 40;
  for (int i = 0; i < n; ++i)
    s.objects.push_back(
        box_with_sigma("b" + std::to_string(i), 1.0f, 1.0f + 0.01f * float(i), {2.0f * float(i), 0, 0}));
  SceneBuffers sb = compiled_scene(s);
  SceneView sv = sb.view();
  const Vec3 org{100.0f, 0.1f, 0.3f}, dir{-1, 0, 0};
  std::vector<Fragment> all = ray_fragments(sv, org, dir, 11u);
  ASSERT_EQ(all.size(), size_t(2 * n));
  std::vector<Fragment> broken = without(sv, all, 34, false);
  ASSERT_EQ(broken.size(), size_t(2 * n - 1));
  WalkStats st;
  Recorder r = walk(sv, broken, {}, st, 200.0f);
  EXPECT_EQ(st.match_overflow, 1u);
  EXPECT_EQ(st.unmatched, 1u);
  ASSERT_EQ(r.segments.size(), size_t(n - 1));
  for (const SegmentCall& c : r.segments) {
    EXPECT_NEAR(c.t1 - c.t0, 1.0f, 1e-4f) << "a segment spans one box, nothing longer";
    int box = int(std::lround((100.0f - 0.5f * (c.t0 + c.t1)) / 2.0f));
    EXPECT_NE(box, 34);
    EXPECT_FLOAT_EQ(c.sigma, 1.0f + 0.01f * float(box));
  }
  // The same boxes through a ray with only 10 objects on it: same segments.
  std::vector<Fragment> few;
  for (const Fragment& f : broken)
    if (sv.tri_object[frag_prim(f)] >= 30) few.push_back(f);
  WalkStats st_few;
  Recorder r_few = walk(sv, few, {}, st_few, 200.0f);
  EXPECT_EQ(st_few.match_overflow, 0u);
  EXPECT_EQ(st_few.unmatched, 1u);
  ASSERT_EQ(r_few.segments.size(), 9u);
  for (size_t k = 0; k < r_few.segments.size(); ++k) {
    EXPECT_EQ(r_few.segments[k].t0, r.segments[k].t0);
    EXPECT_EQ(r_few.segments[k].t1, r.segments[k].t1);
    EXPECT_EQ(r_few.segments[k].sigma, r.segments[k].sigma);
  }
}

// Both counters reach the frame's statistics (and so --stats and the
// printed summary): a camera looking down a row of 40 boxes, and into 20
// nested shells of constant media (summed: nothing is left out; volumes
// left out are counted: test_nested_media.cpp).
TEST(SegmentWalker, CountersReachFrameStats) {
  Scene s = empty_scene("counters");
  for (int i = 0; i < 40; ++i)
    s.objects.push_back(box_with_sigma("row" + std::to_string(i), 0.5f, 0.02f, {0.0f, 0.0f, -2.0f * float(i)}));
  for (int i = 0; i < 20; ++i)
    s.objects.push_back(box_with_sigma("shell" + std::to_string(i), 30.0f - 1.0f * float(i), 0.01f, {0, 0, -40.0f}));
  for (Object& o : s.objects) o.surface.opacity = 0.0f;  // the camera ray goes on through all of them
  s.camera.position = {0.1f, 0.05f, 1.5f};
  s.camera.target = {0.1f, 0.05f, -1.0f};
  s.camera.far = 100.0f;
  s.camera.fov_y_deg = 2.0f;  // every ray down the whole row
  s.camera.width = 32;
  s.camera.height = 24;
  s.lights.push_back(spot_light({0, 5, 0}, {0, -1, 0}, 40.0f, 35.0f));
  s.shadows.resolution = 32;
  Renderer r;
  RenderOptions opt;
  opt.fragments = FragmentSource::Cpu;
  FrameStats st;
  r.render(s, opt, &st);
  EXPECT_GT(st.camera_fragments, 0u);
  EXPECT_GT(st.match_overflow, 0u) << st.camera_fragments << " camera fragments, " << st.unmatched_fragments
                                   << " unmatched";
  EXPECT_EQ(st.enclosing_overflow, 0u);
}

// Per-pixel sort: a total order (depth, primitive, facing), the same for the
// insertion sort (<= 64) and the heap sort beyond, whatever the input order.
TEST(FragmentSort, TotalOrderShortAndLong) {
  std::mt19937 rng(9u);
  std::uniform_int_distribution<int> depth(0, 40), prim(0, 30), coin(0, 1);
  for (int n : {0, 1, 2, 5, 63, 64, 65, 200, 1000}) {
    for (int rep = 0; rep < 20; ++rep) {
      std::vector<Fragment> f;
      for (int i = 0; i < n; ++i)  // many equal depths: ties broken by primitive, then facing
        f.push_back(make_fragment(0.25f * float(depth(rng)), uint32_t(prim(rng)), coin(rng) == 1));
      std::vector<Fragment> expect = f;
      std::stable_sort(expect.begin(), expect.end(), frag_less);
      std::vector<Fragment> a = f, b = f;
      std::shuffle(b.begin(), b.end(), rng);
      sort_fragments({a.data(), a.size()});
      sort_fragments({b.data(), b.size()});
      for (int i = 0; i < n; ++i) {
        ASSERT_EQ(a[size_t(i)].depth, expect[size_t(i)].depth) << "n " << n << " i " << i;
        ASSERT_EQ(a[size_t(i)].bits, expect[size_t(i)].bits) << "n " << n << " i " << i;
        ASSERT_EQ(b[size_t(i)].bits, a[size_t(i)].bits) << "input order changed the result, n " << n;
        ASSERT_EQ(b[size_t(i)].depth, a[size_t(i)].depth);
      }
    }
  }
}
