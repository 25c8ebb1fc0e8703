#include "frame.h"

#include "cdsm/fields.h"
#include "cdsm/method_params.h"
#include "cluster/focus.h"
#include "backend/backend.h"
#include "scene_compile.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <unordered_map>

namespace cdsm {
namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

Vec3 any_perpendicular(Vec3 d) {
  Vec3 a = std::fabs(d.y) < 0.9f ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
  return normalize(cross(cross(d, a), d)) * -1.0f;
}

using Hasher = Fnv1a;

uint64_t hash_light(const LightData& l) {
  Hasher h;
  h.pod(l.position);
  h.pod(l.type);
  h.pod(l.direction);
  h.pod(l.cos_outer);
  return h.h;
}

std::vector<uint32_t> mask_words(const std::vector<uint32_t>& members, size_t object_count) {
  std::vector<uint32_t> w((object_count + 31) / 32, 0u);
  for (uint32_t o : members) w[o >> 5] |= 1u << (o & 31u);
  return w;
}

// Depth range of a light: far over the scene box; near half the distance
// to the closest caster box that does not hold the light, not a fraction of
// far — one huge object must not push near past the small ones near the
// light. (Near only clips surfaces: depths are radial floats, there is no
// depth buffer, and media boundaries before near are kept anyway.)
void light_range(const Light& l, const SceneBuffers& sb, float& near, float& far) {
  far = 0.0f;
  for (int c = 0; c < 8; ++c) far = std::max(far, length(sb.bounds.corner(c) - l.position));
  far = far * 1.01f + 1e-3f;
  float closest = far;
  for (size_t o = 0; o < sb.objects.size(); ++o) {
    if (!(sb.objects[o].flags & kObjCastsShadows) || sb.object_bounds[o].empty()) continue;
    const Box3& b = sb.object_bounds[o];
    float d = length(vmax(vmax(b.lo - l.position, l.position - b.hi), Vec3{0, 0, 0}));
    if (d > 0.0f) closest = std::min(closest, d);
  }
  near = std::max(0.5f * closest, 1e-6f);
}

}  // namespace

LightData light_data(const Light& l) {
  LightData ld{};
  ld.position = l.type == LightType::Directional ? Vec3{0, 0, 0} : l.position;
  ld.type = l.type;
  ld.direction = normalize(l.direction);
  const float k = 3.14159265f / 180.0f;
  ld.cos_outer = l.type == LightType::Spot ? std::cos(l.outer_cone_deg * k) : -2.0f;
  ld.cos_inner = l.type == LightType::Spot ? std::cos(std::min(l.inner_cone_deg, l.outer_cone_deg) * k) : -1.0f;
  if (ld.cos_inner <= ld.cos_outer) ld.cos_inner = ld.cos_outer + 1e-6f;
  ld.radiance = l.color * l.intensity;
  ld.size = l.type == LightType::Directional ? std::tan(0.5f * l.angular_diameter_deg * k) : l.radius;
  return ld;
}

FragmentProducer cpu_fragment_producer(const SceneView& scene) {
  return [scene](ShadowBackend& backend, const PinholeView& view, ObjectMask mask) {
    FragmentBuffers fb;
    cast_fragments(scene, view, mask, fb);
    return backend.adopt_lists(std::move(fb));
  };
}

PinholeView camera_view(const Camera& cam) {
  // The eye's axes are the view matrix's rows: one basis for the camera
  // pass, the clustering and an engine's GL view (Camera::view_matrix).
  const Mat4 m = cam.view_matrix();
  PinholeView v;
  v.eye = cam.position;
  v.right = {m.m[0][0], m.m[0][1], m.m[0][2]};
  v.up = {m.m[1][0], m.m[1][1], m.m[1][2]};
  v.forward = -Vec3{m.m[2][0], m.m[2][1], m.m[2][2]};
  v.tan_half_y = std::tan(cam.fov_y_deg * 0.5f * 3.14159265f / 180.0f);
  v.tan_half_x = v.tan_half_y * float(cam.width) / float(cam.height);
  v.width = cam.width;
  v.height = cam.height;
  v.near = cam.near;
  v.far = cam.far;
  return v;
}

PinholeView light_view(Vec3 eye, Vec3 forward, Vec3 up_hint, float tan_half, int res, int guard, float near,
                       float far) {
  PinholeView v;
  v.eye = eye;
  v.forward = normalize(forward);
  Vec3 r = cross(v.forward, up_hint);
  if (length(r) < 1e-4f) r = cross(v.forward, any_perpendicular(v.forward));
  v.right = normalize(r);
  v.up = cross(v.right, v.forward);
  // Widen so `guard` texels lie outside the requested window on each side.
  float widen = float(res) / float(std::max(1, res - 2 * guard));
  v.tan_half_x = v.tan_half_y = tan_half * widen;
  v.width = v.height = res;
  v.near = near;
  v.far = far;
  return v;
}

std::vector<PinholeView> cube_face_views(Vec3 eye, int res, float near, float far) {
  const Vec3 fwd[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  const Vec3 up[6] = {{0, 1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}, {0, 1, 0}, {0, 1, 0}};
  std::vector<PinholeView> v;
  for (int f = 0; f < 6; ++f) v.push_back(light_view(eye, fwd[f], up[f], 1.0f, res, 1, near, far));
  return v;
}

LightSetup setup_lights(const std::vector<Light>& lights, const SceneBuffers& sb, int res) {
  LightSetup ls;
  std::vector<uint32_t> casters;
  for (uint32_t o = 0; o < sb.objects.size(); ++o)
    if (sb.objects[o].flags & kObjCastsShadows) casters.push_back(o);
  for (size_t li = 0; li < lights.size(); ++li) {
    const Light& l = lights[li];
    LightData ld = light_data(l);
    ld.first_map = uint32_t(ls.maps.size());
    if (l.type == LightType::Directional) {
      Box3 box;
      for (uint32_t o : casters) box.grow(sb.object_bounds[o]);
      if (box.empty()) box = sb.bounds;
      if (box.empty()) box.grow(Vec3{0, 0, 0});
      ls.maps.push_back({cluster::directional_view(ld.direction, box, res), uint32_t(li), casters});
      ld.map_count = 1;
      ld.map_mode = MapMode::Combine;
      ls.lights.push_back(ld);
      continue;
    }
    float near, far;
    light_range(l, sb, near, far);
    bool faces = l.type == LightType::Point || l.outer_cone_deg > cluster::kMaxSpotFrustumHalfAngleDeg;
    if (faces) {
      for (const PinholeView& v : cube_face_views(l.position, res, near, far))
        ls.maps.push_back({v, uint32_t(li), casters});
      ld.map_count = 6;
      ld.map_mode = MapMode::CubeFaces;
    } else {
      float tan_half = std::tan(l.outer_cone_deg * 3.14159265f / 180.0f);
      ls.maps.push_back(
          {light_view(l.position, ld.direction, {0, 1, 0}, tan_half, res, 1, near, far), uint32_t(li), casters});
      ld.map_count = 1;
      ld.map_mode = MapMode::Combine;
    }
    ls.lights.push_back(ld);
  }
  return ls;
}

DsmLayoutParams dsm_layout_params(const ShadowSettings& s) { return {s.layout, s.fixed_layers, s.chunk_nodes}; }

void ShadowFrame::refresh_headers() {
  headers.clear();
  for (MapId id : maps) headers.push_back(backend->map_header(id));
}

ShadowView ShadowFrame::view(const ShadowSettings& s, bool with_storage) const {
  ShadowView v;
  v.lights = {setup.lights.data(), setup.lights.size()};
  v.maps = {headers.data(), headers.size()};
  v.storage = backend && with_storage ? backend->storage() : DsmStorage{};
  set_lookup(v, s);
  return v;
}

void set_lookup(ShadowView& v, const ShadowSettings& s) {
  v.filtering = s.filtering;
  v.penumbra = s.penumbra;
  v.bias_constant = s.bias_constant;
  v.bias_slope = s.bias_slope;
  v.receiver = s.receiver;
}

namespace {

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

// Replaces the light's unclustered maps with one focused map per cluster.
void cluster_light(const FrameInputs& in, size_t li, const LightClusters* previous, LightSetup& ls, LightClusters& lc) {
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
  cs.max_clusters = s.max_clusters;
  cs.resolution = s.resolution;
  PinholeView cam = camera_view(in.camera);
  const cluster::LightShape light = light_shape(in.lights[li]);
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
  fp.resolution = in.settings.resolution;
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
  Hasher h;
  h.pod(l.type);
  h.pod(l.position);
  h.pod(l.direction);
  h.pod(l.outer_cone_deg);
  hash_fields(h, s, kAffectsClusters);
  return h.h;
}

uint64_t settings_hash(const ShadowSettings& s) {
  Hasher h;
  hash_fields(h, s, kAffectsMaps);
  return h.h;
}

// What a map is built from: its view, its members' identities and content
// generations, the map settings.
uint64_t map_key(const MapPlan& plan, const FrameInputs& in, uint64_t settings) {
  Hasher h;
  h.pod(plan.view);
  for (uint32_t o : plan.members) {
    h.pod(in.object_ids[o]);
    h.pod(in.object_generations[o]);
  }
  h.pod(settings);
  return h.h;
}

// What a map's fragment lists are produced from: its view, its members'
// identities and generations, everything else the producer reads.
uint64_t fragment_key(const MapPlan& plan, const FrameInputs& in) {
  Hasher h;
  h.pod(plan.view);
  for (uint32_t o : plan.members) {
    h.pod(in.object_ids[o]);
    h.pod(in.object_generations[o]);
  }
  h.pod(in.geometry_epoch);
  return h.h;
}

// The depth extent of a map's casters along its rays (radial from a point
// light, axial for parallel rays): from the nearest point of their boxes to
// the farthest corner. The deep opacity maps' default layers span it.
float caster_depth_extent(const MapPlan& plan, const SceneBuffers& sb) {
  const PinholeView& v = plan.view;
  float lo = 1e30f, hi = 0.0f;
  for (uint32_t o : plan.members) {
    const Box3& b = sb.object_bounds[o];
    if (b.empty()) continue;
    if (is_orthographic(v)) {
      for (int c = 0; c < 8; ++c) {
        const float t = dot(b.corner(c) - v.eye, v.forward);
        lo = std::min(lo, t);
        hi = std::max(hi, t);
      }
    } else {
      lo = std::min(lo, length(vmax(vmax(b.lo - v.eye, v.eye - b.hi), Vec3{0, 0, 0})));
      for (int c = 0; c < 8; ++c) hi = std::max(hi, length(b.corner(c) - v.eye));
    }
  }
  return hi > std::max(lo, 0.0f) ? hi - std::max(lo, 0.0f) : 0.0f;
}

// A map whose casters all project to less than a texel across holds
// (almost) no shadow, and nothing else would say so (issue 25 c: a 10 km
// scene with 1 m casters, one map). Per map, from the casters' boxes: the
// casters in its window, the largest one's extent in texels and the texel's
// world size at the nearest one.
struct CasterTexels {
  int casters = 0;       // members whose box lies (partly) in the map's window
  float largest = 0.0f;  // the largest projected extent among them, texels
  float texel = 0.0f;    // world size of a texel at the nearest of them
};

CasterTexels caster_texels(const MapPlan& plan, const SceneBuffers& sb) {
  const PinholeView& v = plan.view;
  CasterTexels r;
  float nearest = 0.0f;
  for (uint32_t o : plan.members) {
    const Box3& b = sb.object_bounds[o];
    if (b.empty()) continue;
    float u0 = 1e30f, u1 = -1e30f, v0 = 1e30f, v1 = -1e30f, axial = 1e30f;
    int behind = 0;
    for (int c = 0; c < 8; ++c) {
      const ViewProjection p = project(v, b.corner(c));
      if (p.axial <= 0.0f) {
        ++behind;
        continue;
      }
      u0 = std::min(u0, p.u);
      u1 = std::max(u1, p.u);
      v0 = std::min(v0, p.v);
      v1 = std::max(v1, p.v);
      axial = std::min(axial, p.axial);
    }
    if (behind == 8) continue;  // behind the light's plane: not in this map
    if (behind > 0) {           // around the light: as wide as the map
      ++r.casters;
      r.largest = 1e30f;
      continue;
    }
    if (u1 < 0.0f || v1 < 0.0f || u0 > float(v.width) || v0 > float(v.height)) continue;  // outside the window
    if (r.casters == 0 || axial < nearest) nearest = axial;
    ++r.casters;
    r.largest = std::max(r.largest, std::max(u1 - u0, v1 - v0));
  }
  r.texel = 2.0f * v.tan_half_x * nearest / float(v.width);
  return r;
}

// One warning per light with a map whose every caster is below a texel.
// The whole cone after parallel splits only serves points outside every
// split: it is not counted.
void warn_subtexel_casters(const FrameInputs& in, ShadowFrame& frame) {
  for (size_t li = 0; li < frame.setup.lights.size(); ++li) {
    const LightData& ld = frame.setup.lights[li];
    const bool splits = ld.map_mode == MapMode::FirstContaining && ld.map_count > 1;
    const uint32_t counted = splits ? ld.map_count - 1 : ld.map_count;
    uint32_t small = 0;
    float largest = 0.0f, texel = 1e30f;
    int res = 0;
    for (uint32_t k = 0; k < counted; ++k) {
      const MapPlan& plan = frame.setup.maps[ld.first_map + k];
      const CasterTexels c = caster_texels(plan, *in.scene);
      if (c.casters == 0 || !(c.largest < 1.0f)) continue;
      ++small;
      largest = std::max(largest, c.largest);
      texel = std::min(texel, c.texel);
      res = plan.view.width;
    }
    if (small == 0) continue;
    const Light& l = in.lights[li];
    const std::string light = l.name.empty() ? "light " + std::to_string(li) : "light '" + l.name + "'";
    const std::string maps =
        ld.map_count == 1 ? "its map" : std::to_string(small) + " of its " + std::to_string(ld.map_count) + " maps";
    char text[512];
    std::snprintf(
        text, sizeof text,
        "%s: every shadow caster in %s is smaller than a texel (%dx%d texels; a texel is %.3g world units wide at "
        "the casters, the largest caster covers %.2g of one), so they cast almost no shadow; use more clusters "
        "(/shadows/clusters, now %d) or a higher resolution (/shadows/resolution)",
        light.c_str(), maps.c_str(), res, res, double(texel), double(largest), in.settings.max_clusters);
    frame.warnings.push_back(text);
  }
}

RebuildReason rebuild_reason(const MapCache::Entry* before, const MapCache::Entry& now) {
  if (!before) return RebuildReason::New;
  if (before->settings_hash != now.settings_hash) return RebuildReason::Settings;
  if (before->light_hash != now.light_hash) return RebuildReason::Light;
  if (before->member_ids != now.member_ids) return RebuildReason::Members;
  if (std::memcmp(&before->view, &now.view, sizeof(PinholeView)) != 0) return RebuildReason::Frustum;
  return RebuildReason::Content;
}

}  // namespace

void MapCache::clear(ShadowBackend& backend) {
  for (const Entry& e : entries) backend.free_map(e.id);
  for (MapId id : retired) backend.free_map(id);
  for (const KeptFragments& k : fragments) backend.free_lists(k.lists);
  entries.clear();
  retired.clear();
  lights.clear();
  fragments.clear();
}

namespace {

// Step 1: which maps this frame needs — each light's views (cube faces,
// parallel splits, clusters with their hysteresis), and the light states
// the cache keeps for the next frame. Last frame's retired maps go first.
std::unordered_map<uint64_t, MapCache::LightState> plan_maps(const FrameInputs& in, ShadowBackend& backend,
                                                             MapCache& cache, ShadowFrame& frame) {
  const ShadowSettings& s = in.settings;
  frame.setup = setup_lights(in.lights, *in.scene, s.resolution);
  frame.clusters.resize(in.lights.size());
  // Last frame's replaced maps (kept for the popping probe) go now.
  for (MapId id : cache.retired) {
    backend.free_map(id);
    ++frame.freed;
  }
  cache.retired.clear();
  if (s.parallel_splits > 1) {
    for (size_t li = 0; li < in.lights.size(); ++li) split_light(in, li, frame.setup);
    frame.clusters.assign(in.lights.size(), LightClusters{});
    for (LightClusters& lc : frame.clusters) lc.fallback_reason = "parallel-split maps (baseline)";
  } else if (s.max_clusters > 1) {
    auto t0 = std::chrono::steady_clock::now();
    for (size_t li = 0; li < in.lights.size(); ++li) {
      auto it = cache.lights.find(in.light_ids[li]);
      const bool keep = it != cache.lights.end() && it->second.signature == light_signature(in.lights[li], s);
      cluster_light(in, li, keep ? &it->second.clusters : nullptr, frame.setup, frame.clusters[li]);
    }
    frame.cluster_ms = ms_since(t0);
  }
  warn_subtexel_casters(in, frame);
  std::unordered_map<uint64_t, MapCache::LightState> lights;
  for (size_t li = 0; li < in.lights.size(); ++li)
    lights[in.light_ids[li]] = {frame.clusters[li], light_signature(in.lights[li], s)};
  return lights;
}

// The planned maps against the cache: per plan its entry (reused by key, or
// described for building), and per cache entry whether a plan took it.
struct CacheMatch {
  std::vector<MapCache::Entry> next;  // per planned map
  std::vector<uint8_t> found;         // per planned map: its key was in the cache
  std::vector<uint8_t> taken;         // per cache entry: a planned map reuses it
  size_t missing() const { return found.size() - size_t(std::count(found.begin(), found.end(), 1)); }
};

// Step 2: reuse by key (each cache entry once, the first of equal keys
// first), and the reason each unmatched map is built — against the map its
// light had in that place. O(maps + entries).
CacheMatch match_cache(const FrameInputs& in, const MapCache& cache, ShadowFrame& frame) {
  const uint64_t settings = settings_hash(in.settings);
  const size_t n = frame.setup.maps.size();
  CacheMatch m;
  m.next.resize(n);
  m.found.assign(n, 0);
  m.taken.assign(cache.entries.size(), 0);
  std::unordered_map<uint64_t, std::vector<size_t>> by_key;  // cache indices, in cache order
  for (size_t c = cache.entries.size(); c-- > 0;) by_key[cache.entries[c].key].push_back(c);
  for (size_t k = 0; k < n; ++k) {
    const MapPlan& plan = frame.setup.maps[k];
    const LightData& ld = frame.setup.lights[plan.light];
    MapCache::Entry& e = m.next[k];
    e.key = map_key(plan, in, settings);
    e.light_id = in.light_ids[plan.light];
    e.slot = uint32_t(k - ld.first_map);
    e.light_hash = hash_light(ld);
    e.settings_hash = settings;
    e.view = plan.view;
    for (uint32_t o : plan.members) e.member_ids.push_back(in.object_ids[o]);
    auto it = by_key.find(e.key);
    if (it == by_key.end() || it->second.empty()) continue;
    const size_t c = it->second.back();  // the earliest untaken entry
    it->second.pop_back();
    m.taken[c] = 1;
    m.found[k] = 1;
    e.id = cache.entries[c].id;
    e.stats = cache.entries[c].stats;
  }
  std::map<std::pair<uint64_t, uint32_t>, const MapCache::Entry*> by_place;  // (light, slot) -> its last entry
  for (const MapCache::Entry& old : cache.entries) by_place[{old.light_id, old.slot}] = &old;
  for (size_t k = 0; k < n; ++k) {
    if (m.found[k]) continue;
    auto it = by_place.find({m.next[k].light_id, m.next[k].slot});
    const MapCache::Entry* before = it == by_place.end() ? nullptr : it->second;
    frame.rebuilds.push_back({frame.setup.maps[k].light, m.next[k].slot, rebuild_reason(before, m.next[k])});
  }
  return m;
}

// Step 3: releases the maps no plan took (or retires them for the popping
// probe), builds the missing ones (from kept fragment lists where their key
// matches), and updates the cache. A failure (a build refused by the memory
// budget, an allocation) leaves nothing of this frame: the maps it built
// are freed, and so is the cache (its maps and lists), so the backend's
// store holds no map nothing refers to and the next frame builds afresh.
void build_missing(const FrameInputs& in, const FragmentProducer& produce, ShadowBackend& backend, MapCache& cache,
                   CacheMatch& m, ShadowFrame& frame) {
  const SceneBuffers& sb = *in.scene;
  SceneView sv = sb.view();
  const ShadowSettings& s = in.settings;
  const size_t n = frame.setup.maps.size();
  std::vector<MapCache::Entry>& next = m.next;
  // Replaced maps are released before new ones are built (a layout change
  // needs an empty store), or kept one frame for the popping probe.
  const DsmLayoutParams layout = dsm_layout_params(s);
  const bool layout_changed = layout.layout != cache.layout.layout ||
                              layout.fixed_layers != cache.layout.fixed_layers ||
                              layout.chunk_nodes != cache.layout.chunk_nodes;
  frame.previous_kept = in.keep_previous && !layout_changed;
  std::vector<uint8_t> released(cache.entries.size(), 0);  // freed or retired below
  std::vector<uint8_t> built(n, 0);
  std::vector<MapCache::KeptFragments> kept;  // the next frame's MapCache::fragments
  std::vector<ListsId> reading;               // lists a build is reading
  reading.reserve(1);
  auto abandon = [&] {
    auto quietly = [](auto f) {
      try {
        f();
      } catch (...) {  // freeing a map may compact the store, whose failure leaves holes only
      }
    };
    for (size_t k = 0; k < n; ++k)
      if (built[k]) quietly([&] { backend.free_map(next[k].id); });
    for (size_t c = 0; c < cache.entries.size(); ++c)
      if (!released[c]) quietly([&] { backend.free_map(cache.entries[c].id); });
    for (MapId id : cache.retired) quietly([&] { backend.free_map(id); });
    for (const MapCache::KeptFragments& c : kept) quietly([&] { backend.free_lists(c.lists); });
    for (const MapCache::KeptFragments& c : cache.fragments)
      if (!c.taken) quietly([&] { backend.free_lists(c.lists); });
    for (ListsId id : reading) quietly([&] { backend.free_lists(id); });
    cache.entries.clear();
    cache.retired.clear();
    cache.lights.clear();
    cache.fragments.clear();
    frame = ShadowFrame{};
  };
  try {
    for (size_t c = 0; c < cache.entries.size(); ++c) {
      if (m.taken[c]) continue;
      released[c] = 1;
      if (frame.previous_kept) {
        cache.retired.push_back(cache.entries[c].id);
      } else {
        backend.free_map(cache.entries[c].id);
        ++frame.freed;
      }
    }
    if (in.maps_built) in.maps_built->store(0);
    if (in.maps_to_build) in.maps_to_build->store(uint32_t(m.missing()));
    for (size_t k = 0; k < n; ++k) {
      MapCache::Entry& e = next[k];
      const MapPlan& plan = frame.setup.maps[k];
      MapCache::KeptFragments* cached = nullptr;
      const uint64_t fkey = in.keep_fragments ? fragment_key(plan, in) : 0;
      if (in.keep_fragments)
        for (MapCache::KeptFragments& c : cache.fragments)
          if (!c.taken && c.key == fkey) cached = &c;
      if (cached) {  // (kept for the next frame below, where it is free again)
        cached->taken = true;
        kept.push_back(*cached);
      }
      if (m.found[k]) {
        frame.map_rebuilt.push_back(0);
        ++frame.reused;
      } else {
        std::vector<uint32_t> words = mask_words(plan.members, sb.objects.size());
        ObjectMask mask{{words.data(), words.size()}};
        auto t0 = std::chrono::steady_clock::now();
        // The lists the build reads (and sorts in place): a copy of kept
        // lists, or new ones of which a copy is kept — on the backend.
        if (cached) {
          reading.push_back(backend.copy_lists(cached->lists));
          ++frame.fragment_lists_reused;
        } else {
          reading.push_back(produce(backend, plan.view, mask));
          if (in.keep_fragments) kept.push_back({fkey, backend.copy_lists(reading.back()), false});
        }
        const ListsId lists = reading.back();
        frame.fragments_ms += ms_since(t0);
        frame.fragments += backend.lists_fragments(lists);
        t0 = std::chrono::steady_clock::now();
        std::vector<uint32_t> inside = objects_containing(sv, plan.view.eye, mask);
        LightPassParams lp{plan.view, s.epsilon, {inside.data(), inside.size()}, s.method, s.method_param};
        if (s.method == ShadowMethod::DeepOpacity)
          lp.layer_thickness = s.layer_thickness > 0.0f
                                   ? s.layer_thickness
                                   : caster_depth_extent(plan, sb) / method_param_or_default(s.method, s.method_param);
        // RGB nodes only where a member is coloured (deep shadow maps; the
        // baselines are grey).
        lp.rgb = s.rgb_maps && s.method == ShadowMethod::Dsm &&
                 std::any_of(plan.members.begin(), plan.members.end(),
                             [&](uint32_t o) { return is_coloured(sv, sv.objects[o]); });
        e.id = backend.build_map(lp, lists, layout, e.stats);
        built[k] = 1;
        reading.pop_back();
        backend.free_lists(lists);
        frame.build_ms += ms_since(t0);
        frame.map_rebuilt.push_back(1);
        ++frame.rebuilt;
        if (in.maps_built) in.maps_built->fetch_add(1);
      }
      frame.maps.push_back(e.id);
      frame.map_stats.push_back(e.stats);
    }
  } catch (...) {
    abandon();
    throw;
  }
  frame.refresh_headers();
  for (const MapCache::KeptFragments& c : cache.fragments)
    if (!c.taken) backend.free_lists(c.lists);  // lists of maps no longer planned
  for (MapCache::KeptFragments& c : kept) c.taken = false;
  cache.fragments = std::move(kept);
  for (const MapCache::KeptFragments& c : cache.fragments) frame.fragment_cache_bytes += backend.lists_bytes(c.lists);
  cache.entries = std::move(next);
  cache.layout = layout;
}

}  // namespace

void build_shadow_frame(const FrameInputs& in, const FragmentProducer& produce, ShadowBackend& backend, MapCache& cache,
                        ShadowFrame& frame) {
  frame = ShadowFrame{};
  frame.backend = &backend;
  std::unordered_map<uint64_t, MapCache::LightState> lights = plan_maps(in, backend, cache, frame);
  CacheMatch matched = match_cache(in, cache, frame);
  build_missing(in, produce, backend, cache, matched, frame);
  cache.lights = std::move(lights);
}

}  // namespace cdsm
