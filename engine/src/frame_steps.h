// The steps of build_shadow_frame (frame.h) that live in their own files:
// planning a frame's maps (map_plans.cpp) and what a map's casters are like
// (caster_checks.cpp). frame.cpp matches the plans against the map cache
// and builds what is missing.
#pragma once

#include <cstdint>
#include <unordered_map>

#include "frame.h"

namespace cdsm {

// Step 1: which maps this frame needs — each light's views (cube faces,
// parallel splits, clusters with their hysteresis) into frame.setup and
// frame.clusters, the maps the last frame retired freed first; returns the
// light states the cache keeps for the next frame.
std::unordered_map<uint64_t, MapCache::LightState> plan_maps(const FrameInputs& in, ShadowBackend& backend,
                                                             MapCache& cache, ShadowFrame& frame);

// The depth extent of a map's casters along its rays (radial from a point
// light, axial for parallel rays): from the nearest point of their boxes to
// the farthest corner. The deep opacity maps' default layers span it.
float caster_depth_extent(const MapPlan& plan, const SceneBuffers& sb);

// One warning per light (frame.warnings) with a map whose every caster
// projects to less than a texel.
void warn_subtexel_casters(const FrameInputs& in, ShadowFrame& frame);

}  // namespace cdsm
