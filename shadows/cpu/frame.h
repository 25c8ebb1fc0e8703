// One frame on the cpu backend: lights -> maps -> fragment lists -> DSMs,
// then the camera pass. Fragment lists come from a pluggable producer (the
// CPU ray caster or the OpenGL rasterizer).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "cdsm/scene.h"
#include "cpu/backend.h"
#include "cpu/scene_buffers.h"

namespace cdsm {

// Produces one view's fragment lists for the objects in the mask.
using FragmentProducer = std::function<void(const PinholeView&, ObjectMask, FragmentBuffers&)>;

FragmentProducer cpu_fragment_producer(const SceneView& scene);

PinholeView camera_view(const Camera& cam);

// A view from `eye` along `forward` with a square window of half-angle
// atan(tan_half); `up_hint` picks the roll. The window is widened by
// `guard` texels per side so bilinear taps at its border stay inside.
PinholeView light_view(Vec3 eye, Vec3 forward, Vec3 up_hint, float tan_half, int res, int guard,
                       float near, float far);

// The six 90-degree faces +X,-X,+Y,-Y,+Z,-Z of an omni light (one-texel guard band).
std::vector<PinholeView> cube_face_views(Vec3 eye, int res, float near, float far);

// Kernel lights and the maps each needs (spot: one view; spot wider than
// 120 degrees and point lights: six cube faces), covering `scene_box`.
struct LightSetup {
  std::vector<LightData> lights;
  std::vector<PinholeView> map_views;   // in map order
  std::vector<uint32_t> map_light;      // light index per map
};
LightSetup setup_lights(const Scene& scene, const Box3& scene_box, int res);

struct ShadowFrame {
  LightSetup setup;
  DsmBuffers dsm;
  std::vector<DsmBuildStats> map_stats;
  double fragments_ms = 0.0;
  double build_ms = 0.0;
  uint64_t fragments = 0;
  ShadowView view(const ShadowSettings& s) const;
};

// Builds every light's maps with the scene's shadow casters.
void build_shadow_frame(const Scene& scene, const SceneBuffers& sb, const FragmentProducer& produce,
                        ShadowFrame& frame);

}  // namespace cdsm
