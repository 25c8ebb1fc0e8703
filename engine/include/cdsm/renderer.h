// The research harness's renderer (cdsm render, cdsm bench, the tests): one
// call renders a scene's camera view with clustered deep shadow maps and
// reports what it cost and, on request, how wrong it is against the exact
// reference. It drives a ShadowSystem (cdsm/shadow_system.h, what an engine
// links) and keeps it across calls, so a sequence of render() calls
// rebuilds only what changed.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "cdsm/backend.h"
#include "cdsm/frame_stats.h"
#include "cdsm/image.h"
#include "cdsm/scene.h"

namespace cdsm {

struct RenderOptions {
  Backend backend = Backend::Cpu;
  FragmentSource fragments = FragmentSource::Auto;  // Auto: GL when a context can be made
  bool compare_reference = false;                   // transmittance + image error against the reference
  bool measure_popping = false;                     // |dT| at the last frame's receivers when maps changed (costs a
                                                    // 48x48 receiver walk and keeps replaced maps one frame)
  int error_samples = 20000;                        // shaded points for the transmittance error
  float reference_step_voxels = 0.25f;
  RenderProgress* progress = nullptr;  // optional: the reference's progress, cancellation
};

class Renderer {
 public:
  Renderer();
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Renders the scene's camera. Throws cdsm::Error on invalid content.
  // With compare_reference, also renders the reference image of the same
  // view (costly: use small sizes) and fills stats->transmittance/image.
  Image render(const Scene& scene, const RenderOptions& options, FrameStats* stats = nullptr);

  // The reference image alone (no shadow maps).
  Image render_reference(const Scene& scene, const RenderOptions& options, FrameStats* stats = nullptr);

  // The transmittance error of the DSM path at sampled shaded points.
  TransmittanceError transmittance_error(const Scene& scene, const RenderOptions& options);

  // The reference image of the last compare_reference render (empty otherwise).
  const Image& last_reference() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cdsm
