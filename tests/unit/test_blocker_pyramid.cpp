// The blocker pyramid (hd/blocker_pyramid.h; issue 46 item 2): every cell
// the light pass built is the least opacity depth of its texels, computed
// again here from the node lists; a soft lookup's blocker search reads the
// same, to the bit, with the pyramid as without it and as a plain search
// that walks every ring texel (the pyramid only says where the search
// would count nothing, the first-node test which texels cannot reach)
// while it skips the search for a good share of the receivers; maps of lights without a size have none
// (they pay nothing for soft shadows). The shipped scenes with their
// lights given a size: the default scene's spot (RGB maps), the glass
// under the sun (clustered orthographic maps), the teapot's point light
// (cube faces), in every layout. The filter that follows the search reads
// each texel once where its taps share texels, with the same sum.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "cdsm/scene_io.h"
#include "common/pyramid_check.h"
#include "common/sanitized.h"
#include "hd/lights.h"
#include "unit_util.h"

using namespace cdsm;
using namespace cdsm_test;

namespace {

Scene shipped(const std::string& name) { return load_scene(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/" + name); }

// The scene's lights given a size (spots and points 0.15 m, the sun 2 degrees).
Scene sized(Scene s) {
  for (Light& l : s.lights) {
    if (l.type == LightType::Directional)
      l.angular_diameter_deg = 2.0f;
    else
      l.radius = 0.15f;
  }
  return s;
}

// Receivers over the scene's bounds and around each object (its box grown
// by half): points on planes (surfaces looked up at their plane: level,
// and tilted 45 and 70 degrees), and the same points as volume samples;
// and the objects' own surfaces (up to 400 triangles' centres each, at the
// triangle's plane, its own step left out), where blockers lie just in
// front of the plane beside the receiver.
std::vector<Receiver> receivers(const SceneBuffers& sb) {
  std::vector<Box3> boxes{sb.bounds};
  for (const Box3& b : sb.object_bounds) {
    const Vec3 grow = (b.hi - b.lo) * 0.25f;
    boxes.push_back(Box3{b.lo - grow, b.hi + grow});
  }
  std::vector<Receiver> out;
  for (const Box3& b : boxes)
    for (int k = 0; k < 4; ++k)
      for (int j = 0; j < 12; ++j)
        for (int i = 0; i < 12; ++i) {
          const Vec3 t{(float(i) + 0.5f) / 12.0f, (float(k) + 0.02f) / 4.0f, (float(j) + 0.5f) / 12.0f};
          const Vec3 p = b.lo + (b.hi - b.lo) * t;
          out.push_back(Receiver{p, {0, 1, 0}, kNoObject});
          out.push_back(Receiver{p, {0.70710678f, 0.70710678f, 0}, kNoObject});
          out.push_back(Receiver{p, {0, 0.34202014f, 0.93969262f}, kNoObject});
          out.push_back(Receiver{p, {0, 0, 0}, kNoObject});
        }
  const SceneView sv = sb.view();
  for (uint32_t o = 0; o < sv.objects.size(); ++o) {
    const ObjectData& od = sv.objects[o];
    const uint32_t step = std::max(1u, od.tri_count / 400u);
    for (uint32_t t = od.first_tri; t < od.first_tri + od.tri_count; t += step) {
      const Vec3 a = sv.tri_vertices[3 * t], b = sv.tri_vertices[3 * t + 1], c = sv.tri_vertices[3 * t + 2];
      const Vec3 n = cross(b - a, c - a);
      if (!(length(n) > 0.0f)) continue;
      out.push_back(Receiver{(a + b + c) * (1.0f / 3.0f), normalize(n), o});
    }
  }
  return out;
}

// The blocker search as hd/lights.h describes it, every ring texel walked:
// no pyramid, no first-node shortcut (penumbra_filter_radius must read
// the same).
float plain_search(const ShadowView& sv, const LightData& L, const DsmMap& m, const ViewProjection& pr,
                   const Receiver& r) {
  const float z = pr.depth;
  const PenumbraFrame f = penumbra_frame(m, pr);
  const float search =
      std::min(penumbra_radius(L, m, z, std::max(m.view.near, 1e-6f)), kPenumbraSearchTexels * f.texel);
  const int res = int(m.res);
  float weight = 0.0f, moment = 0.0f, ring = 0.0f;
  for (int k = 0; k < 2 + 8 * kPenumbraSearchRings; ++k) {
    if (k > 0 && (k - 1) % 8 == 0) {
      if (ring >= search) break;
      ring = std::min(k == 1 ? f.texel : 2.0f * ring, search);
    }
    const int d = k == 0 ? 0 : ((k - 1) % 8) * 2 + (((k - 1) / 8) & 1);
    const Vec2 dir = penumbra_direction(d);
    const Vec2 at = k == 0 ? Vec2{0.0f, 0.0f} : to_pixels(f, ring * dir.x, ring * dir.y);
    const int tx = int(std::floor(pr.u + at.x)), ty = int(std::floor(pr.v + at.y));
    if (tx < 0 || ty < 0 || tx >= res || ty >= res) continue;
    const float lim = blocker_limit(sv, L, m, pr, r, tx, ty);
    const TexelBlockers b =
        m.rgb ? texel_blockers<3>(sv.storage, m, tx, ty, lim) : texel_blockers<1>(sv.storage, m, tx, ty, lim);
    if (!(b.alpha > kPenumbraMinAlpha)) continue;
    const float off = angle_of(f, float(tx) + 0.5f - pr.u, float(ty) + 0.5f - pr.v);
    if (off > 2.0f * penumbra_radius(L, m, z, b.depth) + f.texel) continue;
    weight += b.alpha;
    moment += b.alpha * b.depth;
  }
  return weight > kPenumbraMinAlpha ? penumbra_radius(L, m, z, moment / weight) : 0.0f;
}

// The soft filter as hd/lights.h describes it, every tap's bilinear
// texels read for that tap (soft_map_alpha_in_colour, which reads each
// texel once for taps that share them, must give the same, to the bit).
Vec3 plain_filter(const ShadowView& sv, const LightData& L, const DsmMap& m, const ViewProjection& pr,
                  const Receiver& r) {
  const float radius = penumbra_filter_radius(sv, L, m, pr, r);
  const PenumbraFrame f = penumbra_frame(m, pr);
  const float reach = radius * max_pixels_per_angle(f);
  if (!(reach >= 0.5f)) return map_alpha_in_colour(sv, L, m, pr, r);
  const MapTaps taps = map_taps(sv, L, m, pr, r);
  const float spacing = std::max(1.0f, 2.0f * reach / float(sv.penumbra_taps));
  const float inv = 1.0f / spacing, out = reach + 0.5f * spacing;
  const int i0 = int(std::ceil((pr.u - out) * inv)), i1 = int(std::floor((pr.u + out) * inv));
  const int j0 = int(std::ceil((pr.v - out) * inv)), j1 = int(std::floor((pr.v + out) * inv));
  Vec3 sum{0, 0, 0};
  float weight = 0.0f;
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i) {
      ViewProjection at = pr;
      at.u = float(i) * spacing;
      at.v = float(j) * spacing;
      const float du = at.u - pr.u, dv = at.v - pr.v;
      if (du * du + dv * dv > out * out) continue;
      const float w = rim_weight(du, dv, angle_of(f, du, dv), radius, spacing);
      if (!(w > 0.0f)) continue;
      weight += w;
      if (sv.penumbra == Penumbra::Estimated && !blocks_receiver(sv, L, m, pr, f, r, taps, at)) continue;
      sum += map_alpha_in_colour(sv, L, m, at, r) * w;
    }
  const Vec3 soft = sum * (1.0f / weight);
  if (reach >= 1.5f) return soft;
  const float t = reach - 0.5f;
  return map_alpha_in_colour(sv, L, m, pr, r) * (1.0f - t) + soft * t;
}

// The storage without its pyramids (the GL lookup's view of it).
ShadowView without_pyramid(ShadowView sv) {
  sv.storage.grey.pyramid = {};
  sv.storage.rgb.pyramid = {};
  return sv;
}

struct Case {
  const char* scene;
  DsmLayout layout;
};

class BlockerPyramid : public ::testing::TestWithParam<Case> {};

// The case's scene, its lights given a size, in its layout at 256^2.
Scene case_scene(const Case& c) {
  Scene s = sized(shipped(c.scene));
  s.shadows.layout = c.layout;
  s.shadows.resolution = 256;
  return s;
}

TEST_P(BlockerPyramid, SearchReadsTheSameWithFewerWalks) {
  const Case c = GetParam();
  const Scene s = case_scene(c);
  const SystemFrame f(s);
  const ShadowView sv = f.frame.view(s.shadows), bare = without_pyramid(sv);
  const std::vector<Receiver> rs = receivers(f.sb);
  int lookups = 0, skipped = 0, blocked = 0;
  for (uint32_t li = 0; li < sv.lights.size(); ++li) {
    const LightData& L = sv.lights[li];
    ASSERT_GT(L.size, 0.0f);
    for (uint32_t mi = L.first_map; mi < L.first_map + L.map_count; ++mi) {
      const DsmMap& m = sv.maps[mi];
      const std::string what = std::string(c.scene) + " light " + std::to_string(li) + " map " + std::to_string(mi);
      ASSERT_TRUE(m.rgb ? has_pyramid(sv.storage.rgb, m) : has_pyramid(sv.storage.grey, m)) << what;
      const PyramidMismatch mismatch = pyramid_mismatch(sv.storage, m);
      EXPECT_EQ(mismatch.wrong, 0) << what << ": first " << mismatch.first;
      for (const Receiver& r : rs) {
        const ViewProjection pr = project(m.view, r.p);
        if (pr.axial <= 0.0f || pr.u < 0.0f || pr.v < 0.0f || pr.u >= float(m.res) || pr.v >= float(m.view.height))
          continue;
        const float with = penumbra_filter_radius(sv, L, m, pr, r), without = penumbra_filter_radius(bare, L, m, pr, r);
        const float plain = plain_search(sv, L, m, pr, r);
        ASSERT_EQ(std::memcmp(&with, &without, sizeof with), 0)
            << what << " at (" << r.p.x << ", " << r.p.y << ", " << r.p.z << "): " << with << " with the pyramid, "
            << without << " without";
        ASSERT_EQ(std::memcmp(&with, &plain, sizeof with), 0)
            << what << " at (" << r.p.x << ", " << r.p.y << ", " << r.p.z << "): " << with << ", every texel walked "
            << plain;
        const PenumbraFrame pf = penumbra_frame(m, pr);
        const float search =
            std::min(penumbra_radius(L, m, pr.depth, std::max(m.view.near, 1e-6f)), kPenumbraSearchTexels * pf.texel);
        const bool maybe = m.rgb ? blockers_within_reach<3>(sv, L, m, pr, r, pf, search)
                                 : blockers_within_reach<1>(sv, L, m, pr, r, pf, search);
        ++lookups;
        skipped += !maybe;
        blocked += with > 0.0f;
      }
    }
  }
  std::printf("[ pyramid  ] %s: %d lookups, %d with blockers, %d searches skipped\n", c.scene, lookups, blocked,
              skipped);
  ASSERT_GT(lookups, 500);
  EXPECT_GT(blocked, lookups / 50) << "receivers in penumbrae, where the pyramid must say yes";
  EXPECT_GT(skipped, lookups / 4) << "the pyramid skips the search for receivers with nothing in reach";
}

// The filter reads each texel once where taps share it (hd/lights.h
// soft_filter's two rows) and sums what a tap-by-tap filter sums, to the
// bit: estimated and fixed-kernel, at the default tap budget and at 5 and
// 32 (taps a texel apart and several apart), grey and RGB maps, surfaces and
// volume samples.
TEST_P(BlockerPyramid, FilterReadsEachTexelOnceWithTheSameSum) {
  const size_t kReceiverStride = CDSM_TEST_SANITIZED ? 12 : 3;  // every 3rd receiver (12th under a sanitizer)
  const Case c = GetParam();
  const Scene s = case_scene(c);
  const SystemFrame fr(s);
  const std::vector<Receiver> rs = receivers(fr.sb);
  int soft = 0;
  for (const Penumbra penumbra : {Penumbra::Estimated, Penumbra::FixedKernel})
    for (const int taps : {kPenumbraTaps, 5, 32}) {
      ShadowView sv = fr.frame.view(s.shadows);
      sv.penumbra = penumbra;
      sv.penumbra_taps = taps;
      for (uint32_t li = 0; li < sv.lights.size(); ++li) {
        const LightData& L = sv.lights[li];
        for (uint32_t mi = L.first_map; mi < L.first_map + L.map_count; ++mi) {
          const DsmMap& m = sv.maps[mi];
          for (size_t k = 0; k < rs.size(); k += kReceiverStride) {
            const Receiver& r = rs[k];
            const ViewProjection pr = project(m.view, r.p);
            if (pr.axial <= 0.0f || pr.u < 0.0f || pr.v < 0.0f || pr.u >= float(m.res) || pr.v >= float(m.view.height))
              continue;
            const Vec3 got = soft_map_alpha_in_colour(sv, L, m, pr, r), want = plain_filter(sv, L, m, pr, r);
            ASSERT_EQ(std::memcmp(&got, &want, sizeof got), 0)
                << c.scene << " map " << mi << " taps " << taps << " at (" << r.p.x << ", " << r.p.y << ", " << r.p.z
                << "): " << got.x << " " << got.y << " " << got.z << " against " << want.x << " " << want.y << " "
                << want.z;
            soft += !(got.x == map_alpha_in_colour(sv, L, m, pr, r).x);
          }
        }
      }
    }
  std::printf("[ filter   ] %s: %d lookups read other than the hard lookup\n", c.scene, soft);
  EXPECT_GT(soft, 100) << "receivers in penumbrae, where the filter sums taps";
}

INSTANTIATE_TEST_SUITE_P(Scenes, BlockerPyramid,
                         ::testing::Values(Case{"default.json", DsmLayout::Packed},
                                           Case{"default.json", DsmLayout::Chunked},
                                           Case{"sun_glass.json", DsmLayout::Fixed},
                                           Case{"teapot_omni.json", DsmLayout::Packed}),
                         [](const ::testing::TestParamInfo<Case>& i) {
                           std::string n = std::string(i.param.scene).substr(0, std::string(i.param.scene).find('.')) +
                                           "_" + std::to_string(int(i.param.layout));
                           return n;
                         });

// Hard lights build no pyramid: no memory, no launches for it.
TEST(BlockerPyramidCost, HardLightsHaveNone) {
  Scene s = shipped("default.json");
  for (Light& l : s.lights) l.radius = 0.0f;
  const SystemFrame hard(s);
  EXPECT_EQ(hard.frame.view(s.shadows).storage.grey.pyramid.size(), 0u);
  EXPECT_EQ(hard.frame.view(s.shadows).storage.rgb.pyramid.size(), 0u);
  for (const DsmBuildStats& b : hard.frame.map_stats) EXPECT_EQ(b.pyramid_bytes, 0u);
  s = sized(s);
  const SystemFrame soft(s);
  uint64_t bytes = 0, texels = 0;
  for (const DsmBuildStats& b : soft.frame.map_stats) {
    bytes += b.pyramid_bytes;
    texels += b.texels;
  }
  EXPECT_GT(bytes, 0u);
  EXPECT_LE(double(bytes) / double(texels), 4.0 / 3.0 + 0.05) << "a third of a float per texel";
}

}  // namespace
