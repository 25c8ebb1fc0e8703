#include "cpu/frame.h"

#include "cluster/focus.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

namespace cdsm {
namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

Vec3 any_perpendicular(Vec3 d) {
  Vec3 a = std::fabs(d.y) < 0.9f ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
  return normalize(cross(cross(d, a), d)) * -1.0f;
}

// FNV-1a over bytes, mixed.
struct Hasher {
  uint64_t h = 1469598103934665603ull;
  void bytes(const void* p, size_t n) {
    const unsigned char* c = static_cast<const unsigned char*>(p);
    for (size_t i = 0; i < n; ++i) {
      h ^= c[i];
      h *= 1099511628211ull;
    }
  }
  template <class T>
  void pod(const T& v) {
    bytes(&v, sizeof(T));
  }
};

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

LightData light_data(const Light& l) {
  LightData ld{};
  ld.position = l.position;
  ld.type = l.type == LightType::Spot ? kLightSpot : kLightPoint;
  ld.direction = normalize(l.direction);
  const float k = 3.14159265f / 180.0f;
  ld.cos_outer = l.type == LightType::Spot ? std::cos(l.outer_cone_deg * k) : -2.0f;
  ld.cos_inner = l.type == LightType::Spot ? std::cos(std::min(l.inner_cone_deg, l.outer_cone_deg) * k) : -1.0f;
  if (ld.cos_inner <= ld.cos_outer) ld.cos_inner = ld.cos_outer + 1e-6f;
  ld.radiance = l.color * l.intensity;
  return ld;
}

}  // namespace

FragmentProducer cpu_fragment_producer(const SceneView& scene) {
  return [scene](const PinholeView& view, ObjectMask mask, FragmentBuffers& out) {
    cast_fragments(scene, view, mask, out);
  };
}

PinholeView camera_view(const Camera& cam) {
  PinholeView v;
  v.eye = cam.position;
  v.forward = normalize(cam.target - cam.position);
  Vec3 r = cross(v.forward, cam.up);
  if (length(r) < 1e-6f) r = cross(v.forward, any_perpendicular(v.forward));
  v.right = normalize(r);
  v.up = cross(v.right, v.forward);
  v.tan_half_y = std::tan(cam.fov_y_deg * 0.5f * 3.14159265f / 180.0f);
  v.tan_half_x = v.tan_half_y * float(cam.width) / float(cam.height);
  v.width = cam.width;
  v.height = cam.height;
  v.near = cam.near;
  v.far = cam.far;
  return v;
}

PinholeView light_view(Vec3 eye, Vec3 forward, Vec3 up_hint, float tan_half, int res, int guard,
                       float near, float far) {
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

LightSetup setup_lights(const Scene& scene, const SceneBuffers& sb, int res) {
  LightSetup ls;
  std::vector<uint32_t> casters;
  for (uint32_t o = 0; o < sb.objects.size(); ++o)
    if (sb.objects[o].flags & kObjCastsShadows) casters.push_back(o);
  for (size_t li = 0; li < scene.lights.size(); ++li) {
    const Light& l = scene.lights[li];
    LightData ld = light_data(l);
    ld.first_map = uint32_t(ls.maps.size());
    float near, far;
    light_range(l, sb, near, far);
    bool faces = l.type == LightType::Point || l.outer_cone_deg > 60.0f;
    if (faces) {
      for (const PinholeView& v : cube_face_views(l.position, res, near, far))
        ls.maps.push_back({v, uint32_t(li), casters});
      ld.map_count = 6;
      ld.map_mode = kMapsCubeFaces;
    } else {
      float tan_half = std::tan(l.outer_cone_deg * 3.14159265f / 180.0f);
      ls.maps.push_back({light_view(l.position, ld.direction, {0, 1, 0}, tan_half, res, 1, near, far),
                         uint32_t(li), casters});
      ld.map_count = 1;
      ld.map_mode = kMapsCombine;
    }
    ls.lights.push_back(ld);
  }
  return ls;
}

std::vector<uint64_t> object_hashes(const SceneBuffers& sb) {
  Hasher vol;
  vol.bytes(sb.voxels.data(), sb.voxels.size() * sizeof(float));
  vol.bytes(sb.macro_max.data(), sb.macro_max.size() * sizeof(float));
  vol.bytes(sb.nano_pool.data(), sb.nano_pool.size() * sizeof(sb.nano_pool[0]));
  std::vector<uint64_t> out(sb.objects.size());
  for (size_t o = 0; o < sb.objects.size(); ++o) {
    const ObjectData& od = sb.objects[o];
    Hasher h;
    h.pod(od);
    h.bytes(sb.tri_vertices.data() + size_t(od.first_tri) * 3, size_t(od.tri_count) * 3 * sizeof(Vec3));
    if (od.volume >= 0) {
      h.pod(sb.volumes[size_t(od.volume)]);
      h.pod(vol.h);
    }
    out[o] = h.h;
  }
  return out;
}

uint64_t map_key(const MapPlan& plan, const std::vector<uint64_t>& hashes, const ShadowSettings& s) {
  Hasher h;
  h.pod(plan.view);
  for (uint32_t o : plan.members) {
    h.pod(o);
    h.pod(hashes[o]);
  }
  h.pod(s.epsilon);
  h.pod(s.layout);
  h.pod(s.fixed_layers);
  h.pod(s.chunk_nodes);
  h.pod(s.method);
  h.pod(s.method_param);
  h.pod(s.parallel_splits);
  return h.h;
}

static_assert(uint32_t(ReceiverLookup::Plane) == kReceiverPlane && uint32_t(ReceiverLookup::SlopeBias) == kReceiverSlopeBias,
              "hd/lights.h receiver tags equal cdsm::ReceiverLookup");

ShadowView ShadowFrame::view(const ShadowSettings& s) const {
  ShadowView v;
  v.lights = {setup.lights.data(), setup.lights.size()};
  v.maps = {dsm.maps.data(), dsm.maps.size()};
  v.storage = dsm.storage();
  v.filtering = s.filtering;
  v.bias_constant = s.bias_constant;
  v.bias_slope = s.bias_slope;
  v.receiver = uint32_t(s.receiver);
  return v;
}

void append_dsm(DsmBuffers& dst, const DsmBuffers& src) { dst.append(src); }

namespace {

// Replaces the light's unclustered maps with one focused map per cluster.
void cluster_light(const Scene& scene, const SceneBuffers& sb, size_t li, const ShadowCache& cache,
                   bool keep_hysteresis, LightSetup& ls, LightClusters& lc) {
  const ShadowSettings& s = scene.shadows;
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
  PinholeView cam = camera_view(scene.camera);
  const Light& light = scene.lights[li];
  if (keep_hysteresis && li < cache.clusters.size() && cache.clusters[li].clustered)
    lc.clustering = cluster::update_clusters(light, cam, sb.bounds, casters, cs, cache.clusters[li].clustering);
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
  LightData& ld = ls.lights[li];
  std::vector<MapPlan> maps;
  for (size_t k = 0; k < ls.maps.size(); ++k)
    if (k < ld.first_map || k >= ld.first_map + ld.map_count) maps.push_back(ls.maps[k]);
  // Maps of later lights shift: rebuild the index from scratch below.
  std::vector<MapPlan> mine;
  for (const cluster::Cluster& c : lc.clustering.clusters)
    for (const PinholeView& v : c.views) {
      MapPlan p{v, uint32_t(li), {}};
      for (int32_t id : c.members) p.members.push_back(uint32_t(id));
      mine.push_back(std::move(p));
    }
  std::vector<MapPlan> all;
  for (size_t l = 0; l < ls.lights.size(); ++l) {
    uint32_t first = uint32_t(all.size());
    if (l == li) {
      for (auto& m : mine) all.push_back(m);
      ls.lights[l].map_count = uint32_t(mine.size());
      ls.lights[l].map_mode = kMapsCombine;
    } else {
      for (uint32_t k = 0; k < ls.lights[l].map_count; ++k) all.push_back(ls.maps[ls.lights[l].first_map + k]);
    }
    ls.lights[l].first_map = first;
  }
  ls.maps.swap(all);
  lc.clustered = true;
}

// Replaces a spot light's map by parallel-split maps (near to far) along
// the camera's view: slice i of the view frustum by the practical split
// scheme (half logarithmic, half uniform), a light frustum focused on the
// slice's box within the scene, holding every caster between the light and
// the scene's far end.
void split_light(const Scene& scene, const SceneBuffers& sb, size_t li, LightSetup& ls) {
  const Light& light = scene.lights[li];
  const int m = scene.shadows.parallel_splits;
  if (ls.lights[li].map_mode != kMapsCombine || ls.lights[li].map_count != 1) return;  // spots only
  PinholeView cam = camera_view(scene.camera);
  // The view's depth range inside the scene box.
  float far = 0.0f;
  for (int c = 0; c < 8; ++c) far = std::max(far, dot(sb.bounds.corner(c) - cam.eye, cam.forward));
  far = std::min(far, cam.far);
  const float near = cam.near;
  if (!(far > near)) return;
  const MapPlan base = ls.maps[ls.lights[li].first_map];
  cluster::FocusParams fp;
  fp.resolution = scene.shadows.resolution;
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
    p.view.near = base.view.near;  // every caster between the light and the slice
    p.view.far = base.view.far;
    mine.push_back(std::move(p));
  }
  if (mine.empty()) return;
  mine.push_back(base);  // the whole cone last: points outside every split
  std::vector<MapPlan> all;
  for (size_t l = 0; l < ls.lights.size(); ++l) {
    uint32_t first = uint32_t(all.size());
    if (l == li) {
      for (auto& p : mine) all.push_back(p);
      ls.lights[l].map_count = uint32_t(mine.size());
      ls.lights[l].map_mode = kMapsFirstContaining;
    } else {
      for (uint32_t k = 0; k < ls.lights[l].map_count; ++k) all.push_back(ls.maps[ls.lights[l].first_map + k]);
    }
    ls.lights[l].first_map = first;
  }
  ls.maps.swap(all);
}

uint64_t lights_signature(const Scene& scene) {
  Hasher h;
  for (const Light& l : scene.lights) {
    h.pod(l.type);
    h.pod(l.position);
    h.pod(l.direction);
    h.pod(l.outer_cone_deg);
  }
  h.pod(scene.shadows.max_clusters);
  h.pod(scene.shadows.d0);
  h.pod(scene.shadows.resolution);
  return h.h;
}

}  // namespace

void build_shadow_frame(const Scene& scene, const SceneBuffers& sb, const FragmentProducer& produce,
                        ShadowCache& cache, ShadowFrame& frame) {
  SceneView sv = sb.view();
  frame = ShadowFrame{};
  const ShadowSettings& s = scene.shadows;
  frame.setup = setup_lights(scene, sb, s.resolution);
  frame.clusters.resize(scene.lights.size());
  uint64_t sig = lights_signature(scene);
  bool keep = sig == cache.light_signature;
  if (s.parallel_splits > 1) {
    for (size_t li = 0; li < scene.lights.size(); ++li) split_light(scene, sb, li, frame.setup);
    frame.clusters.assign(scene.lights.size(), LightClusters{});
    for (LightClusters& lc : frame.clusters) lc.fallback_reason = "parallel-split maps (baseline)";
  } else if (s.max_clusters > 1) {
    auto t0 = std::chrono::steady_clock::now();
    for (size_t li = 0; li < scene.lights.size(); ++li)
      cluster_light(scene, sb, li, cache, keep, frame.setup, frame.clusters[li]);
    frame.cluster_ms = ms_since(t0);
  }
  std::vector<uint64_t> hashes = object_hashes(sb);
  std::vector<ShadowCache::Entry> next;
  FragmentBuffers fb;
  for (const MapPlan& plan : frame.setup.maps) {
    uint64_t key = map_key(plan, hashes, s);
    ShadowCache::Entry entry;
    auto it = std::find_if(cache.entries.begin(), cache.entries.end(), [&](const ShadowCache::Entry& e) { return e.key == key; });
    if (it != cache.entries.end()) {
      entry = std::move(*it);
      cache.entries.erase(it);
      frame.map_rebuilt.push_back(0);
      ++frame.reused;
    } else {
      entry.key = key;
      std::vector<uint32_t> words = mask_words(plan.members, sb.objects.size());
      ObjectMask mask{{words.data(), words.size()}};
      auto t0 = std::chrono::steady_clock::now();
      produce(plan.view, mask, fb);
      frame.fragments_ms += ms_since(t0);
      frame.fragments += fb.total();
      t0 = std::chrono::steady_clock::now();
      std::vector<uint32_t> inside = objects_containing(sv, plan.view.eye, mask);
      LightPassParams lp{plan.view, s.epsilon, {inside.data(), inside.size()}, uint32_t(s.method), s.method_param};
      entry.stats = build_dsm(sv, lp, fb.lists(), entry.dsm, dsm_layout_params(s));
      frame.build_ms += ms_since(t0);
      frame.map_rebuilt.push_back(1);
      ++frame.rebuilt;
    }
    append_dsm(frame.dsm, entry.dsm);
    frame.map_stats.push_back(entry.stats);
    next.push_back(std::move(entry));
  }
  cache.entries = std::move(next);
  cache.clusters = frame.clusters;
  cache.light_signature = sig;
}

}  // namespace cdsm
