// Shared helpers of the clustering tests (shadows/cluster).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include "cluster/clustering.h"
#include "cluster/convex.h"
#include "cluster/focus.h"
#include "cluster/light_views.h"
#include "cluster/lispsm.h"
#include "cdsm/scene.h"
#include "hd/view.h"

namespace cluster_test {

using namespace cdsm;
using namespace cdsm::cluster;

constexpr float kPi = 3.14159265358979f;

inline Box3 cube(Vec3 c, float half) {
  Box3 b;
  b.lo = c - vec3(half);
  b.hi = c + vec3(half);
  return b;
}

inline Box3 box(Vec3 lo, Vec3 hi) {
  Box3 b;
  b.lo = lo;
  b.hi = hi;
  return b;
}

// Volume by the divergence theorem over the boundary polygons.
inline float volume(const ConvexBody& body) {
  double v = 0.0;
  for (const Polygon& p : body.polygons) v += double(dot(p[0], polygon_normal(p)));
  return float(v / 6.0);
}

// Every vertex on the inner side of every polygon's plane (convex and closed
// with outward windings).
inline void expect_convex(const ConvexBody& body, float tol) {
  ASSERT_FALSE(body.empty());
  std::vector<Vec3> verts = body.vertices();
  for (const Polygon& poly : body.polygons) {
    ASSERT_GE(poly.size(), 3u);
    Vec3 n = polygon_normal(poly);
    ASSERT_GT(length(n), 0.0f);
    n = normalize(n);
    for (Vec3 p : poly) EXPECT_NEAR(dot(n, p - poly[0]), 0.0f, tol) << "polygon not planar";
    for (Vec3 v : verts) EXPECT_LE(dot(n, v - poly[0]), tol) << "vertex outside a face plane";
  }
}

inline LightShape spot_light(Vec3 pos, Vec3 dir, float outer_deg) {
  LightShape l;
  l.spot = true;
  l.position = pos;
  l.direction = normalize(dir);
  l.outer_cone_deg = outer_deg;
  return l;
}

inline LightShape point_light(Vec3 pos) {
  LightShape l;
  l.spot = false;
  l.position = pos;
  return l;
}

// A camera's view with aspect = width / height when `aspect` <= 0 (the
// frame of cluster::make_frame).
inline PinholeView camera_view(const Camera& camera, float aspect = 0.0f) {
  PinholeView v;
  v.eye = camera.position;
  v.forward = normalize(camera.target - camera.position);
  make_frame(v.forward, camera.up, v.right, v.up);
  v.width = camera.width;
  v.height = camera.height;
  if (!(aspect > 0.0f)) aspect = float(camera.width) / float(std::max(camera.height, 1));
  v.tan_half_y = std::tan(0.5f * camera.fov_y_deg * (kPi / 180.0f));
  v.tan_half_x = v.tan_half_y * aspect;
  v.near = camera.near;
  v.far = camera.far;
  return v;
}

inline PinholeView camera_at(Vec3 pos, Vec3 target, float fov_y = 50.0f, float far = 100.0f) {
  Camera c;
  c.position = pos;
  c.target = target;
  c.fov_y_deg = fov_y;
  c.near = 0.1f;
  c.far = far;
  c.width = 300;
  c.height = 200;
  return camera_view(c);
}

inline const Box3 kScene = box(vec3(-10, 0, -10), vec3(10, 6, 10));

// A point inside the view's window with `guard` texels to spare, and
// within near/far.
inline ::testing::AssertionResult inside_with_guard(const PinholeView& v, Vec3 p, float guard) {
  ViewProjection q = project(v, p);
  const float tol = 1e-3f;
  if (q.axial < v.near * (1.0f - 1e-5f) || q.axial > v.far * (1.0f + 1e-5f))
    return ::testing::AssertionFailure() << "axial " << q.axial << " outside [" << v.near << ", " << v.far << "]";
  if (q.u < guard - tol || q.u > float(v.width) - guard + tol || q.v < guard - tol ||
      q.v > float(v.height) - guard + tol)
    return ::testing::AssertionFailure() << "(u, v) = (" << q.u << ", " << q.v << ") within " << guard
                                         << " texels of the edge of " << v.width << "x" << v.height;
  return ::testing::AssertionSuccess();
}

inline void expect_orthonormal(const PinholeView& v) {
  EXPECT_NEAR(length(v.right), 1.0f, 1e-5f);
  EXPECT_NEAR(length(v.up), 1.0f, 1e-5f);
  EXPECT_NEAR(length(v.forward), 1.0f, 1e-5f);
  EXPECT_NEAR(dot(v.right, v.up), 0.0f, 1e-5f);
  EXPECT_NEAR(dot(v.right, v.forward), 0.0f, 1e-5f);
  EXPECT_NEAR(dot(v.up, v.forward), 0.0f, 1e-5f);
}

inline float angle_deg(Vec3 a, Vec3 b) {
  return std::acos(std::clamp(dot(normalize(a), normalize(b)), -1.0f, 1.0f)) * 180.0f / kPi;
}

// Every caster index exactly once.
inline void expect_partition(const std::vector<std::vector<int>>& groups, int n) {
  std::vector<int> count(size_t(n), 0);
  for (const auto& g : groups) {
    EXPECT_FALSE(g.empty());
    for (int i : g) {
      ASSERT_GE(i, 0);
      ASSERT_LT(i, n);
      ++count[size_t(i)];
    }
  }
  for (int i = 0; i < n; ++i) EXPECT_EQ(count[size_t(i)], 1) << "caster " << i;
}

// A distance table by hand, every caster seen and lit.
inline CasterDistances table(int n, const std::vector<std::vector<float>>& d) {
  CasterDistances D;
  D.count = n;
  D.lispsm.assign(size_t(n * n), 0.0f);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) D.lispsm[size_t(i * n + j)] = d[size_t(i)][size_t(j)];
  D.uniform = D.lispsm;
  D.seen.assign(size_t(n), 1u);
  D.lit.assign(size_t(n), 1u);
  return D;
}

inline std::vector<std::set<int32_t>> member_sets(const Clustering& c) {
  std::vector<std::set<int32_t>> out;
  for (const Cluster& k : c.clusters) out.emplace_back(k.members.begin(), k.members.end());
  return out;
}

}  // namespace cluster_test
