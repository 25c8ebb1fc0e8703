// Exact ray casting (hd/raytri.h, hd/bvh.h, cpu/fragments_cpu.h; DESIGN.md
// §2.1): the watertight test with its tie rule hits a shared edge or vertex
// exactly once per surface crossing; the facing flag; the BVH visits exactly
// the hits of brute force; fragment depth is radial and clipping axial.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "scene/fragments.h"
#include "hd/bvh.h"
#include "unit_util.h"

using namespace cdsm;
using namespace cdsm_test;

namespace {

struct RayHit {
  uint32_t tri;
  float t;
  bool front;
  bool operator<(const RayHit& o) const { return t != o.t ? t < o.t : tri < o.tri; }
  bool operator==(const RayHit& o) const { return tri == o.tri && t == o.t && front == o.front; }
};

std::vector<RayHit> bvh_hits(const SceneView& s, Vec3 org, Vec3 dir, float tmin = 0.0f, float tmax = 3.0e38f,
                             ObjectMask mask = {}) {
  std::vector<RayHit> h;
  bool ok = for_each_hit(s, mask, org, dir, tmin, tmax, [&](uint32_t tri, const TriHit& th) {
    h.push_back({tri, th.t, th.front});
  });
  EXPECT_TRUE(ok) << "BVH stack overflow";
  std::sort(h.begin(), h.end());
  return h;
}

std::vector<RayHit> brute_hits(const SceneView& s, Vec3 org, Vec3 dir, float tmin, float tmax, ObjectMask mask = {}) {
  std::vector<RayHit> h;
  WatertightRay wr = make_watertight_ray(org, dir);
  for (uint32_t tri = 0; tri < s.tri_object.size(); ++tri) {
    if (!mask.contains(s.tri_object[tri])) continue;
    TriHit th;
    if (intersect_triangle(wr, s.tri_vertices[3 * tri], s.tri_vertices[3 * tri + 1], s.tri_vertices[3 * tri + 2], tmin,
                           tmax, th))
      h.push_back({tri, th.t, th.front});
  }
  std::sort(h.begin(), h.end());
  return h;
}

SceneBuffers compile_one(TriangleMesh mesh, Mat4 transform = Mat4{}) {
  Scene s = empty_scene("raytri");
  s.objects.push_back(surface_object("mesh", std::move(mesh), transform));
  return compiled_scene(s);
}

// A closed octahedron with vertices at +-r on the axes, counter-clockwise outwards.
TriangleMesh octahedron(float r) {
  TriangleMesh m;
  m.positions = {{r, 0, 0}, {-r, 0, 0}, {0, r, 0}, {0, -r, 0}, {0, 0, r}, {0, 0, -r}};
  for (int sx = 0; sx < 2; ++sx)
    for (int sy = 0; sy < 2; ++sy)
      for (int sz = 0; sz < 2; ++sz) {
        uint32_t a = uint32_t(sx), b = uint32_t(2 + sy), c = uint32_t(4 + sz);
        bool positive = ((sx + sy + sz) % 2) == 0;  // sign product of the octant
        if (positive)
          m.indices.insert(m.indices.end(), {a, b, c});
        else
          m.indices.insert(m.indices.end(), {a, c, b});
      }
  return m;
}

bool front_expected(Vec3 a, Vec3 b, Vec3 c, Vec3 dir) {
  double e1[3] = {double(b.x) - a.x, double(b.y) - a.y, double(b.z) - a.z};
  double e2[3] = {double(c.x) - a.x, double(c.y) - a.y, double(c.z) - a.z};
  double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
  return n[0] * dir.x + n[1] * dir.y + n[2] * dir.z < 0.0;
}

// A closed convex mesh crossed by a line through its interior: exactly one
// entry (front) then one exit (back).
::testing::AssertionResult one_entry_one_exit(const std::vector<RayHit>& h) {
  if (h.size() != 2) return ::testing::AssertionFailure() << h.size() << " hits";
  if (!h[0].front || h[1].front) return ::testing::AssertionFailure() << "facing " << h[0].front << h[1].front;
  return ::testing::AssertionSuccess();
}

}  // namespace

// Axis-aligned rays through integer and half-integer points of a box with
// vertices at +-1: the face diagonals (u == v), the face centres (shared by
// both triangles of a face) and the box's edges and corners are hit exactly.
TEST(RayTriangle, BoxAxisRaysThroughEdgesAndVertices) {
  SceneBuffers sb = compile_one(make_box({2, 2, 2}));
  SceneView sv = sb.view();
  int inside = 0, boundary = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (float sign : {1.0f, -1.0f})
      for (int iu = -6; iu <= 6; ++iu)
        for (int iv = -6; iv <= 6; ++iv) {
          float u = 0.25f * float(iu), v = 0.25f * float(iv);
          Vec3 org, dir;
          org[axis] = -5.0f * sign;
          org[(axis + 1) % 3] = u;
          org[(axis + 2) % 3] = v;
          dir[axis] = sign;
          std::vector<RayHit> h = bvh_hits(sv, org, dir);
          SCOPED_TRACE("axis " + std::to_string(axis) + " sign " + std::to_string(sign) + " u " + std::to_string(u) +
                       " v " + std::to_string(v));
          bool strictly_in = std::fabs(u) < 1.0f && std::fabs(v) < 1.0f;
          bool outside = std::fabs(u) > 1.0f || std::fabs(v) > 1.0f;
          if (strictly_in) {
            ++inside;
            ASSERT_TRUE(one_entry_one_exit(h));
            EXPECT_EQ(h[0].t, 4.0f);
            EXPECT_EQ(h[1].t, 6.0f);
          } else if (outside) {
            EXPECT_TRUE(h.empty()) << h.size() << " hits";
          } else {  // on the silhouette: both crossings or none, never one
            ++boundary;
            EXPECT_TRUE(h.empty() || one_entry_one_exit(h)) << h.size() << " hits";
          }
        }
  EXPECT_GT(inside, 100);
  EXPECT_GT(boundary, 20);
}

// Oblique lines with dyadic directions, exactly through the box's corners,
// the midpoints of its edges and points on its face diagonals, and through
// an interior point: every one crosses the closed box exactly twice (one
// entry, one exit), tested against each of the 12 triangles directly.
TEST(RayTriangle, BoxObliqueDyadicLinesThroughEdgesAndCorners) {
  TriangleMesh box = make_box({2, 2, 2});
  std::vector<Vec3> targets;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z) {
        int on = (std::abs(x) == 1) + (std::abs(y) == 1) + (std::abs(z) == 1);
        if (on >= 2) targets.push_back({float(x), float(y), float(z)});  // corners, edge midpoints
      }
  for (float a : {-0.5f, 0.5f, 0.25f}) {  // on the face diagonals (u == v) of every face
    for (int axis = 0; axis < 3; ++axis)
      for (float s : {-1.0f, 1.0f}) {
        Vec3 p;
        p[axis] = s;
        p[(axis + 1) % 3] = a;
        p[(axis + 2) % 3] = a;
        targets.push_back(p);
        p[(axis + 2) % 3] = -a;
        targets.push_back(p);
      }
  }
  const Vec3 interior[] = {{0, 0, 0}, {0.5f, 0.25f, -0.5f}, {-0.25f, 0.5f, 0.125f}, {0.75f, -0.75f, 0.5f}};
  int lines = 0;
  for (const Vec3& target : targets)
    for (const Vec3& c : interior) {
      Vec3 d = c - target;  // dyadic components: the shear is exact
      Vec3 org = target - d * 4.0f;
      WatertightRay wr = make_watertight_ray(org, d);
      std::vector<RayHit> h;
      for (uint32_t t = 0; t < box.triangle_count(); ++t) {
        Vec3 a = box.positions[box.indices[3 * t]], b = box.positions[box.indices[3 * t + 1]],
             cc = box.positions[box.indices[3 * t + 2]];
        TriHit th;
        if (intersect_triangle(wr, a, b, cc, 0.0f, 1e30f, th)) {
          h.push_back({t, th.t, th.front});
          EXPECT_EQ(th.front, front_expected(a, b, cc, d));
        }
      }
      std::sort(h.begin(), h.end());
      EXPECT_TRUE(one_entry_one_exit(h)) << "target (" << target.x << ", " << target.y << ", " << target.z
                                         << ") towards (" << c.x << ", " << c.y << ", " << c.z << ")";
      if (h.size() == 2) {
        EXPECT_FLOAT_EQ(h[0].t, 4.0f) << "the entry is the target itself";
      }
      ++lines;
    }
  EXPECT_EQ(lines, int(targets.size()) * 4);
}

// A closed fan of eight triangles around a vertex (integer coordinates), in
// both windings: rays with dyadic slopes exactly through the centre vertex,
// along the spokes and through interiors hit exactly one triangle, with the
// facing flag of the geometric normal.
TEST(RayTriangle, FanAroundVertexExactlyOneHit) {
  const Vec3 ring[8] = {{2, 0, 0}, {2, 2, 0}, {0, 2, 0}, {-2, 2, 0}, {-2, 0, 0}, {-2, -2, 0}, {0, -2, 0}, {2, -2, 0}};
  const Vec3 centre{0, 0, 0};
  const Vec3 targets[] = {{0, 0, 0},    {1, 0, 0},        {1, 1, 0},          {0, 1, 0},     {-1, 1, 0},
                          {-1, 0, 0},   {-1, -1, 0},      {0, -1, 0},         {1, -1, 0},    {0.5f, 0.25f, 0},
                          {1.5f, 1, 0}, {-0.5f, 0.5f, 0}, {0.25f, -0.75f, 0}, {-1.5f, 0, 0}, {0, 1.5f, 0}};
  const Vec3 dirs[] = {{0, 0, 1},         {0, 0, -1},        {0.5f, 0.25f, 1}, {-0.5f, 0.25f, -1}, {1, 1, 2},
                       {-1, 0.5f, 0.25f}, {0.25f, -1, 0.5f}, {3, -2, 1},       {-2, -3, -4},       {1, 0, 0.125f}};
  int cases = 0;
  for (bool reversed : {false, true})
    for (const Vec3& target : targets)
      for (const Vec3& d : dirs) {
        Vec3 org = target - d * 4.0f;
        WatertightRay wr = make_watertight_ray(org, d);
        int hits = 0;
        for (int k = 0; k < 8; ++k) {
          Vec3 a = centre, b = ring[k], c = ring[(k + 1) % 8];
          if (reversed) std::swap(b, c);
          TriHit h;
          if (intersect_triangle(wr, a, b, c, 0.0f, 1e30f, h)) {
            ++hits;
            EXPECT_EQ(h.front, front_expected(a, b, c, d));
            EXPECT_NEAR(h.t, 4.0f, 1e-5f);  // unnormalized direction: t in units of d
          }
        }
        EXPECT_EQ(hits, 1) << "target (" << target.x << ", " << target.y << ") dir (" << d.x << ", " << d.y << ", "
                           << d.z << ") reversed " << reversed;
        ++cases;
      }
  EXPECT_EQ(cases, 2 * 15 * 10);
}

// An octahedron with integer vertices: lines through a vertex or the midpoint
// of an edge and an interior lattice point cross the surface exactly twice.
TEST(RayTriangle, OctahedronLinesThroughVerticesAndEdges) {
  TriangleMesh oct = octahedron(4.0f);
  ASSERT_TRUE(is_closed(oct));
  SceneBuffers sb = compile_one(oct);
  SceneView sv = sb.view();
  std::vector<Vec3> targets = oct.positions;
  for (uint32_t t = 0; t < 8; ++t)
    for (int k = 0; k < 3; ++k) {
      Vec3 a = oct.positions[oct.indices[3 * t + k]], b = oct.positions[oct.indices[3 * t + (k + 1) % 3]];
      targets.push_back((a + b) * 0.5f);  // edge midpoints (exact: integers / 2)
    }
  int lines = 0;
  for (const Vec3& target : targets)
    for (int x = -2; x <= 2; ++x)
      for (int y = -1; y <= 1; ++y)
        for (int z = -1; z <= 1; ++z) {
          if (std::abs(x) + std::abs(y) + std::abs(z) >= 4) continue;  // on the surface
          Vec3 c{float(x), float(y), float(z)};                        // strictly interior
          Vec3 d = c - target;
          if (length(d) == 0.0f) continue;
          Vec3 dir = normalize(d);
          Vec3 org = target - dir * 10.0f;
          std::vector<RayHit> h = bvh_hits(sv, org, dir);
          EXPECT_TRUE(one_entry_one_exit(h)) << "target (" << target.x << ", " << target.y << ", " << target.z
                                             << ") through (" << x << ", " << y << ", " << z << ")";
          if (!h.empty()) {
            EXPECT_NEAR(h[0].t, 10.0f, 1e-4f);
          }
          ++lines;
        }
  EXPECT_GT(lines, 1000) << lines;
}

// UV sphere: the poles are vertices shared by a full fan; lines along the
// axis hit each pole once, and lines aimed from every vertex towards the
// interior cross exactly twice.
TEST(RayTriangle, SpherePolesAndVertexAimedLines) {
  TriangleMesh sphere = make_sphere(1.0f, 24, 12);
  SceneBuffers sb = compile_one(sphere);
  SceneView sv = sb.view();
  for (float s : {1.0f, -1.0f}) {
    std::vector<RayHit> h = bvh_hits(sv, {0, -5.0f * s, 0}, {0, s, 0});
    ASSERT_TRUE(one_entry_one_exit(h));
    EXPECT_NEAR(h[0].t, 4.0f, 1e-6f);
    EXPECT_NEAR(h[1].t, 6.0f, 1e-6f);
  }
  std::mt19937 rng(11u);
  std::uniform_real_distribution<float> u(-0.4f, 0.4f);
  for (const Vec3& v : sphere.positions)
    for (int k = 0; k < 6; ++k) {
      Vec3 c{u(rng), u(rng), u(rng)};
      Vec3 dir = normalize(c - v);
      std::vector<RayHit> h = bvh_hits(sv, v - dir * 3.0f, dir);
      EXPECT_TRUE(one_entry_one_exit(h)) << "vertex (" << v.x << ", " << v.y << ", " << v.z << ")";
    }
}

// The facing flag equals the sign of the geometric normal against the ray.
TEST(RayTriangle, FrontFacingFlagMatchesGeometricNormal) {
  std::mt19937 rng(12u);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  int hits = 0;
  for (int i = 0; i < 200000 && hits < 20000; ++i) {
    Vec3 a{u(rng), u(rng), u(rng)}, b{u(rng), u(rng), u(rng)}, c{u(rng), u(rng), u(rng)};
    Vec3 target = a * 0.3f + b * 0.3f + c * 0.4f;
    Vec3 dir = normalize(Vec3{u(rng), u(rng), u(rng)});
    Vec3 org = target - dir * (1.0f + 2.0f * std::fabs(u(rng)));
    TriHit h;
    if (intersect_triangle(make_watertight_ray(org, dir), a, b, c, 0.0f, 1e30f, h)) {
      ++hits;
      ASSERT_EQ(h.front, front_expected(a, b, c, dir)) << "trial " << i;
    }
  }
  EXPECT_GE(hits, 20000);
}

namespace {

// A few thousand triangles: spheres and boxes under random rotations,
// non-uniform scales and translations.
SceneBuffers cluttered_scene() {
  Scene s = empty_scene("bvh");
  std::mt19937 rng(13u);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 16; ++i) {
    Vec3 t{-3.0f + 6.0f * u(rng), -2.0f + 4.0f * u(rng), -3.0f + 6.0f * u(rng)};
    Vec3 r{360.0f * u(rng), 360.0f * u(rng), 360.0f * u(rng)};
    Vec3 sc{0.5f + u(rng), 0.5f + u(rng), 0.5f + u(rng)};
    TriangleMesh m = i % 3 == 0 ? make_box({1, 1, 1}) : make_sphere(1.0f, 24, 12);
    s.objects.push_back(surface_object("o" + std::to_string(i), std::move(m), make_transform(t, r, sc)));
  }
  return compiled_scene(s);
}

}  // namespace

// for_each_hit over the BVH visits exactly the hits of a test against every
// triangle: random rays, axis-aligned rays, clipped ranges, object masks.
TEST(Bvh, ForEachHitEqualsBruteForce) {
  SceneBuffers sb = cluttered_scene();
  SceneView sv = sb.view();
  ASSERT_GT(sv.tri_object.size(), 2000u);
  std::mt19937 rng(14u);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), u01(0.0f, 1.0f);
  std::vector<uint32_t> odd_objects((sv.objects.size() + 31) / 32, 0u);
  for (uint32_t o = 1; o < sv.objects.size(); o += 2) odd_objects[o >> 5] |= 1u << (o & 31u);
  ObjectMask odd{{odd_objects.data(), odd_objects.size()}};
  size_t total_hits = 0;
  for (int i = 0; i < 12000; ++i) {
    Vec3 org{5.0f * u(rng), 3.0f * u(rng), 5.0f * u(rng)};
    Vec3 dir;
    switch (i % 4) {
      case 0: {  // axis-aligned (zero components: the slab test's infinities)
        int a = i / 4 % 3;
        dir[a] = u(rng) < 0.0f ? -1.0f : 1.0f;
        break;
      }
      case 1:  // towards the middle of the scene
        dir = normalize(Vec3{u(rng), u(rng), u(rng)} - org);
        break;
      default: dir = normalize(Vec3{u(rng), u(rng), u(rng)});
    }
    float tmin = i % 5 == 0 ? 2.0f * u01(rng) : 0.0f;
    float tmax = i % 7 == 0 ? tmin + 4.0f * u01(rng) : 3.0e38f;
    ObjectMask mask = i % 3 == 0 ? odd : ObjectMask{};
    std::vector<RayHit> a = bvh_hits(sv, org, dir, tmin, tmax, mask);
    std::vector<RayHit> b = brute_hits(sv, org, dir, tmin, tmax, mask);
    ASSERT_EQ(a.size(), b.size()) << "ray " << i;
    for (size_t k = 0; k < a.size(); ++k) ASSERT_TRUE(a[k] == b[k]) << "ray " << i << " hit " << k;
    total_hits += a.size();
  }
  EXPECT_GT(total_hits, 10000u);
}

// Watertightness under arbitrary transforms: rays from outside aimed at the
// vertices (shared by up to 24 triangles) and edge midpoints of closed meshes
// cross each of them in alternating entries and exits, an even number of
// times — never a lone crossing through a crack or a double hit on an edge.
TEST(RayTriangle, ClosedMeshesAlternateEntriesAndExits) {
  SceneBuffers sb = cluttered_scene();
  SceneView sv = sb.view();
  std::mt19937 rng(15u);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  int rays = 0, crossings = 0;
  for (uint32_t tri = 0; tri < sv.tri_object.size(); tri += 3) {
    for (int k = 0; k < 2; ++k) {
      Vec3 a = sv.tri_vertices[3 * tri], b = sv.tri_vertices[3 * tri + 1];
      Vec3 target = k == 0 ? a : (a + b) * 0.5f;
      Vec3 dir = normalize(Vec3{u(rng), u(rng), u(rng)});
      Vec3 org = target - dir * 30.0f;  // outside every object
      std::vector<RayHit> h = bvh_hits(sv, org, dir);
      // Grazing a vertex gives an entry and an exit at the same depth: entry first.
      std::stable_sort(h.begin(), h.end(),
                       [](const RayHit& x, const RayHit& y) { return x.t != y.t ? x.t < y.t : (x.front && !y.front); });
      std::vector<int> state(sv.objects.size(), 0);
      for (const RayHit& hit : h) {
        uint32_t o = sv.tri_object[hit.tri];
        ASSERT_EQ(hit.front, state[o] == 0) << "object " << o << " ray " << rays << " t " << hit.t;
        state[o] ^= 1;
        ++crossings;
      }
      for (size_t o = 0; o < state.size(); ++o) ASSERT_EQ(state[o], 0) << "object " << o << " ray " << rays;
      ++rays;
    }
  }
  EXPECT_GT(rays, 1000);
  EXPECT_GT(crossings, 2 * rays);
}

namespace {

// A camera looking straight down at a large quad at axial distance 5, with
// a 90-degree field of view (corner rays 54.7 degrees off axis).
PinholeView down_view(float near, float far) {
  PinholeView v;
  v.eye = {0.0f, 5.0f, 0.0f};
  v.forward = {0, -1, 0};
  v.right = {1, 0, 0};
  v.up = {0, 0, -1};
  v.tan_half_x = v.tan_half_y = 1.0f;
  v.width = v.height = 32;
  v.near = near;
  v.far = far;
  return v;
}

}  // namespace

// Fragment depth is the distance from the eye along the ray (radial), not
// the view-axis coordinate.
TEST(Fragments, DepthIsRadial) {
  SceneBuffers sb = compile_one(make_quad(40.0f, 40.0f));
  SceneView sv = sb.view();
  PinholeView view = down_view(0.1f, 100.0f);
  FragmentBuffers fb;
  cast_fragments(sv, view, ObjectMask{}, fb);
  ASSERT_EQ(fb.width, 32);
  ASSERT_EQ(fb.offsets.size(), 32u * 32u + 1u);
  FragmentLists fl = fb.lists();
  double max_gap = 0.0;
  for (int py = 0; py < 32; ++py)
    for (int px = 0; px < 32; ++px) {
      Span<Fragment> f = fl.pixel(px, py);
      ASSERT_EQ(f.size(), 1u) << px << ", " << py;
      Vec3 dir = pixel_ray(view, px, py);
      double t = 5.0 / -double(dir.y);  // where the ray meets y = 0
      Vec3 p = view.eye + dir * float(t);
      double radial = length(p - view.eye);
      double axial = 5.0;
      EXPECT_NEAR(f[0].depth, radial, 2e-6 * radial);
      max_gap = std::max(max_gap, radial - axial);
      EXPECT_TRUE(frag_front(f[0]));  // the quad faces +y, the camera looks down
      EXPECT_LT(frag_prim(f[0]), 2u);
    }
  EXPECT_GT(max_gap, 3.0) << "corner rays must be far from the axis for this test to mean anything";
}

// Clipping keeps hits whose view-axis coordinate lies in [near, far]: the
// quad at axial 5 has radial depths up to 8.5 in the corners.
TEST(Fragments, NearFarClipOnAxialCoordinate) {
  SceneBuffers sb = compile_one(make_quad(40.0f, 40.0f));
  SceneView sv = sb.view();
  struct Case {
    float near, far;
    uint32_t expect;  // fragments per pixel
  } cases[] = {{0.1f, 6.0f, 1u}, {0.1f, 4.9f, 0u}, {5.5f, 100.0f, 0u}, {4.5f, 5.5f, 1u}, {4.99f, 5.01f, 1u}};
  for (const Case& c : cases) {
    FragmentBuffers fb;
    cast_fragments(sv, down_view(c.near, c.far), ObjectMask{}, fb);
    EXPECT_EQ(fb.total(), size_t(32 * 32) * c.expect) << "near " << c.near << " far " << c.far;
    for (int i = 0; i < 32 * 32; ++i)
      ASSERT_EQ(fb.offsets[size_t(i) + 1] - fb.offsets[size_t(i)], c.expect) << "pixel " << i;
  }
}

// A 3D scene cut by the clip planes: every pixel's fragments are exactly the
// BVH hits along its centre ray whose axial coordinate is in [near, far].
TEST(Fragments, ListsEqualAxiallyClippedHits) {
  SceneBuffers sb = cluttered_scene();
  SceneView sv = sb.view();
  PinholeView view;
  view.eye = {0.0f, 1.0f, 9.0f};
  view.forward = normalize(Vec3{0.0f, -0.1f, -1.0f});
  view.right = normalize(cross(view.forward, {0, 1, 0}));
  view.up = cross(view.right, view.forward);
  view.tan_half_x = 0.8f;
  view.tan_half_y = 0.6f;
  view.width = 64;
  view.height = 48;
  view.near = 7.5f;
  view.far = 10.0f;
  FragmentBuffers fb;
  cast_fragments(sv, view, ObjectMask{}, fb);
  FragmentLists fl = fb.lists();
  size_t clipped = 0;
  for (int py = 0; py < view.height; ++py)
    for (int px = 0; px < view.width; ++px) {
      Vec3 dir = pixel_ray(view, px, py);
      std::vector<RayHit> all = bvh_hits(sv, view.eye, dir);
      std::vector<RayHit> expect;
      for (const RayHit& h : all) {
        float ax = h.t * dot(dir, view.forward);
        if (ax >= view.near && ax <= view.far)
          expect.push_back(h);
        else
          ++clipped;
      }
      std::vector<RayHit> got;
      for (const Fragment& f : fl.pixel(px, py)) got.push_back({frag_prim(f), f.depth, frag_front(f)});
      std::sort(got.begin(), got.end());
      ASSERT_EQ(got.size(), expect.size()) << px << ", " << py;
      for (size_t k = 0; k < got.size(); ++k) ASSERT_TRUE(got[k] == expect[k]) << px << ", " << py;
    }
  EXPECT_GT(clipped, 100u) << "the clip planes should cut the scene";
  EXPECT_GT(fb.total(), 500u);
}

namespace {

uint32_t bits_of(float x) {
  uint32_t u;
  std::memcpy(&u, &x, 4);
  return u;
}

}  // namespace

// cdsm::fminf / fmaxf (cdsm/math.h) are the inline host versions every
// CDSM_HD slab test, clamp and march uses: bit for bit what the C library
// returns, NaN operands (a ray parallel to a slab: 0 * inf) and signed
// zeros (the second of an equal pair) included, so inlining them changed
// no result. (GCC may expand a direct ::fminf call itself, with the first
// of an equal pair: the reference is the library's function, called
// through a pointer.)
TEST(HostMinMax, BitIdenticalToTheCLibrary) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  std::vector<float> v = {0.0f, -0.0f, 1.0f, -1.0f, inf, -inf, nan, -nan, 1e-38f, -1e-45f, 3.0e38f, 0.5f};
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-10.0f, 10.0f);
  for (int i = 0; i < 200; ++i) v.push_back(u(rng));
  // Through pointers the compiler cannot see through: the library's own
  // functions, never an inline expansion of the builtins.
  float (*volatile lib_fminf)(float, float) = ::fminf;
  float (*volatile lib_fmaxf)(float, float) = ::fmaxf;
  size_t checked = 0;
  for (float a : v)
    for (float b : v) {
      const float lib_min = lib_fminf(a, b), lib_max = lib_fmaxf(a, b);
      const float our_min = cdsm::fminf(a, b), our_max = cdsm::fmaxf(a, b);
      if (std::isnan(lib_min))
        EXPECT_TRUE(std::isnan(our_min)) << a << " " << b;
      else
        EXPECT_EQ(bits_of(our_min), bits_of(lib_min)) << "fminf(" << a << ", " << b << ")";
      if (std::isnan(lib_max))
        EXPECT_TRUE(std::isnan(our_max)) << a << " " << b;
      else
        EXPECT_EQ(bits_of(our_max), bits_of(lib_max)) << "fmaxf(" << a << ", " << b << ")";
      ++checked;
    }
  EXPECT_EQ(checked, v.size() * v.size());
}
