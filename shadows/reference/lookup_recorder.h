// The error probe's view of the camera pass: the camera pass's own
// visibility functor, wrapped so that every shadow lookup it makes (light,
// receiver: point, plane, own step; result) is recorded with the compositing weight of the
// point it shades. The probe then compares exactly what the image used —
// same bias, same sample classification (surface, receive-only surface,
// volume sample), same filtering, same cluster combination — against the
// reference; there is no second classification to drift from the camera
// pass (issue "Shadows that are right where they should be").
#pragma once

#include <vector>

#include "hd/camera_pass.h"

namespace cdsm {

struct RecordedLookup {
  int light;
  Receiver at;         // point, plane, own step
  Vec3 transmittance;  // what the camera pass used, per colour channel
  float weight;        // the shaded point's compositing weight
};

// Wraps the camera pass's visibility functor; lookups wait in `pending`
// until LookupRecorder::shaded() gives them their point's weight.
template <class Visibility>
struct RecordingVisibility {
  const Visibility& inner;
  std::vector<RecordedLookup>* pending;
  Vec3 operator()(int light, const Receiver& r) const {
    const Vec3 t = inner(light, r);
    pending->push_back({light, r, t, 0.0f});
    return t;
  }
};

// The camera pass's recorder: shade_point() made the pending lookups for
// the point now reported; they are kept when its weight is not negligible.
struct LookupRecorder {
  std::vector<RecordedLookup>* pending;
  std::vector<RecordedLookup>* out;
  float min_weight = 1e-4f;
  void shaded(Vec3, Vec3, bool, float weight) {
    if (weight > min_weight)
      for (RecordedLookup& l : *pending) {
        l.weight = weight;
        out->push_back(l);
      }
    pending->clear();
  }
};

// Shades pixel (px, py) as the camera pass does, through `visibility`, and
// appends the lookups its shaded points made to `out`.
template <class Visibility>
void record_pixel_lookups(const SceneView& s, Span<const LightData> lights, const Visibility& visibility,
                          const CameraPassParams& cam, Span<Fragment> frags, int px, int py,
                          std::vector<RecordedLookup>& out, WalkStats& ws) {
  std::vector<RecordedLookup> pending;
  RecordingVisibility<Visibility> rv{visibility, &pending};
  LookupRecorder rec{&pending, &out};
  shade_pixel(s, lights, rv, cam, frags, px, py, rec, ws);
}

}  // namespace cdsm
