#include "cluster/clustering.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "cluster/light_views.h"

namespace cdsm::cluster {
namespace {

// 2D extreme points pp_min / pp_max of a caster in one map.
struct Extent {
  bool present = false;
  Vec2 lo{1e30f, 1e30f}, hi{-1e30f, -1e30f};
};

bool overlaps(const Box3& a, const Box3& b) {
  return a.lo.x <= b.hi.x && b.lo.x <= a.hi.x && a.lo.y <= b.hi.y && b.lo.y <= a.hi.y && a.lo.z <= b.hi.z &&
         b.lo.z <= a.hi.z;
}

// The caster's box cut by `planes`, mapped by `map`.
Extent extent_in(const Box3& box, const std::vector<Plane>& planes, const LispsmMap& map) {
  Extent e;
  ConvexBody b = box_body(box);
  b.clip(planes);
  for (Vec3 p : b.vertices()) {
    Vec2 q;
    if (!map.map(p, q)) continue;
    e.present = true;
    e.lo = {std::min(e.lo.x, q.x), std::min(e.lo.y, q.y)};
    e.hi = {std::max(e.hi.x, q.x), std::max(e.hi.y, q.y)};
  }
  return e;
}

float norm2(float x, float y) { return std::sqrt(x * x + y * y); }

// Paper eq. 2.
float extent_distance(const Extent& a, const Extent& b) {
  return std::max(norm2(a.lo.x - b.lo.x, a.lo.y - b.lo.y), norm2(a.hi.x - b.hi.x, a.hi.y - b.hi.y));
}

// Raises table[i][j] to the distance in this direction for pairs present in it.
void accumulate(const std::vector<Extent>& ext, int n, std::vector<float>& table) {
  for (int i = 0; i < n; ++i) {
    if (!ext[size_t(i)].present) continue;
    for (int j = i + 1; j < n; ++j) {
      if (!ext[size_t(j)].present) continue;
      float d = extent_distance(ext[size_t(i)], ext[size_t(j)]);
      float& t = table[size_t(i) * size_t(n) + size_t(j)];
      t = std::max(t, d);
      table[size_t(j) * size_t(n) + size_t(i)] = t;
    }
  }
}

// Pairs never present together: kFarDistance; the diagonal: 0.
void finish(std::vector<float>& table, int n) {
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      float& t = table[size_t(i) * size_t(n) + size_t(j)];
      if (i == j)
        t = 0.0f;
      else if (t < 0.0f)
        t = kFarDistance;
    }
}

// Largest distance between two lit members (unlit casters cast no shadow,
// so where they sit does not matter).
float diameter_of(const CasterDistances& D, const std::vector<int>& idx) {
  float d = 0.0f;
  for (size_t a = 0; a < idx.size(); ++a)
    for (size_t b = a + 1; b < idx.size(); ++b)
      if (D.lit[size_t(idx[a])] && D.lit[size_t(idx[b])]) d = std::max(d, D.d(idx[a], idx[b]));
  return d;
}

FocusParams focus_params(const ClusterSettings& s) {
  FocusParams p;
  p.resolution = s.resolution;
  p.guard_texels = std::max(s.guard_texels, 1.0f);
  p.max_half_angle_deg = s.max_half_angle_deg;
  p.min_near = s.min_near;
  return p;
}

// Fills members (ids ascending), views and split of a cluster given by
// indices. The frustum is focused on the members inside the convex body B
// of some direction (those are the only ones whose shadows can reach the
// view: B holds every segment from the light to a visible point); members
// outside every B stay in the map but do not widen it. Without seen
// members, the lit ones decide, then all. (A directional light's window
// then moves only when a member enters or leaves B: with the camera's far
// plane reaching across the scene, B is most of the scene box.)
void focus_into(Cluster& c, const LightShape& light, const std::vector<Caster>& casters, const std::vector<int>& idx,
                const ClusterSettings& s, const CasterDistances& D) {
  std::vector<int> order = idx;
  std::sort(order.begin(), order.end(), [&](int a, int b) { return casters[size_t(a)].id < casters[size_t(b)].id; });
  c.members.clear();
  std::vector<Box3> seen, lit, all;
  for (int i : order) {
    c.members.push_back(casters[size_t(i)].id);
    all.push_back(casters[size_t(i)].bounds);
    if (D.lit[size_t(i)]) lit.push_back(casters[size_t(i)].bounds);
    if (D.seen[size_t(i)]) seen.push_back(casters[size_t(i)].bounds);
  }
  const std::vector<Box3>& boxes = !seen.empty() ? seen : (!lit.empty() ? lit : all);
  FocusResult f = focus_cluster(light, boxes, focus_params(s));
  c.views = std::move(f.views);
  c.split = f.split;
}

bool same_views(const std::vector<PinholeView>& a, const std::vector<PinholeView>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (!same_view(a[i], b[i])) return false;
  return true;
}

}  // namespace

std::vector<PinholeView> light_directions(const LightShape& light, const Box3& scene, int resolution, float min_near) {
  if (light.directional) return {directional_view(light.direction, scene, resolution)};
  float far = 2.0f * min_near;
  for (int i = 0; i < 8; ++i) far = std::max(far, length(scene.corner(i) - light.position));
  far *= 1.01f;
  if (spot_fits_one_frustum(light)) return {spot_view(light, resolution, min_near, far)};
  auto faces = cube_face_views(light.position, min_near, far, resolution);
  return std::vector<PinholeView>(faces.begin(), faces.end());
}

CasterDistances caster_distances(const LightShape& light, const PinholeView& camera, const Box3& scene,
                                 const std::vector<Caster>& casters, const ClusterSettings& settings) {
  CasterDistances D;
  const int n = int(casters.size());
  D.count = n;
  D.lispsm.assign(size_t(n) * size_t(n), -1.0f);
  D.uniform.assign(size_t(n) * size_t(n), -1.0f);
  D.seen.assign(size_t(n), 0u);
  D.lit.assign(size_t(n), 0u);
  const std::vector<Plane> cone = cone_planes(light);  // empty for point lights

  const std::vector<PinholeView> views = light_directions(light, scene, settings.resolution, settings.min_near);
  for (size_t k = 0; k < views.size(); ++k) {
    Direction dir;
    dir.view = views[k];
    dir.body = light.directional ? lispsm_body_directional(camera, light.direction, scene, &dir.view)
                                 : lispsm_body(camera, light.position, scene, &dir.view);
    dir.body.clip(cone);
    dir.map = build_lispsm(camera, dir.view, dir.body, settings.lispsm);

    // Uniform: the casters inside the plain light frustum (and cone).
    std::vector<Plane> frustum = frustum_planes(dir.view);
    frustum.insert(frustum.end(), cone.begin(), cone.end());
    const LispsmMap plain = uniform_light_map(dir.view);
    std::vector<Extent> ext(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) {
      ext[size_t(i)] = extent_in(casters[size_t(i)].bounds, frustum, plain);
      if (ext[size_t(i)].present) D.lit[size_t(i)] = 1;
    }
    accumulate(ext, n, D.uniform);

    // LiSPSM: the casters' parts inside B.
    if (dir.map.valid) {
      const std::vector<Plane> bplanes = dir.body.planes();
      const Box3 bbox = dir.body.bounds();
      for (int i = 0; i < n; ++i) {
        const Box3& box = casters[size_t(i)].bounds;
        ext[size_t(i)] = (D.lit[size_t(i)] && overlaps(box, bbox)) ? extent_in(box, bplanes, dir.map) : Extent{};
        if (ext[size_t(i)].present && k < 32) D.seen[size_t(i)] |= 1u << k;
      }
      accumulate(ext, n, D.lispsm);
    }
    D.directions.push_back(std::move(dir));
  }
  finish(D.lispsm, n);
  finish(D.uniform, n);
  return D;
}

std::vector<std::vector<int>> greedy_clusters(const CasterDistances& D, float d0, int m) {
  const int n = D.count;
  m = std::max(m, 1);
  std::vector<int> owner(size_t(n), -1);
  std::vector<std::vector<int>> C;
  auto fits = [&](int o, size_t k) {
    for (int j : C[k])
      if (D.d(o, j) > d0) return false;
    return true;
  };
  auto nearest = [&](int o) {  // thesis §4.5 "Find the Nearest Cluster"
    size_t best = 0;
    float best_d = 1e38f;
    for (size_t k = 0; k < C.size(); ++k) {
      float md = 0.0f;
      for (int j : C[k]) md = std::max(md, D.d(o, j));
      if (md < best_d) best_d = md, best = k;
    }
    return best;
  };
  auto put = [&](int o, size_t k) {
    C[k].push_back(o);
    owner[size_t(o)] = int(k);
  };
  auto open = [&](int o) {
    C.emplace_back();
    put(o, C.size() - 1);
  };

  // Pairs of seen casters, by descending distance (ties by index).
  struct Pair {
    float d;
    int a, b;
  };
  std::vector<Pair> pairs;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      if (D.seen[size_t(i)] && D.seen[size_t(j)]) pairs.push_back({D.d(i, j), i, j});
  std::sort(pairs.begin(), pairs.end(), [](const Pair& x, const Pair& y) {
    if (x.d != y.d) return x.d > y.d;
    return x.a != y.a ? x.a < y.a : x.b < y.b;
  });

  for (const Pair& p : pairs) {  // thesis Alg. 4.2, lines 9-35
    const int A = p.a, B = p.b;
    for (size_t k = 0; k < C.size(); ++k) {
      if (owner[size_t(A)] < 0 && fits(A, k)) put(A, k);
      if (owner[size_t(B)] < 0 && fits(B, k)) put(B, k);
    }
    const bool has_a = owner[size_t(A)] >= 0, has_b = owner[size_t(B)] >= 0;
    if (has_a && has_b) continue;
    if (int(C.size()) < m) {
      if (!has_a && !has_b && p.d <= d0) {
        open(A);
        put(B, C.size() - 1);
      } else {
        if (!has_a) open(A);
        if (!has_b) {
          if (int(C.size()) < m)
            open(B);
          else
            put(B, nearest(B));
        }
      }
    } else {
      if (!has_a) put(A, nearest(A));
      if (!has_b) put(B, nearest(B));
    }
  }

  // Casters in no pair: the same rule, one at a time.
  auto place = [&](int o) {
    for (size_t k = 0; k < C.size(); ++k)
      if (fits(o, k)) return put(o, k);
    if (int(C.size()) < m)
      open(o);
    else
      put(o, nearest(o));
  };
  for (int o = 0; o < n; ++o)
    if (owner[size_t(o)] < 0 && D.seen[size_t(o)]) place(o);
  for (int o = 0; o < n; ++o)
    if (owner[size_t(o)] < 0 && D.lit[size_t(o)]) place(o);
  // No light reaches these: they cast no shadow, so they only need a home.
  for (int o = 0; o < n; ++o)
    if (owner[size_t(o)] < 0) {
      if (C.empty())
        open(o);
      else
        put(o, nearest(o));
    }
  return C;
}

Clustering cluster_casters(const LightShape& light, const PinholeView& camera, const Box3& scene,
                           const std::vector<Caster>& casters, const ClusterSettings& settings) {
  const CasterDistances D = caster_distances(light, camera, scene, casters, settings);
  Clustering out;
  out.directions = int32_t(D.directions.size());
  for (const Direction& dir : D.directions) out.perspective_directions += dir.map.perspective ? 1 : 0;
  for (const std::vector<int>& idx : greedy_clusters(D, settings.d0, settings.max_clusters)) {
    Cluster c;
    focus_into(c, light, casters, idx, settings, D);
    c.diameter = diameter_of(D, idx);
    out.clusters.push_back(std::move(c));
  }
  return out;
}

Clustering update_clusters(const LightShape& light, const PinholeView& camera, const Box3& scene,
                           const std::vector<Caster>& casters, const ClusterSettings& settings,
                           const Clustering& previous) {
  const CasterDistances D = caster_distances(light, camera, scene, casters, settings);
  const float h = std::max(settings.hysteresis, 0.0f);
  const int m = std::max(settings.max_clusters, 1);

  // Previous member sets as caster indices; any unknown or missing caster
  // means the assignment cannot be kept.
  std::map<int32_t, int> index_of;
  for (size_t i = 0; i < casters.size(); ++i) index_of[casters[i].id] = int(i);
  bool keep = !previous.clusters.empty() && int(previous.clusters.size()) <= m;
  std::vector<std::vector<int>> prev_idx;
  size_t covered = 0;
  for (const Cluster& c : previous.clusters) {
    std::vector<int> idx;
    for (int32_t id : c.members) {
      auto it = index_of.find(id);
      if (it == index_of.end())
        keep = false;
      else
        idx.push_back(it->second);
    }
    covered += c.members.size();
    prev_idx.push_back(std::move(idx));
  }
  keep = keep && covered == casters.size();
  const bool below_m = int(previous.clusters.size()) < m;
  for (size_t k = 0; keep && k < prev_idx.size(); ++k) {
    const float diam = diameter_of(D, prev_idx[k]);
    const float allowed = below_m ? settings.d0 : std::max(settings.d0, previous.clusters[k].diameter);
    if (diam > allowed * (1.0f + h)) keep = false;
  }
  for (size_t a = 0; keep && a < prev_idx.size(); ++a)
    for (size_t b = a + 1; keep && b < prev_idx.size(); ++b) {
      std::vector<int> u = prev_idx[a];
      u.insert(u.end(), prev_idx[b].begin(), prev_idx[b].end());
      if (diameter_of(D, u) <= settings.d0 / (1.0f + h)) keep = false;  // they should merge
    }

  Clustering out;
  out.directions = int32_t(D.directions.size());
  for (const Direction& dir : D.directions) out.perspective_directions += dir.map.perspective ? 1 : 0;
  if (keep) {
    out.reclustered = false;
    for (size_t k = 0; k < prev_idx.size(); ++k) {
      Cluster c;
      focus_into(c, light, casters, prev_idx[k], settings, D);
      c.diameter = previous.clusters[k].diameter;
      c.previous = int32_t(k);
      c.members_changed = false;
      c.views_changed = !same_views(c.views, previous.clusters[k].views);
      out.clusters.push_back(std::move(c));
    }
    return out;
  }
  for (const std::vector<int>& idx : greedy_clusters(D, settings.d0, settings.max_clusters)) {
    Cluster c;
    focus_into(c, light, casters, idx, settings, D);
    c.diameter = diameter_of(D, idx);
    for (size_t k = 0; k < previous.clusters.size(); ++k)
      if (previous.clusters[k].members == c.members) {
        c.previous = int32_t(k);
        c.members_changed = false;
        c.views_changed = !same_views(c.views, previous.clusters[k].views);
        break;
      }
    out.clusters.push_back(std::move(c));
  }
  return out;
}

}  // namespace cdsm::cluster
