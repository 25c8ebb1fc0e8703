// Auto resolution (ShadowSettings::resolution == kAutoResolution, the scene
// file's "resolution": "auto"): each map's texels per side chosen from the
// screen. The camera's receivers are sampled (a grid of camera rays through
// the scene's BVH, every surface the eye sees with weight); at each, the
// world size of an image pixel and of a map texel are compared, and a map
// gets the resolution at which its receivers' median sees
// `texels_per_pixel` texels across a pixel, rounded to a ladder of powers
// of 2^(1/2) below `max_resolution`, with hysteresis: a moving camera
// changes a map's rung only when the wanted resolution moved three quarters
// of a step past it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "cdsm/frame_stats.h"
#include "cdsm/scene.h"
#include "frame.h"

namespace cdsm {

// A surface point the camera sees and the world size of one image pixel
// there (across the view ray).
struct CameraReceiver {
  Vec3 p;
  float pixel;
};

// About `samples` camera rays on a regular grid of pixel centres; along each,
// the surfaces in front of the eye until what they let through falls below
// 5% (those it sees with a weight of at least 5%), and where it enters or
// leaves a medium (the volume samples its march shades lie between).
std::vector<CameraReceiver> sample_camera_receivers(const SceneBuffers& sb, const Camera& camera, int samples);

inline constexpr int32_t kSmallestAutoResolution = 16;  // the ladder's bottom (rung 0)

// The ladder: 16 * 2^(k/2) texels per side, rounded (16, 23, 32, 45, 64, ...).
int32_t resolution_rung(int k);
// The rung nearest to `texels` (in log scale), and that position unrounded.
double rung_position(double texels);

// Auto clusters: the rung position (rung_position) a map can reach — the
// ladder's top within max_resolution (auto resolution), or the fixed
// resolution's.
double reachable_rung(const ShadowSettings& s);
// What light `li`'s maps in `setup` ask for: the texels per side its
// neediest map wants at the median of the receivers it serves (at
// s.texels_per_pixel), over the maps that serve at least 0.5% of
// `receivers` (0 when none does), and the texels all its maps would have
// (auto resolution: each at its rung within the ladder, before any budget;
// else the fixed resolution's).
struct LightDemand {
  double wanted_texels = 0.0;
  double texels = 0.0;
};
LightDemand light_demand(const ShadowSettings& s, const std::vector<CameraReceiver>& receivers, const LightSetup& setup,
                         uint32_t li);

// Auto clusters: which of the cluster counts tried a light takes.
struct CountTrial {
  double need = 0.0;    // rung position its neediest map wants (-inf: no map seen)
  double texels = 0.0;  // of all its maps
  double maps = 1.0;
};
struct CountChoice {
  size_t pick = 0;
  const char* reason = "";
};
// Eligible are the counts whose need is within `reach` (the reachable rung
// plus half a step), or where none is, within a step of the best need. Of
// those the fewest, unless more maps cost less — texels x maps lower (twice
// the maps for less than half the texels) and at least kMinTexelSaving
// texels fewer (with a fixed resolution never: the fewest that reach).
// `kept` (the index of the last frame's count, -1: none) stays while its
// need is within 3/4 of a step of the bound and, against a pick with more
// maps, it no longer reaches or the pick saves less than twice what is
// asked above; against a pick with fewer maps, the pick reaches by less than
// 3/4 of a step or the kept count still saves half of what is asked.
inline constexpr double kMinTexelSaving = 512.0 * 512.0;
CountChoice pick_cluster_count(const std::vector<CountTrial>& trials, double reach, int kept);

// Sets each map of `setup` to its resolution (the view's width and height,
// its window widened so that its one-texel guard band stays a texel),
// keeping a map's previous rung (`previous[light][map]`, -1: none) within
// the hysteresis; while the maps' texels (at `bytes_per_texel`) exceed
// `budget_bytes`, the map serving the fewest receivers steps down a rung.
// Writes the rungs chosen to `rungs` and the figures to `stats` (one per
// map, in map order).
void choose_map_resolutions(const ShadowSettings& s, const std::vector<CameraReceiver>& receivers,
                            const std::vector<std::vector<int>>& previous, double budget_bytes, double bytes_per_texel,
                            LightSetup& setup, std::vector<std::vector<int>>& rungs,
                            std::vector<MapResolutionStats>& stats);

}  // namespace cdsm
