// Backend parity (DESIGN.md §5, issue 16 item 9): one frame of a scene on
// two ShadowBackends — maps from the same fragment lists, the camera pass
// over the same camera fragments — compared texel by texel and pixel by
// pixel. Used with the exec backend on CPU threads (test_exec_backend.cpp,
// every build) and with the cuda backend (test_cuda_backend.cpp, on a GPU).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "backend/backend.h"
#include "cdsm/scene.h"
#include "cdsm/scene_io.h"
#include "common/system_frame.h"
#include "frame.h"

namespace cdsm::parity {

inline std::string scene_path(const std::string& name) {
  if (name == "default") return std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/default.json";
  return std::string(CDSM_GPU_SCENES_DIR) + "/" + name + ".json";
}

// A scene of the GPU suite, made small enough for CI (res x res maps, w x h camera).
inline Scene load(const std::string& name, int res, int w, int h) {
  Scene s = load_scene(scene_path(name));
  s.shadows.resolution = res;
  s.camera.width = w;
  s.camera.height = h;
  return s;
}

// One frame of `scene` on `backend`, built by a ShadowSystem that owns it
// (CPU-cast fragment lists): every map, then the camera pass. `frame` is a
// copy of the snapshot's (its maps live in the system's backend).
struct Frame {
  std::unique_ptr<ShadowSystem> system;
  ShadowFrame frame;
  std::vector<float> rgb;
  FrameStats frame_stats;            // render()'s: stage and kernel times, walk counters
  std::vector<DsmBuildStats> stats;  // per map
  ShadowBackend& backend() { return SystemHooks::backend(*system); }
};

inline void run(const Scene& scene, std::unique_ptr<ShadowBackend> backend, Frame& f) {
  f.system = std::make_unique<ShadowSystem>(cdsm_test::cpu_system_options());
  SystemHooks::wrap_backend(*f.system, [&](std::unique_ptr<ShadowBackend>) { return std::move(backend); });
  sync_scene(*f.system, scene);
  f.rgb = f.system->render(&f.frame_stats).rgb;
  f.frame = FrameSnapshot(*f.system).frame();
  f.stats = f.frame.map_stats;
}

// Node lists of texel (tx, ty) of a map from host-readable storage (any layout, either kind).
struct TexelList {
  std::vector<float> z, a;  // a: one value per node (grey) or three (RGB)
};
inline TexelList texel_list(const DsmStorage& st, const DsmMap& m, int tx, int ty) {
  TexelList t;
  if (m.rgb) {
    std::vector<DsmNodeRgb> n(8192);
    const uint32_t c = read_texel(st, m, tx, ty, n.data(), uint32_t(n.size()));
    for (uint32_t i = 0; i < c && i < n.size(); ++i) {
      t.z.push_back(n[i].z);
      t.a.insert(t.a.end(), {n[i].alpha.x, n[i].alpha.y, n[i].alpha.z});
    }
  } else {
    std::vector<DsmNode> n(8192);
    const uint32_t c = read_texel(st, m, tx, ty, n.data(), uint32_t(n.size()));
    for (uint32_t i = 0; i < c && i < n.size(); ++i) {
      t.z.push_back(n[i].z);
      t.a.push_back(n[i].alpha);
    }
  }
  return t;
}

// alpha of a texel's node list at depth z (per channel for RGB).
inline std::vector<float> alpha_at(const DsmStorage& st, const DsmMap& m, int tx, int ty, float z) {
  if (m.rgb) {
    const Vec3 a = texel_alpha<3>(st, m, tx, ty, z);
    return {a.x, a.y, a.z};
  }
  return {texel_alpha<1>(st, m, tx, ty, z)};
}

struct MapComparison {
  uint64_t texels = 0, identical = 0;  // texels 0 (nothing compared): identical / texels is NaN, which fails any bound
  uint64_t nodes_a = 0, nodes_b = 0;
  double max_alpha_diff = 0.0;  // over every node depth of either list (and just before it)
  std::string first_difference;
};

// Whether `st` holds map `m`'s texels (headers, or fixed slots), so reading them stays inside it.
inline bool holds_texels(const DsmStorage& st, const DsmMap& m) {
  const uint64_t texels = uint64_t(m.texel_offset) + uint64_t(m.res) * m.res;
  if (st.layout == DsmLayout::Fixed) return (m.rgb ? st.rgb.nodes.size() : st.grey.nodes.size()) >= texels * st.layers;
  return (m.rgb ? st.rgb.texels.size() : st.grey.texels.size()) >= texels;
}

// Texel by texel: identical node lists, and the largest |alpha_a - alpha_b|
// at every node depth of either (the functions are piecewise linear
// between them, so that is the sup over z). Maps of different sizes or
// kinds, maps of no texels and storage that lacks a map's texels are a test
// failure: nothing was compared. So are two maps without a single node,
// unless `may_be_empty` (a frame's maps compared one by one: a point
// light's cube face that sees no caster holds none, rightly; the caller
// then fails a frame whose maps hold no node at all).
inline MapComparison compare_maps(const DsmStorage& sa, const DsmMap& ma, const DsmStorage& sb, const DsmMap& mb,
                                  bool may_be_empty = false) {
  MapComparison r;
  const auto kind = [](const DsmMap& m) { return std::to_string(m.res) + "^2 " + (m.rgb ? "RGB" : "grey"); };
  if (ma.res == 0 || ma.res != mb.res || ma.rgb != mb.rgb) {
    ADD_FAILURE() << "compare_maps: a map of " << kind(ma) << " against one of " << kind(mb) << ": nothing to compare";
    return r;
  }
  for (int side = 0; side < 2; ++side) {
    const DsmStorage& st = side ? sb : sa;
    const DsmMap& m = side ? mb : ma;
    if (!holds_texels(st, m)) {
      ADD_FAILURE() << "compare_maps: the " << (side ? "second" : "first") << " storage lacks its map's texels ("
                    << kind(m) << " from texel " << m.texel_offset << ")";
      return r;
    }
  }
  const int res = int(ma.res);
  for (int ty = 0; ty < res; ++ty)
    for (int tx = 0; tx < res; ++tx) {
      ++r.texels;
      const TexelList a = texel_list(sa, ma, tx, ty), b = texel_list(sb, mb, tx, ty);
      r.nodes_a += a.z.size();
      r.nodes_b += b.z.size();
      if (a.z == b.z && a.a == b.a) {
        ++r.identical;
        continue;
      }
      if (r.first_difference.empty())
        r.first_difference = "texel (" + std::to_string(tx) + ", " + std::to_string(ty) +
                             "): " + std::to_string(a.z.size()) + " vs " + std::to_string(b.z.size()) + " nodes";
      std::vector<float> zs = a.z;
      zs.insert(zs.end(), b.z.begin(), b.z.end());
      for (float z : zs)
        for (float zz : {z, std::nextafter(z, 0.0f)}) {
          const std::vector<float> x = alpha_at(sa, ma, tx, ty, zz), y = alpha_at(sb, mb, tx, ty, zz);
          for (size_t k = 0; k < x.size(); ++k)
            r.max_alpha_diff = std::max(r.max_alpha_diff, double(std::fabs(x[k] - y[k])));
        }
    }
  if (r.nodes_a == 0 && r.nodes_b == 0 && !may_be_empty)
    ADD_FAILURE() << "compare_maps: neither map (" << kind(ma) << ") holds a node: nothing was compared";
  return r;
}

// PSNR in dB of two linear images (values clamped to [0, 1]); inf when equal.
// Images of different sizes, or empty ones, are a test failure (and -inf):
// nothing was compared.
inline double psnr(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.empty() || a.size() != b.size()) {
    ADD_FAILURE() << "psnr: images of " << a.size() << " and " << b.size()
                  << " values: " << (a.empty() ? "empty, nothing to compare" : "different sizes");
    return -INFINITY;
  }
  double se = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    const double d = double(std::min(std::max(a[i], 0.0f), 1.0f)) - double(std::min(std::max(b[i], 0.0f), 1.0f));
    se += d * d;
  }
  const double mse = se / double(a.size());
  return mse == 0.0 ? INFINITY : 10.0 * std::log10(1.0 / mse);
}

}  // namespace cdsm::parity
