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
  // render(): the fraction of rows started is stored in `progress`; when
  // `cancel` becomes true the remaining rows are skipped (the caller checks
  // `cancel` afterwards).
  std::atomic<float>* progress = nullptr;
  const std::atomic<bool>* cancel = nullptr;
};

class ReferenceRenderer {
 public:
  ReferenceRenderer(const SceneView& scene, std::vector<LightData> lights, ReferenceOptions opt = {});

  // Transmittance per colour channel from light `light` to p through shadow
  // casters; p's own surface (hits within a relative 1e-5 of p) does not
  // shadow it. The float forms give the grey value (grey_of: exact for grey
  // casters, the channel mean otherwise).
  Vec3 transmittance_rgb(int light, Vec3 p) const;
  float transmittance(int light, Vec3 p) const { return grey_of(transmittance_rgb(light, p)); }

  // Transmittance along an arbitrary segment a -> b (casters only); the
  // point b's own surface (hits within a relative 1e-5 of b) does not count.
  Vec3 transmittance_segment_rgb(Vec3 a, Vec3 b) const;
  float transmittance_segment(Vec3 a, Vec3 b) const { return grey_of(transmittance_segment_rgb(a, b)); }
  // The same through the casters in `members` only (a cluster's objects);
  // hits of object `own` within `own_window` before b are b's own surface
  // too (the error probe's taps: its own surface by identity).
  Vec3 transmittance_segment_rgb(Vec3 a, Vec3 b, ObjectMask members, uint32_t own = kNoObject,
                                 float own_window = 0.0f) const;

  // Renders the camera view into rgb (3 floats per pixel).
  void render(const CameraPassParams& params, std::vector<float>& rgb) const;

  const std::vector<LightData>& lights() const { return lights_; }

 private:
  struct Hit {
    float t;
    uint32_t object;
  };
  void hits_along(Vec3 org, Vec3 dir, float tmax, ObjectMask mask, std::vector<Hit>& out) const;
  // Optical depth per channel (double: the sum of many Simpson panels).
  struct Depth {
    double r = 0, g = 0, b = 0;
  };
  Depth optical_depth_volume(uint32_t volume, Vec3 org, Vec3 dir, float t0, float t1) const;

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
};

}  // namespace cdsm
