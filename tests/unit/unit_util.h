// Shared helpers of the unit tests: scenes built in code, exact chords of
// tessellated meshes, piecewise-linear evaluation of node lists.
#pragma once

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "cdsm/image.h"
#include "cdsm/procedural.h"
#include "cdsm/scene.h"
#include "common/builders.h"
#include "common/system_frame.h"
#include "frame.h"
#include "hd/bvh.h"
#include "hd/camera_pass.h"
#include "hd/compress.h"
#include "reference/reference.h"

namespace cdsm_test {

using namespace cdsm;

inline std::shared_ptr<const TriangleMesh> share(TriangleMesh m) {
  return std::make_shared<const TriangleMesh>(std::move(m));
}

inline Mat4 translation(Vec3 t) { return make_transform(t, {0, 0, 0}, {1, 1, 1}); }

// Every hit depth of the triangles of object `object` along org + t dir
// (unit dir), over all triangles (no BVH), sorted.
inline std::vector<float> object_hits(const SceneView& s, uint32_t object, Vec3 org, Vec3 dir) {
  std::vector<float> ts;
  WatertightRay wr = make_watertight_ray(org, dir);
  const ObjectData& od = s.objects[object];
  for (uint32_t tri = od.first_tri; tri < od.first_tri + od.tri_count; ++tri) {
    TriHit h;
    if (intersect_triangle(wr, s.tri_vertices[3 * tri], s.tri_vertices[3 * tri + 1], s.tri_vertices[3 * tri + 2], 0.0f,
                           3.0e38f, h))
      ts.push_back(h.t);
  }
  std::sort(ts.begin(), ts.end());
  return ts;
}

// Length of org + t dir, t in [0, tmax], inside the closed object (parity of
// its crossings beyond t; the ray origin must be outside it or the hit list
// odd). This is the exact chord of the tessellated mesh.
inline double inside_length(const std::vector<float>& ts, double tmax) {
  double len = 0.0;
  bool inside = (ts.size() & 1u) != 0u;
  double start = 0.0;
  for (float t : ts) {
    if (inside)
      len += std::max(0.0, std::min<double>(t, tmax) - start);
    else
      start = std::min<double>(t, tmax);
    inside = !inside;
  }
  if (inside) len += std::max(0.0, tmax - start);
  return len;
}

inline double chord(const SceneView& s, uint32_t object, Vec3 org, Vec3 dir, double tmax) {
  return inside_length(object_hits(s, object, org, dir), tmax);
}

// Piecewise-linear alpha of a node list, treating equal-z nodes as a jump:
// left(z) is the value 'before' a step at z (what lookup_alpha returns),
// right(z) the value from z on (the value 'after'). Binary searches.
struct NodeFunction {
  const std::vector<DsmNode>& n;

  static double lerp_nodes(const DsmNode& a, const DsmNode& b, double z) {
    double w = (z - a.z) / (double(b.z) - a.z);
    return a.alpha + w * (double(b.alpha) - a.alpha);
  }
  double left(double z) const {
    auto it = std::lower_bound(n.begin(), n.end(), z, [](const DsmNode& a, double v) { return double(a.z) < v; });
    size_t j = size_t(it - n.begin());  // first node with depth >= z
    if (j == n.size()) return n.empty() ? 0.0 : n.back().alpha;
    if (double(n[j].z) == z) return n[j].alpha;
    if (j == 0) return 0.0;
    return lerp_nodes(n[j - 1], n[j], z);
  }
  double right(double z) const {
    auto it = std::upper_bound(n.begin(), n.end(), z, [](double v, const DsmNode& a) { return v < double(a.z); });
    size_t j = size_t(it - n.begin());  // first node with depth > z
    if (j == 0) return 0.0;
    if (j == n.size() || double(n[j - 1].z) == z) return n[j - 1].alpha;
    return lerp_nodes(n[j - 1], n[j], z);
  }
};

// A scene's frame built by a ShadowSystem on the cpu backend with the exact
// CPU fragment producer (common/system_frame.h).
struct ShadowFixture : SystemFrame {
  Scene scene;
  explicit ShadowFixture(Scene s) : SystemFrame(s), scene(std::move(s)) {}
  ShadowFixture(const ShadowFixture&) = delete;
  ShadowView view() const { return frame.view(scene.shadows); }
  const PinholeView& map_view(size_t i) const { return frame.headers[i].view; }
};

// A scene's frame with what the map tests compare at once: the lookups
// over its maps (sv), the camera pass's visibility through them (vis) and
// the reference renderer over the same lights (ref).
struct ProbedFrame : SystemFrame {
  ShadowView sv;
  DsmVisibility vis;
  ReferenceRenderer ref;
  explicit ProbedFrame(const Scene& s) : SystemFrame(s), sv(view(s)), vis{sv}, ref(sb.view(), frame.setup.lights) {}
  ProbedFrame(const ProbedFrame&) = delete;
};

// PSNR in dB of image a against image b (values as rendered, peak 1).
inline double image_psnr(const Image& a, const Image& b) {
  double se = 0.0;
  for (size_t i = 0; i < a.rgb.size(); ++i) se += double(a.rgb[i] - b.rgb[i]) * double(a.rgb[i] - b.rgb[i]);
  return 10.0 * std::log10(1.0 / std::fmax(se / double(std::max<size_t>(a.rgb.size(), 1)), 1e-20));
}

// What the camera pass uses for a surface point of object `object` (a
// caster's: its own step is left out; kNoObject: a receive-only surface) on
// a plane with normal n: 1 - alpha with each tap at the plane's depth along
// its own ray (hd/lights.h Receiver, hd/camera_pass.h).
inline float surface_visibility(const ShadowView& sv, int light, Vec3 p, Vec3 n, uint32_t object) {
  return grey_of(DsmVisibility{sv}(light, Receiver{p, n, object}));
}

// A volume sample's visibility: looked up at its own depth.
inline float sample_visibility(const ShadowView& sv, int light, Vec3 p) {
  return 1.0f - grey_of(shadow_alpha(sv, sv.lights[uint32_t(light)], p));
}

}  // namespace cdsm_test
