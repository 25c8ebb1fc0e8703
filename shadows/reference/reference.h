// The reference renderer (DESIGN.md §7): its own code path — exact hits,
// fine marching, and for every shaded sample a shadow ray to each light with
// exact transmittance through surfaces, constant media and volumes. No
// shadow map, and no empty-space skipping of the DSM path: volumes are
// integrated everywhere inside the box that holds their grid's values. It
// shares only ray-triangle/BVH traversal, voxel sampling and the shading
// models with the DSM path, so image error isolates shadows.
#pragma once

#include <atomic>
#include <vector>

#include "hd/camera_pass.h"
#include "hd/lights.h"
#include "hd/scene_data.h"

namespace cdsm {

struct ReferenceOptions {
  float step_voxels = 0.25f;  // march step in voxels (<= 1/4: converged to 1e-4)
  // Shadow rays per lookup to a light with a size (LightData::size > 0):
  // stratified over the sphere light's disk facing the point, or over the
  // directional light's cone; rounded down to a square number of strata.
  int area_samples = 256;
  // render(): the fraction of rows started is stored in `progress`; when
  // `cancel` becomes true the remaining rows are skipped (the caller checks
  // `cancel` afterwards).
  std::atomic<float>* progress = nullptr;
  const std::atomic<bool>* cancel = nullptr;
};

class ReferenceRenderer {
 public:
  ReferenceRenderer(const SceneView& scene, std::vector<LightData> lights, ReferenceOptions opt = {});

  // How a shadow ray treats what it meets at its end b (DESIGN.md §8, the
  // rule the maps' lookups follow, hd/dsm.h TexelRead):
  //   a point (a volume sample): every hit before b counts;
  //   a surface: its own surface is left out — the hit of object `own`
  //   nearest to b within `own_window` of it (kNoObject: none) — and
  //   nothing else: every hit before b by more than kRelativeDepthOffset of
  //   the distance counts, and of the hits touching b (within it) those of
  //   another object whose rank (hd/compress.h SurfaceRank) is below the
  //   receiver's (its own hit's; an entry without one).
  struct End {
    bool surface = false;
    uint32_t own = kNoObject;
    float own_window = 0.0f;
  };
  // The End of a shaded receiver at distance `dist` from the light: its own
  // hit lies at b up to float rounding (1e-3 of the distance is searched;
  // the nearest own hit is the one left out).
  static End end_of(const Receiver& r, float dist);

  // Transmittance per colour channel from light `light` to receiver r
  // through shadow casters (grey_of() of it: exact for grey casters, the
  // channel mean otherwise); or to a point (no surface). A light with a
  // size: the mean over area_samples shadow rays to points of its area.
  Vec3 transmittance(int light, const Receiver& r) const;
  Vec3 transmittance(int light, Vec3 p) const;

  // Where light L's shadow ray to p starts: the light's position, or for a
  // directional light the point up its beam (against `direction`) just
  // outside the scene's bounds (parallel shadow rays).
  Vec3 light_origin(const LightData& L, Vec3 p) const;
  Vec3 outside_along(Vec3 p, Vec3 u) const;  // past the scene's box from p along unit u

  // Where shadow ray k of n (n a square number) to p starts on light L's
  // area: stratum k of a sqrt(n) x sqrt(n) grid, jittered by a hash of p
  // and k, mapped onto the disk (concentric map) of the sphere light facing
  // p, or onto the directional light's cone. A light without a size: its
  // one origin.
  Vec3 area_origin(const LightData& L, Vec3 p, int k, int n) const;
  int area_sample_count(const LightData& L) const;

  // Transmittance along an arbitrary segment a -> b (casters only), b a point.
  Vec3 transmittance_segment(Vec3 a, Vec3 b) const;
  // The same through the casters in `members` only (a cluster's objects),
  // with b's End (the error probe's taps: each on its receiver's plane).
  Vec3 transmittance_segment(Vec3 a, Vec3 b, ObjectMask members, const End& end) const;

  // Renders the camera view into rgb (3 floats per pixel).
  void render(const CameraPassParams& params, std::vector<float>& rgb) const;

  const std::vector<LightData>& lights() const { return lights_; }

 private:
  struct Hit {
    float t;
    uint32_t object;
    uint32_t rank;  // SurfaceRank of the crossing
  };
  void hits_along(Vec3 org, Vec3 dir, float tmax, ObjectMask mask, std::vector<Hit>& out) const;
  // Optical depth per channel (double: the sum of many Simpson panels).
  struct Depth {
    double r = 0, g = 0, b = 0;
  };
  Depth optical_depth_volume(uint32_t volume, Vec3 org, Vec3 dir, float t0, float t1) const;
  void clip_to_value_box(uint32_t volume, Vec3 index_org, Vec3 index_dir, float& ta, float& tb) const;

  SceneView scene_;
  std::vector<LightData> lights_;
  ReferenceOptions opt_;
  std::vector<uint32_t> caster_words_;
  // Per volume, the index-space box outside which every sample reads only
  // the background (the grid's data plus the one-voxel reach of trilinear
  // filtering), found from the grid itself, not from the DSM path's
  // macro-cells: the reference integrates everything inside it.
  struct ValueBox {
    Vec3 lo, hi;
  };
  std::vector<ValueBox> value_boxes_;
  Vec3 scene_lo_{0, 0, 0}, scene_hi_{0, 0, 0};  // the triangles' bounds (empty scene: a point)
};

}  // namespace cdsm
