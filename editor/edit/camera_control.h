// The editor's camera controls as plain state (STYLE.md 14): orbit about a
// target, pan, zoom (dolly), fly, and framing a box — mouse and keyboard
// deltas in, a cdsm::Camera out. No window or ImGui here: unit-tested.
#pragma once

#include "cdsm/math.h"
#include "cdsm/scene.h"

namespace cdsm::editor {

struct OrbitCamera {
  Vec3 target{0, 0.5f, 0};
  float distance = 5.0f;
  float yaw_deg = 0.0f;     // about +y; 0 looks along -z
  float pitch_deg = 20.0f;  // above the horizon, in (-89, 89)
  // From a camera (position and target): the same view.
  static OrbitCamera from(const Camera& c);
  Vec3 position() const;
  // The camera: `base` with this position and target (fov, near, far, size kept).
  Camera apply(const Camera& base) const;

  // Mouse deltas in pixels of a viewport `height` pixels high.
  void orbit(float dx, float dy);                             // 0.3 degrees per pixel
  void pan(float dx, float dy, float fov_y_deg, int height);  // the target moves with the cursor
  void zoom(float wheel_steps);                               // 12% per step, towards the target
  // Fly: moves position and target together, in camera space (right, up, forward), world units.
  void fly(Vec3 right_up_forward);
  // Frames `box`: target at its centre, distance so its bounding sphere fills the vertical fov.
  void frame(const Box3& box, float fov_y_deg);
};

}  // namespace cdsm::editor
