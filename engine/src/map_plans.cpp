// Step 1 of a frame (frame_steps.h): which maps it needs — each light's
// views (cube faces, parallel splits, clusters with their hysteresis).
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "auto_resolution.h"
#include "cdsm/fields.h"
#include "cluster/focus.h"
#include "memory_budget.h"
#include "frame_steps.h"
#include "scene_compile.h"
#include "stopwatch.h"

namespace cdsm {
namespace {

// Camera rays sampled for auto resolution (about one per 9 x 9 pixels at 720 x 480).
constexpr int kAutoSamples = 4096;

// Light li's maps become `mine` (read with `mode`); the other lights' maps
// keep their order, every light's first_map follows.
void replace_light_maps(LightSetup& ls, size_t li, const std::vector<MapPlan>& mine, MapMode mode) {
  std::vector<MapPlan> all;
  for (size_t l = 0; l < ls.lights.size(); ++l) {
    uint32_t first = uint32_t(all.size());
    if (l == li) {
      for (const MapPlan& p : mine) all.push_back(p);
      ls.lights[l].map_count = uint32_t(mine.size());
      ls.lights[l].map_mode = mode;
    } else {
      for (uint32_t k = 0; k < ls.lights[l].map_count; ++k) all.push_back(ls.maps[ls.lights[l].first_map + k]);
    }
    ls.lights[l].first_map = first;
  }
  ls.maps.swap(all);
}

// Replaces the light's unclustered maps with one focused map per cluster
// (at most m clusters).
void cluster_light(const FrameInputs& in, size_t li, const LightClusters* previous, int m, LightSetup& ls,
                   LightClusters& lc) {
  lc.count = m;
  const SceneBuffers& sb = *in.scene;
  const ShadowSettings& s = in.settings;
  std::vector<cluster::Caster> casters;
  for (uint32_t o = 0; o < sb.objects.size(); ++o)
    if (sb.objects[o].flags & kObjCastsShadows) casters.push_back({int32_t(o), sb.object_bounds[o]});
  if (casters.empty()) {
    lc.fallback_reason = "no shadow casters";
    return;
  }
  cluster::ClusterSettings cs;
  cs.d0 = s.d0;
  cs.max_clusters = m;
  cs.resolution = s.planned_resolution();
  PinholeView cam = camera_view(in.camera);
  const cluster::LightShape light = light_shape(in.lights[li]);
  cs.min_near = cluster::near_clamp(light, sb.bounds);
  if (previous && previous->clustered)
    lc.clustering = cluster::update_clusters(light, cam, sb.bounds, casters, cs, previous->clustering);
  else
    lc.clustering = cluster::cluster_casters(light, cam, sb.bounds, casters, cs);
  size_t views = lc.clustering.view_count();
  if (views == 0 || views > size_t(kMaxMapsPerLight)) {
    lc.fallback_reason = views == 0 ? "no cluster reaches the light"
                                    : std::to_string(views) + " focused maps exceed the limit of " +
                                          std::to_string(kMaxMapsPerLight) + " per light";
    return;
  }
  // Swap this light's maps for the clusters' focused maps.
  std::vector<MapPlan> mine;
  for (const cluster::Cluster& c : lc.clustering.clusters)
    for (const PinholeView& v : c.views) {
      MapPlan p{v, uint32_t(li), {}};
      for (int32_t id : c.members) p.members.push_back(uint32_t(id));
      mine.push_back(std::move(p));
    }
  replace_light_maps(ls, li, mine, MapMode::Combine);
  lc.clustered = true;
}

// Auto clusters (ShadowSettings::auto_clusters): light li clustered with
// each count 1, 2, 4, ... up to cluster_limit, the count taken by
// pick_cluster_count (auto_resolution.h) from what each one's maps want;
// the previous frame's count reuses its clusters' hysteresis.
void choose_cluster_count(const FrameInputs& in, size_t li, const std::vector<CameraReceiver>& receivers,
                          const LightClusters* previous, LightSetup& ls, LightClusters& lc) {
  const ShadowSettings& s = in.settings;
  struct Trial {
    int m;
    LightSetup setup;
    LightClusters clusters;
    LightDemand demand;
    double need;  // rung position the neediest map wants (-inf: none seen)
  };
  std::vector<Trial> trials;
  const int prev = previous ? previous->count : 0;
  for (int m = 1;; m = std::min(2 * m, s.cluster_limit)) {
    Trial t{m, ls, {}, {}, 0.0};
    t.clusters.count = 1;
    if (m > 1) cluster_light(in, li, m == prev ? previous : nullptr, m, t.setup, t.clusters);
    t.demand = light_demand(s, receivers, t.setup, uint32_t(li));
    const double side = t.demand.wanted_texels;
    t.need = side > 0.0 ? rung_position(side) : -std::numeric_limits<double>::infinity();
    trials.push_back(std::move(t));
    if (m >= s.cluster_limit) break;
  }
  const double reach = reachable_rung(s) + 0.5;
  std::vector<CountTrial> options;
  int kept = -1;
  for (size_t k = 0; k < trials.size(); ++k) {
    options.push_back({trials[k].need, trials[k].demand.texels, double(trials[k].setup.lights[li].map_count)});
    if (trials[k].m == prev) kept = int(k);
  }
  const CountChoice choice = pick_cluster_count(options, reach, kept);
  Trial& chosen = trials[choice.pick];
  for (const Trial& t : trials)
    chosen.clusters.count_trials.push_back(
        {t.m, t.setup.lights[li].map_count, t.demand.wanted_texels, t.demand.texels, t.need <= reach});
  chosen.clusters.count_reason = choice.reason;
  ls = std::move(chosen.setup);
  lc = std::move(chosen.clusters);
}

// Replaces a spot or directional light's map by parallel-split maps (near to far) along
// the camera's view: slice i of the view frustum by the practical split
// scheme (half logarithmic, half uniform), a light frustum focused on the
// slice's box within the scene, holding every caster between the light and
// the scene's far end.
void split_light(const FrameInputs& in, size_t li, LightSetup& ls) {
  const SceneBuffers& sb = *in.scene;
  const cluster::LightShape light = light_shape(in.lights[li]);
  const int m = in.settings.parallel_splits;
  if (ls.lights[li].map_mode != MapMode::Combine || ls.lights[li].map_count != 1) return;  // spots, directional
  PinholeView cam = camera_view(in.camera);
  // The view's depth range inside the scene box.
  float far = 0.0f;
  for (int c = 0; c < 8; ++c) far = std::max(far, dot(sb.bounds.corner(c) - cam.eye, cam.forward));
  far = std::min(far, cam.far);
  const float near = cam.near;
  if (!(far > near)) return;
  const MapPlan base = ls.maps[ls.lights[li].first_map];
  cluster::FocusParams fp;
  fp.resolution = in.settings.planned_resolution();
  std::vector<MapPlan> mine;
  for (int i = 0; i < m; ++i) {
    auto split_at = [&](int k) {
      float t = float(k) / float(m);
      return 0.5f * near * std::pow(far / near, t) + 0.5f * (near + (far - near) * t);
    };
    float z0 = split_at(i), z1 = split_at(i + 1);
    Box3 slice;
    for (float z : {z0, z1})
      for (int c = 0; c < 4; ++c) {
        float sx = (c & 1) ? cam.tan_half_x : -cam.tan_half_x, sy = (c & 2) ? cam.tan_half_y : -cam.tan_half_y;
        slice.grow(cam.eye + (cam.forward + cam.right * sx + cam.up * sy) * z);
      }
    slice.lo = vmax(slice.lo, sb.bounds.lo);
    slice.hi = vmin(slice.hi, sb.bounds.hi);
    if (slice.empty()) continue;
    cluster::FocusResult f = cluster::focus_cluster(light, {slice}, fp);
    if (f.views.size() != 1) continue;
    MapPlan p{f.views[0], uint32_t(li), base.members};
    // Every caster between the light and the slice: the whole map's depth
    // range (orthographic maps: from the whole map's window plane too).
    if (is_orthographic(p.view))
      p.view.eye = p.view.eye + p.view.forward * dot(base.view.eye - p.view.eye, p.view.forward);
    p.view.near = base.view.near;
    p.view.far = base.view.far;
    mine.push_back(std::move(p));
  }
  if (mine.empty()) return;
  mine.push_back(base);  // the whole cone last: points outside every split
  replace_light_maps(ls, li, mine, MapMode::FirstContaining);
}

// What a light's clusters depend on besides the casters: a change drops
// the hysteresis (clusters are recomputed from scratch).
uint64_t light_signature(const Light& l, const ShadowSettings& s) {
  Fnv1a h;
  hash_fields(h, l, kAffectsClusters);  // type, position, direction, outer cone (fields.h)
  hash_fields(h, s, kAffectsClusters);
  return h.h;
}

}  // namespace

// Step 1: which maps this frame needs — each light's views (cube faces,
// parallel splits, clusters with their hysteresis), and the light states
// the cache keeps for the next frame. Last frame's retired maps go first.
std::unordered_map<uint64_t, MapCache::LightState> plan_maps(const FrameInputs& in, ShadowBackend& backend,
                                                             MapCache& cache, ShadowFrame& frame) {
  const ShadowSettings& s = in.settings;
  frame.setup = setup_lights(in.lights, *in.scene, s.planned_resolution());
  frame.clusters.resize(in.lights.size());
  // Last frame's replaced maps (kept for the popping probe) go now.
  backend.free_maps(cache.retired);
  frame.freed += uint32_t(cache.retired.size());
  cache.retired.clear();
  if (s.parallel_splits > 1) {
    for (size_t li = 0; li < in.lights.size(); ++li) split_light(in, li, frame.setup);
    frame.clusters.assign(in.lights.size(), LightClusters{});
    for (LightClusters& lc : frame.clusters) lc.fallback_reason = "parallel-split maps (baseline)";
  }
  std::vector<CameraReceiver> receivers;
  if (s.auto_resolution() || (s.auto_clusters() && s.parallel_splits <= 1))
    receivers = sample_camera_receivers(*in.scene, in.camera, kAutoSamples);
  if (s.parallel_splits <= 1 && s.clustering()) {
    auto t0 = Clock::now();
    for (size_t li = 0; li < in.lights.size(); ++li) {
      auto it = cache.lights.find(in.light_ids[li]);
      const bool keep = it != cache.lights.end() && it->second.signature == light_signature(in.lights[li], s);
      const LightClusters* previous = keep ? &it->second.clusters : nullptr;
      if (s.auto_clusters())
        choose_cluster_count(in, li, receivers, previous, frame.setup, frame.clusters[li]);
      else
        cluster_light(in, li, previous, s.max_clusters, frame.setup, frame.clusters[li]);
    }
    frame.cluster_ms = ms_since(t0);
  }
  std::vector<std::vector<int>> rungs(in.lights.size());
  if (s.auto_resolution()) {
    std::vector<std::vector<int>> previous(in.lights.size());
    for (size_t li = 0; li < in.lights.size(); ++li) {
      auto it = cache.lights.find(in.light_ids[li]);
      if (it != cache.lights.end()) previous[li] = it->second.rungs;
    }
    choose_map_resolutions(s, receivers, previous, in.map_texel_budget, map_bytes_per_texel(s), frame.setup, rungs,
                           frame.resolutions);
  } else {
    frame.resolutions.assign(frame.setup.maps.size(), MapResolutionStats{});
    for (size_t k = 0; k < frame.setup.maps.size(); ++k) {
      frame.resolutions[k].light = frame.setup.maps[k].light;
      frame.resolutions[k].resolution = frame.setup.maps[k].view.width;
    }
  }
  warn_subtexel_casters(in, frame);
  std::unordered_map<uint64_t, MapCache::LightState> lights;
  for (size_t li = 0; li < in.lights.size(); ++li)
    lights[in.light_ids[li]] = {frame.clusters[li], light_signature(in.lights[li], s), rungs[li]};
  return lights;
}

}  // namespace cdsm
