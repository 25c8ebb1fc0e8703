// One frame on the cpu backend: lights -> (clusters ->) maps -> fragment
// lists -> DSMs, with a cache that rebuilds a map only when what it was
// built from changed. Fragment lists come from a pluggable producer (the
// CPU ray caster or the OpenGL rasterizer).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "cdsm/scene.h"
#include "cluster/clustering.h"
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

// One map to build: a view and the caster objects it contains.
struct MapPlan {
  PinholeView view;
  uint32_t light = 0;
  std::vector<uint32_t> members;  // object indices (casters) in this map
};

// Kernel lights and the maps each needs.
struct LightSetup {
  std::vector<LightData> lights;
  std::vector<MapPlan> maps;  // in map order; lights[i] owns maps [first_map, first_map + map_count)
};

// Unclustered maps: a spot's cone (wider than 120 degrees: six cube faces
// with the cone mask), six faces for a point light; every caster in each.
LightSetup setup_lights(const Scene& scene, const SceneBuffers& sb, int res);

// Per light, the clusters of the current frame (for hysteresis and stats).
struct LightClusters {
  cluster::Clustering clustering;
  bool clustered = false;        // false: m = 1, or fell back to unclustered maps
  std::string fallback_reason;   // why clustering fell back
};

// What a map was built from: its view, its members' content, the settings.
uint64_t map_key(const MapPlan& plan, const std::vector<uint64_t>& object_hashes, const ShadowSettings& s);

// Content hash of every object (world triangles, material, interior, volume data).
std::vector<uint64_t> object_hashes(const SceneBuffers& sb);

// State kept across frames: the built maps by key, and the clusters.
struct ShadowCache {
  struct Entry {
    uint64_t key = 0;
    DsmBuffers dsm;  // one map
    DsmBuildStats stats;
  };
  std::vector<Entry> entries;
  std::vector<LightClusters> clusters;  // per light of the last frame
  uint64_t light_signature = 0;         // lights of the last frame (a change drops hysteresis)
};

struct ShadowFrame {
  LightSetup setup;
  std::vector<LightClusters> clusters;  // per light
  DsmBuffers dsm;                       // all maps of the frame
  std::vector<DsmBuildStats> map_stats; // per map (reused maps: their build's stats)
  std::vector<uint8_t> map_rebuilt;     // per map: built this frame
  uint32_t rebuilt = 0, reused = 0;
  double fragments_ms = 0.0;
  double build_ms = 0.0;
  double cluster_ms = 0.0;
  uint64_t fragments = 0;
  ShadowView view(const ShadowSettings& s) const;
};

// Builds every light's maps with the scene's shadow casters; with
// scene.shadows.max_clusters > 1, one focused map per cluster (thesis Alg.
// 4.2). Maps whose key is in `cache` are reused; the cache is updated.
void build_shadow_frame(const Scene& scene, const SceneBuffers& sb, const FragmentProducer& produce,
                        ShadowCache& cache, ShadowFrame& frame);

// Appends the maps of `src` to `dst` (headers and nodes re-based).
void append_dsm(DsmBuffers& dst, const DsmBuffers& src);

}  // namespace cdsm
