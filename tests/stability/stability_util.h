// Helpers of the numerical-stability suite: scenes built in code, a rig that
// builds a scene's deep shadow maps with the exact CPU fragment producer and
// looks them up, and checks that images and node lists are physical.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "cdsm/cdsm.h"
#include "common/builders.h"
#include "common/system_frame.h"
#include "frame.h"
#include "hd/camera_pass.h"
#include "reference/reference.h"

namespace stab {

using namespace cdsm;
using cdsm_test::compiled_scene;
using cdsm_test::surface_object;
using cdsm_test::SystemFrame;

inline std::shared_ptr<const TriangleMesh> share(TriangleMesh m) {
  return std::make_shared<const TriangleMesh>(std::move(m));
}

inline Mat4 at(Vec3 t, Vec3 scale = {1, 1, 1}, Vec3 rotate_deg = {0, 0, 0}) {
  return make_transform(t, rotate_deg, scale);
}

// A closed object with a constant absorbing interior and an invisible boundary.
inline Object medium_object(const std::string& name, TriangleMesh mesh, Mat4 transform, float sigma,
                            float opacity = 0.0f) {
  Object o = surface_object(name, std::move(mesh), transform, opacity);
  o.interior = InteriorKind::Constant;
  o.sigma = vec3(sigma);
  return o;
}

// A uniform volume (every voxel and the background = 1, transfer 1 ->
// `sigma`) whose grid covers the world box [lo, hi] with n^3 voxels, bounded
// by `proxy` (object space = world space); black albedo unless given.
inline void add_uniform_volume(Scene& s, const std::string& name, Vec3 lo, Vec3 hi, float sigma, TriangleMesh proxy,
                               int n = 8, Vec3 albedo = {0, 0, 0}, float step_voxels = 0.5f) {
  auto g = std::make_shared<DenseGrid>();
  g->nx = g->ny = g->nz = n;
  g->values.assign(size_t(n) * n * n, 1.0f);
  g->background = 1.0f;
  Volume v;
  v.name = name;
  v.grid = g;
  Vec3 vs = (hi - lo) * (1.0f / float(n));
  Mat4 m;
  m.m[0][0] = vs.x;
  m.m[1][1] = vs.y;
  m.m[2][2] = vs.z;
  m.m[0][3] = lo.x + 0.5f * vs.x;
  m.m[1][3] = lo.y + 0.5f * vs.y;
  m.m[2][3] = lo.z + 0.5f * vs.z;
  v.index_to_object = m;
  v.transfer = {TransferPoint{0.0f, vec3(0.0f), albedo}, TransferPoint{1.0f, vec3(sigma), albedo}};
  v.step_voxels = step_voxels;
  s.volumes.push_back(v);
  Object o;
  o.name = name;
  o.mesh = share(std::move(proxy));
  o.surface.opacity = 0.0f;
  o.interior = InteriorKind::Volume;
  o.volume = int32_t(s.volumes.size() - 1);
  s.objects.push_back(o);
}

// The box [lo, hi] as a mesh in world space.
inline TriangleMesh box_mesh(Vec3 lo, Vec3 hi) {
  TriangleMesh m = make_box(hi - lo);
  Vec3 c = (lo + hi) * 0.5f;
  for (Vec3& p : m.positions) p = p + c;
  return m;
}

using cdsm_test::point_light;
using cdsm_test::spot_light;

// An empty scene with a small camera (48x32, from (0, 3, 6)) and 64² maps.
inline Scene scene_named(const std::string& name) {
  Scene s = cdsm_test::empty_scene(name);
  s.camera.position = {0, 3, 6};
  s.camera.width = 48;
  s.camera.height = 32;
  s.shadows.resolution = 64;
  return s;
}

inline RenderOptions cpu_options() {
  RenderOptions o;
  o.fragments = FragmentSource::Cpu;
  o.error_samples = 4000;
  return o;
}

// A scene's frame built by a ShadowSystem on the CPU (exact fragments;
// common/system_frame.h).
struct Rig : SystemFrame {
  Scene scene;

  explicit Rig(Scene s) : SystemFrame(s), scene(std::move(s)) {}
  Rig(const Rig&) = delete;
  ShadowView view() const { return frame.view(scene.shadows); }
  // Opacity between light `li` and p from the maps (no bias).
  float alpha(Vec3 p, int li = 0) const {
    ShadowView v = view();
    return grey_of(shadow_alpha(v, v.lights[size_t(li)], p));
  }
  // Exact transmittance from the reference renderer.
  float reference_T(Vec3 p, int li = 0) const {
    ReferenceRenderer ref(sb.view(), frame.setup.lights);
    return grey_of(ref.transmittance(li, p));
  }
  // Node list of one texel of map `map`.
  std::vector<DsmNode> texel(int map, int tx, int ty) const {
    ShadowView v = view();
    Span<const DsmNode> n = texel_nodes<1>(v.storage, v.maps[size_t(map)], tx, ty);
    return std::vector<DsmNode>(n.begin(), n.end());
  }
  // The texel of map `map` whose cell contains p's projection.
  std::vector<DsmNode> texel_at(int map, Vec3 p) const {
    ShadowView v = view();
    ViewProjection pr = project(v.maps[size_t(map)].view, p);
    return texel(map, int(std::floor(pr.u)), int(std::floor(pr.v)));
  }
  uint64_t overflow_texels() const {
    uint64_t n = 0;
    for (const DsmBuildStats& s : frame.map_stats) n += s.overflow_texels;
    return n;
  }
};

// Every node finite, alpha in [0, 1], depth and alpha non-decreasing.
inline ::testing::AssertionResult physical(const std::vector<DsmNode>& n) {
  for (size_t i = 0; i < n.size(); ++i) {
    if (!std::isfinite(n[i].z) || !std::isfinite(n[i].alpha))
      return ::testing::AssertionFailure() << "node " << i << " is not finite";
    if (n[i].alpha < 0.0f || n[i].alpha > 1.0f)
      return ::testing::AssertionFailure() << "node " << i << " alpha " << n[i].alpha << " outside [0, 1]";
    if (i > 0 && (n[i].z < n[i - 1].z || n[i].alpha < n[i - 1].alpha))
      return ::testing::AssertionFailure() << "node " << i << " (" << n[i].z << ", " << n[i].alpha
                                           << ") goes back from (" << n[i - 1].z << ", " << n[i - 1].alpha << ")";
  }
  return ::testing::AssertionSuccess();
}

// Every texel of every map of the rig is physical.
inline ::testing::AssertionResult all_physical(const Rig& rig) {
  ShadowView v = rig.view();
  for (size_t m = 0; m < v.maps.size(); ++m)
    for (uint32_t ty = 0; ty < v.maps[m].res; ++ty)
      for (uint32_t tx = 0; tx < v.maps[m].res; ++tx) {
        auto r = physical(rig.texel(int(m), int(tx), int(ty)));
        if (!r) return r << " (map " << m << ", texel " << tx << "," << ty << ")";
      }
  return ::testing::AssertionSuccess();
}

inline ::testing::AssertionResult finite_image(const Image& img) {
  if (img.rgb.size() != size_t(img.width) * img.height * 3) return ::testing::AssertionFailure() << "image size";
  for (size_t i = 0; i < img.rgb.size(); ++i)
    if (!std::isfinite(img.rgb[i]) || img.rgb[i] < 0.0f)
      return ::testing::AssertionFailure() << "pixel " << i / 3 << " channel " << i % 3 << " = " << img.rgb[i];
  return ::testing::AssertionSuccess();
}

// The scene's image from the maps and from the reference (CPU fragments),
// and their PSNR, each image checked finite (the result's `finite`).
struct ImagePair {
  Image img, ref;
  ::testing::AssertionResult finite = ::testing::AssertionSuccess();
  double psnr() const { return compare_images(img, ref).psnr; }
};
inline ImagePair render_both(Renderer& r, const Scene& s) {
  ImagePair p;
  const RenderOptions o = cpu_options();
  p.img = r.render(s, o);
  p.ref = r.render_reference(s, o);
  p.finite = finite_image(p.img);
  if (p.finite) p.finite = finite_image(p.ref);
  return p;
}

inline Vec3 pixel(const Image& img, int x, int y) {
  const float* p = img.rgb.data() + (size_t(y) * img.width + x) * 3;
  return {p[0], p[1], p[2]};
}

inline float max_abs_diff(const Image& a, const Image& b) {
  float m = 0.0f;
  for (size_t i = 0; i < a.rgb.size() && i < b.rgb.size(); ++i) m = std::fmax(m, std::fabs(a.rgb[i] - b.rgb[i]));
  return m;
}

// Whether a per-texel node buffer still overflows when a texel crosses
// more surfaces (steps) than it holds — probed on memory larger than the
// declared capacity, so the probe itself cannot corrupt the heap. Returns
// the node count written into a 16-node buffer by 16 steps.
inline int probe_step_overflow() {
  const int capacity = 16;
  std::vector<DsmNode> mem(size_t(capacity) * 8);
  NodeBuffer buf{mem.data(), capacity};
  WedgeCompressor c(0.0f);
  float alpha = 0.0f;
  for (int i = 0; i < capacity; ++i) {
    float z = 1.0f + 0.01f * float(i);
    c.push(buf, z, alpha);
    alpha += 0.05f * (1.0f - alpha);
    c.step(buf, z, alpha);
  }
  c.finish(buf);
  return buf.count;
}

// Fragment lists of a view of `sb` (CPU producer); per-pixel counts.
struct ViewCounts {
  int width = 0, height = 0;
  std::vector<int> front, back;
  int total(int x, int y) const { return front[size_t(y) * width + x] + back[size_t(y) * width + x]; }
};
inline ViewCounts count_fragments(const SceneBuffers& sb, const PinholeView& view, uint32_t only_object = ~0u) {
  FragmentBuffers fb;
  cast_fragments(sb.view(), view, ObjectMask{}, fb);
  ViewCounts c;
  c.width = view.width;
  c.height = view.height;
  c.front.assign(size_t(view.width) * view.height, 0);
  c.back.assign(c.front.size(), 0);
  FragmentLists l = fb.lists();
  for (int y = 0; y < view.height; ++y)
    for (int x = 0; x < view.width; ++x)
      for (const Fragment& f : l.pixel(x, y)) {
        if (only_object != ~0u && sb.tri_object[frag_prim(f)] != only_object) continue;
        (frag_front(f) ? c.front : c.back)[size_t(y) * view.width + x] += 1;
      }
  return c;
}

}  // namespace stab
