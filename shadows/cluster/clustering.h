// Clustering of shadow casters in light space (thesis §3.4, Alg. 4.2;
// DESIGN.md §4): distances between the casters' boxes in the light-space
// perspective map of each light direction, greedy clustering with threshold
// d0 and at most m clusters, one focused frustum per cluster, and
// frame-to-frame hysteresis. Host code.
#pragma once

#include <cstdint>
#include <vector>

#include "cdsm/math.h"
#include "cluster/convex.h"
#include "cluster/focus.h"
#include "cluster/lispsm.h"
#include "cluster/light_views.h"
#include "hd/view.h"

namespace cdsm::cluster {

// The distance of two casters that share no light direction.
inline constexpr float kFarDistance = 1e30f;

// A shadow caster: its world bounding box and the caller's object id.
struct Caster {
  int32_t id = -1;
  Box3 bounds;
};

struct ClusterSettings {
  float d0 = 0.25f;           // distance threshold, normalized map units ([-1, 1] across B)
  int32_t max_clusters = 1;   // m
  int32_t resolution = 512;   // DSM texels per side
  float guard_texels = 1.0f;  // free texels on every side of a focused map (>= 1)
  float hysteresis = 0.25f;   // h: keep last frame's clusters while diameters <= d0 (1 + h)
  LispsmParams lispsm;
  float max_half_angle_deg = 60.0f;  // a cluster spanning more around the light is split
  float min_near = 1e-3f;            // near plane clamp, world units
};

// One light direction used for measuring (a spot's frustum or a cube face).
struct Direction {
  PinholeView view;  // the plain light frustum
  ConvexBody body;   // B = hull(camera frustum U light) n scene box n view (n cone)
  LispsmMap map;     // world -> normalized map coordinates over B
};

// Pairwise caster distances of one frame (indices follow the caster list).
struct CasterDistances {
  int32_t count = 0;
  std::vector<Direction> directions;
  // d(A, B) = max(|pp_min(A) - pp_min(B)|, |pp_max(A) - pp_max(B)|) (paper eq. 2)
  // of the casters' parts inside B, maximum over the directions whose B both
  // intersect; kFarDistance without one. count x count, row-major.
  std::vector<float> lispsm;
  // The same in the plain light views over their whole window, for casters
  // outside every B (they still need a cluster).
  std::vector<float> uniform;
  std::vector<uint32_t> seen;  // per caster: bit k set when it intersects B of direction k
  std::vector<uint8_t> lit;    // per caster: inside some light frustum (and a spot's cone)

  // The distance clustering uses: lispsm when both casters are seen in some
  // direction, uniform otherwise.
  float d(int i, int j) const {
    size_t k = size_t(i) * size_t(count) + size_t(j);
    return (seen[size_t(i)] && seen[size_t(j)]) ? lispsm[k] : uniform[k];
  }
};

// The directions of a light: one frustum for a spot of half-angle <= 60°,
// the six cube faces otherwise (point lights, wide spots), one orthographic
// view over the scene box for a directional light. Far planes reach the
// scene box.
std::vector<PinholeView> light_directions(const LightShape& light, const Box3& scene, int resolution,
                                          float min_near = 1e-3f);

// Distances of every caster pair for this light and camera.
CasterDistances caster_distances(const LightShape& light, const PinholeView& camera, const Box3& scene,
                                 const std::vector<Caster>& casters, const ClusterSettings& settings);

// Thesis Alg. 4.2 on caster indices: pairs of seen casters by descending
// distance; a caster joins the first cluster whose members are all within
// d0, else opens a cluster while fewer than m exist, else joins the nearest
// cluster (smallest maximum distance to its members). Casters in no pair
// (alone, or outside every B) are placed by the same rule afterwards; casters
// no light reaches join the nearest cluster. Every caster ends in exactly one
// cluster; at most max(m, 1) clusters.
std::vector<std::vector<int>> greedy_clusters(const CasterDistances& distances, float d0, int m);

struct Cluster {
  std::vector<int32_t> members;    // caster ids, ascending
  std::vector<PinholeView> views;  // focused frustum (several when split; none when unlit)
  bool split = false;              // spanned > ~120° around the light or contained it
  float diameter = 0.0f;           // largest distance of two lit members when formed
  int32_t previous = -1;           // index of the same member set in the previous result
  bool members_changed = true;     // no cluster of the previous result had these members
  bool views_changed = true;       // members changed or a focused frustum moved: rebuild its DSMs
};

struct Clustering {
  std::vector<Cluster> clusters;
  bool reclustered = true;             // false: the previous assignment was kept
  int32_t directions = 0;              // light directions measured (1 or 6)
  int32_t perspective_directions = 0;  // of those, how many used the LiSPSM warp
  size_t view_count() const {
    size_t n = 0;
    for (const Cluster& c : clusters) n += c.views.size();
    return n;
  }
};

// Clusters the casters of one light and focuses a frustum on each cluster.
Clustering cluster_casters(const LightShape& light, const PinholeView& camera, const Box3& scene,
                           const std::vector<Caster>& casters, const ClusterSettings& settings);

// As cluster_casters(), but keeps `previous`'s member sets while they still
// hold: the same casters, no more than m clusters, every cluster's diameter
// within max(d0, its diameter when formed) * (1 + h) (d0 (1 + h) while fewer
// than m clusters exist), and no two clusters close enough to merge (their
// union's diameter <= d0 / (1 + h)). Otherwise re-clusters and matches the
// new clusters to the previous ones by member set. Frusta are refocused
// either way; views_changed tells which clusters need their DSMs rebuilt.
Clustering update_clusters(const LightShape& light, const PinholeView& camera, const Box3& scene,
                           const std::vector<Caster>& casters, const ClusterSettings& settings,
                           const Clustering& previous);

}  // namespace cdsm::cluster
