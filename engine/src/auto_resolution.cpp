// Auto resolution: each map's texels per side from the screen (auto_resolution.h).
#include "auto_resolution.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "hd/bvh.h"
#include "hd/lights.h"
#include "scene/scene_buffers.h"

namespace cdsm {
namespace {

constexpr float kSeenWeight = 0.05f;  // surfaces the eye sees with less weight are not receivers
constexpr int kUnseenRung = 4;        // 64 texels: a map no sampled receiver lies in
constexpr double kHysteresis = 0.75;  // rungs a wanted resolution moves past the kept one before it changes
// Auto clusters: maps serving fewer of the sampled receivers than this share
// do not decide a light's cluster count.
constexpr double kDecidingShare = 0.005;

// The map's content half-widths (its window less the one-texel guard band
// on each side, at its planned resolution).
float content_half(float half, int res) { return half * float(res - 2) / float(res); }

// The resolution (guard band included) at which a texel of `v` at `axial`
// is `pixel / tpp` across.
double wanted_texels(const PinholeView& v, float axial, float pixel, float tpp) {
  const double half = content_half(v.tan_half_x, v.width);
  return double(tpp) * 2.0 * half * (is_orthographic(v) ? 1.0 : double(axial)) / double(pixel) + 2.0;
}

// Whether map k of light L serves the receiver at p (its lookups read it):
// inside the window, beyond the near plane (a receiver in front of every
// caster of a focused map needs none of its texels), and for cube faces the
// face the lookup picks.
bool serves(const LightData& L, uint32_t k, const PinholeView& v, Vec3 p) {
  if (L.map_mode == MapMode::CubeFaces && L.map_count == 6 && uint32_t(cube_face_of(p - L.position)) != k) return false;
  const ViewProjection pr = project(v, p);
  if (!(pr.axial > 0.0f) || !(pr.depth > v.near)) return false;
  return pr.u >= 1.0f && pr.v >= 1.0f && pr.u <= float(v.width) - 1.0f && pr.v <= float(v.height) - 1.0f;
}

// The resolution each receiver map k of light L serves wants (wanted_texels).
std::vector<double> wanted_by_receivers(const ShadowSettings& s, const std::vector<CameraReceiver>& receivers,
                                        const LightData& L, uint32_t k, const PinholeView& v) {
  std::vector<double> out;
  for (const CameraReceiver& r : receivers)
    if (serves(L, k, v, r.p)) out.push_back(wanted_texels(v, project(v, r.p).axial, r.pixel, s.texels_per_pixel));
  return out;
}

int top_rung(const ShadowSettings& s) {
  int top = 0;  // the highest rung within max_resolution
  while (resolution_rung(top + 1) <= s.max_resolution) ++top;
  return top;
}

double quantile(std::vector<double>& v, double q) {
  if (v.empty()) return 0.0;
  const size_t i = std::min(v.size() - 1, size_t(q * double(v.size())));
  std::nth_element(v.begin(), v.begin() + ptrdiff_t(i), v.end());
  return v[i];
}

}  // namespace

int32_t resolution_rung(int k) {
  return int32_t(std::lround(double(kSmallestAutoResolution) * std::pow(2.0, 0.5 * double(k))));
}

double rung_position(double texels) { return 2.0 * std::log2(std::max(texels, 1.0) / double(kSmallestAutoResolution)); }

std::vector<CameraReceiver> sample_camera_receivers(const SceneBuffers& sb, const Camera& camera, int samples) {
  const PinholeView cam = camera_view(camera);
  const SceneView s = sb.view();
  const int w = cam.width, h = cam.height;
  const double cell = std::max(1.0, std::sqrt(double(w) * double(h) / double(std::max(samples, 1))));
  const int gx = std::max(1, int(std::lround(w / cell))), gy = std::max(1, int(std::lround(h / cell)));
  // The world size of a pixel per unit of axial distance (orthographic: the size).
  const float pixel_per_axial = 2.0f * cam.tan_half_y / float(h);
  std::vector<std::vector<CameraReceiver>> rows(static_cast<size_t>(gy));
  tbb::parallel_for(0, gy, [&](int y) {
    struct Hit {
      float t;
      uint32_t tri;
    };
    std::vector<Hit> hits;
    for (int x = 0; x < gx; ++x) {
      const float u = (float(x) + 0.5f) * float(w) / float(gx), v = (float(y) + 0.5f) * float(h) / float(gy);
      const Vec3 dir = normalize(view_direction(cam, u, v)), org = view_origin(cam, u, v);
      const float c = dot(dir, cam.forward);
      if (!(c > 0.0f)) continue;
      hits.clear();
      for_each_hit(s, ObjectMask{}, org, dir, cam.near / c, cam.far / c, [&](uint32_t tri, const TriHit& th) {
        hits.push_back({th.t, tri});
      });
      std::sort(hits.begin(), hits.end(), [](const Hit& a, const Hit& b) { return a.t < b.t; });
      float seen = 1.0f;  // what the surfaces so far let through to the eye
      for (const Hit& hit : hits) {
        const ObjectData& o = s.objects[s.tri_object[hit.tri]];
        if (passes_all(o)) {
          // A medium's boundary: where the samples its march shades begin.
          if (o.interior != InteriorKind::None)
            rows[size_t(y)].push_back({org + dir * hit.t, pixel_per_axial * (is_orthographic(cam) ? 1.0f : hit.t * c)});
          continue;
        }
        if (seen * o.opacity >= kSeenWeight) {
          const float axial = hit.t * c;
          rows[size_t(y)].push_back({org + dir * hit.t, pixel_per_axial * (is_orthographic(cam) ? 1.0f : axial)});
        }
        seen *= 1.0f - max_channel(o.absorb);
        if (seen < kSeenWeight) break;
      }
    }
  });
  std::vector<CameraReceiver> out;
  for (const auto& r : rows) out.insert(out.end(), r.begin(), r.end());
  return out;
}

double reachable_rung(const ShadowSettings& s) {
  return s.auto_resolution() ? double(top_rung(s)) : rung_position(double(s.resolution));
}

LightDemand light_demand(const ShadowSettings& s, const std::vector<CameraReceiver>& receivers, const LightSetup& setup,
                         uint32_t li) {
  const LightData& L = setup.lights[li];
  const double deciding = kDecidingShare * double(receivers.size());
  const int top = top_rung(s);
  LightDemand d;
  for (uint32_t k = 0; k < L.map_count; ++k) {
    std::vector<double> w = wanted_by_receivers(s, receivers, L, k, setup.maps[L.first_map + k].view);
    const double median = w.empty() ? 0.0 : quantile(w, 0.5);
    const double side = std::isfinite(median) ? median : std::numeric_limits<double>::max();
    if (!w.empty() && double(w.size()) >= deciding) d.wanted_texels = std::max(d.wanted_texels, side);
    double res = double(s.resolution);
    if (s.auto_resolution()) {
      const double pos = w.empty() ? double(kUnseenRung) : rung_position(side);
      res = double(resolution_rung(std::clamp(int(std::lround(std::clamp(pos, -1.0, double(top) + 1.0))), 0, top)));
    }
    d.texels += res * res;
  }
  return d;
}

CountChoice pick_cluster_count(const std::vector<CountTrial>& t, double reach, int kept) {
  CountChoice c;
  if (t.empty()) return c;
  double best = t[0].need;
  for (const CountTrial& x : t) best = std::min(best, x.need);
  const double bound = best <= reach ? reach : best + 1.0;
  auto cost = [](const CountTrial& x) { return x.texels * x.maps; };
  // Whether `a` saves enough against `b` to be worth its maps (factor 2:
  // twice that, 1/2: half).
  auto saves = [&](const CountTrial& a, const CountTrial& b, double factor) {
    return cost(a) * factor < cost(b) && (b.texels - a.texels) >= factor * kMinTexelSaving;
  };
  while (t[c.pick].need > bound) ++c.pick;
  bool cheaper = false;
  for (size_t k = c.pick + 1; k < t.size(); ++k)
    if (t[k].need <= bound && saves(t[k], t[c.pick], 1.0)) {
      c.pick = k;
      cheaper = true;
    }
  c.reason = best > reach ? "none reaches the density: the fewest within a ladder step of the best"
             : cheaper    ? "more maps that reach the density with fewer texels x maps"
                          : "the fewest that reach the density";
  if (kept >= 0 && size_t(kept) < t.size() && size_t(kept) != c.pick) {
    const CountTrial& k = t[size_t(kept)];
    const CountTrial& p = t[c.pick];
    bool stay = k.need <= bound + kHysteresis;
    if (size_t(kept) < c.pick)  // more maps picked: because the kept count no longer reaches, or to save texels
      stay = stay && (k.need > bound || !saves(p, k, 2.0));
    else  // fewer maps picked: the kept count stays while the pick reaches narrowly or it still saves half enough
      stay = stay && (p.need > bound - kHysteresis || saves(k, p, 0.5));
    if (stay) {
      c.pick = size_t(kept);
      c.reason = "kept from the last frame (hysteresis)";
    }
  }
  return c;
}

void choose_map_resolutions(const ShadowSettings& s, const std::vector<CameraReceiver>& receivers,
                            const std::vector<std::vector<int>>& previous, double budget_bytes, double bytes_per_texel,
                            LightSetup& setup, std::vector<std::vector<int>>& rungs,
                            std::vector<MapResolutionStats>& stats) {
  const int top = top_rung(s);
  rungs.assign(setup.lights.size(), {});
  stats.assign(setup.maps.size(), MapResolutionStats{});
  std::vector<int> rung(setup.maps.size(), kUnseenRung);
  std::vector<std::vector<double>> wanted(setup.maps.size());  // per map: per receiver it serves
  // Each map's rung from its receivers (hysteresis: the rung it had).
  for (uint32_t li = 0; li < setup.lights.size(); ++li) {
    const LightData& L = setup.lights[li];
    const bool kept = li < previous.size() && previous[li].size() == L.map_count;
    for (uint32_t k = 0; k < L.map_count; ++k) {
      const uint32_t m = L.first_map + k;
      const MapPlan& plan = setup.maps[m];
      MapResolutionStats& st = stats[m];
      st.light = li;
      wanted[m] = wanted_by_receivers(s, receivers, L, k, plan.view);
      st.receivers = uint32_t(wanted[m].size());
      st.limit = "not seen";
      if (wanted[m].empty()) continue;
      // Kept finite and within a step of the ladder (a degenerate receiver).
      double pos = rung_position(quantile(wanted[m], 0.5));
      if (!(pos > -1.0)) pos = -1.0;
      if (!(pos < double(top) + 1.0)) pos = double(top) + 1.0;
      rung[m] = int(std::lround(pos));
      if (kept && previous[li][k] >= 0 && std::fabs(pos - double(previous[li][k])) <= kHysteresis)
        rung[m] = previous[li][k];
      st.limit = "target";
      if (rung[m] >= top && pos > double(top)) st.limit = "ladder top";
      if (rung[m] <= 0 && pos < 0.0) st.limit = "ladder bottom";
    }
  }
  for (int& r : rung) r = std::clamp(r, 0, top);
  // The memory budget: the maps serving the fewest receivers (covering the
  // fewest pixels) step down first, one rung at a time.
  auto bytes = [&] {
    double b = 0.0;
    for (int r : rung) b += double(resolution_rung(r)) * double(resolution_rung(r)) * bytes_per_texel;
    return b;
  };
  while (bytes() > budget_bytes) {
    int pick = -1;
    for (size_t m = 0; m < rung.size(); ++m)
      if (rung[m] > 0 && (pick < 0 || stats[m].receivers < stats[size_t(pick)].receivers ||
                          (stats[m].receivers == stats[size_t(pick)].receivers && rung[m] > rung[size_t(pick)])))
        pick = int(m);
    if (pick < 0) break;  // every map at the ladder's bottom
    --rung[size_t(pick)];
    stats[size_t(pick)].limit = "budget";
  }
  // Each view at its resolution, the window widened so that its guard band
  // stays one texel; the density its receivers see: a texel of `res` is
  // (wanted - 2) / (res - 2) times the one they want (pixel / tpp).
  for (uint32_t li = 0; li < setup.lights.size(); ++li) {
    const LightData& L = setup.lights[li];
    rungs[li].assign(L.map_count, 0);
    for (uint32_t k = 0; k < L.map_count; ++k) {
      const uint32_t m = L.first_map + k;
      const int res = resolution_rung(rung[m]);
      rungs[li][k] = rung[m];
      PinholeView& v = setup.maps[m].view;
      const float grow = float(res) / float(res - 2) * float(v.width - 2) / float(v.width);
      v.tan_half_x *= grow;
      v.tan_half_y *= grow;
      v.width = v.height = res;
      MapResolutionStats& st = stats[m];
      st.resolution = res;
      for (double& w : wanted[m]) w = double(s.texels_per_pixel) * double(res - 2) / (w - 2.0);
      st.texels_per_pixel_median = quantile(wanted[m], 0.5);
      st.texels_per_pixel_p5 = quantile(wanted[m], 0.05);
    }
  }
}

}  // namespace cdsm
