// The backend-neutral frame (DESIGN.md §5): lights -> map plans ->
// (clusters ->) map cache -> build or reuse -> the lookup over the frame's
// maps. It works on the compiled scene (SceneBuffers) and the scene model's
// lights, camera and settings, and talks to a ShadowBackend
// (shadows/backend/backend.h) for every map it builds or frees; fragment
// lists come from a pluggable producer (the CPU ray caster or the OpenGL
// rasterizer). Maps are cached by what they were built from — their view,
// their members' identities and content generations, the map settings —
// so a frame rebuilds only maps whose inputs changed.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "backend/backend.h"
#include "cdsm/frame_stats.h"
#include "cdsm/renderer.h"
#include "cdsm/scene.h"
#include "cluster/clustering.h"
#include "scene_compile.h"

namespace cdsm {

// One view whose fragment lists are wanted: the view and the objects drawn
// into it.
struct ListsRequest {
  PinholeView view;
  ObjectMask mask;
  // The lists may be made without the host reading their count (GL lists
  // into a backend on the GL context's device:
  // ShadowBackend::lists_from_gl_unchecked), checked by the build that
  // reads them (ListsShortError): the light views' and render()'s camera
  // view's.
  bool unchecked = false;
  // Which lists these are from frame to frame (a light view's map plan, the
  // camera; 0 none): the backend guesses the count of unchecked lists from
  // the last lists of the same slot and size.
  uint64_t slot = 0;
};
// The camera's lists' slot (ListsRequest::slot).
inline constexpr uint64_t kCameraListsSlot = uint64_t(1) << 62;
// The backend's name for slot `slot`'s lists of width x height pixels
// (ShadowBackend::lists_from_gl's slots; 0 for slot 0: none).
inline uint64_t lists_slot_key(uint64_t slot, int32_t width, int32_t height) {
  if (slot == 0) return 0;
  return (slot * 0x9e3779b97f4a7c15ull) ^ (uint64_t(uint32_t(width)) << 32 | uint64_t(uint32_t(height)));
}
// Produces the fragment lists of `n` views into `backend`, ids[i] view i's
// (held there until the caller frees them); all or nothing. Views produced
// together share the producer's waits (the GL rasterizer counts every view,
// scans and reads back once, fills every view, hands them over once).
using FragmentProducer =
    std::function<void(ShadowBackend& backend, const ListsRequest* requests, size_t n, ListsId* ids)>;
// One view's lists through `produce` (ListsRequest::unchecked as given).
ListsId produce_lists(const FragmentProducer& produce, ShadowBackend& backend, const PinholeView& view, ObjectMask mask,
                      bool unchecked = false, uint64_t slot = 0);
// ids[i] = one(requests[i]) for each view in turn; all or nothing (the ones
// made are freed when one fails).
template <class One>
void produce_each(ShadowBackend& backend, const ListsRequest* requests, size_t n, ListsId* ids, One&& one) {
  size_t made = 0;
  try {
    for (; made < n; ++made) ids[made] = one(requests[made]);
  } catch (...) {
    for (size_t i = 0; i < made; ++i) backend.free_lists(ids[i]);
    throw;
  }
}

// The exact ray caster on the host's threads, its lists handed to the
// backend (moved in where the backend's memory is host memory).
FragmentProducer cpu_fragment_producer(const SceneView& scene);

PinholeView camera_view(const Camera& cam);

// A view from `eye` along `forward` with a square window of half-angle
// atan(tan_half); `up_hint` picks the roll. The window is widened by
// `guard` texels per side so bilinear taps at its border stay inside.
PinholeView light_view(Vec3 eye, Vec3 forward, Vec3 up_hint, float tan_half, int res, int guard, float near, float far);

// The six 90-degree faces +X,-X,+Y,-Y,+Z,-Z of an omni light (one-texel guard band).
std::vector<PinholeView> cube_face_views(Vec3 eye, int res, float near, float far);

// The kernels' light (radiance, cone) of a scene light; its maps unset.
LightData light_data(const Light& l);

// The layout of the scene's shadow settings.
DsmLayoutParams dsm_layout_params(const ShadowSettings& s);

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
LightSetup setup_lights(const std::vector<Light>& lights, const SceneBuffers& sb, int res);

// Per light, the clusters of the current frame (for hysteresis and stats).
struct LightClusters {
  cluster::Clustering clustering;
  bool clustered = false;       // false: m = 1, or fell back to unclustered maps
  std::string fallback_reason;  // why clustering fell back
  int32_t count = 0;            // the m it was clustered with (auto clusters: the one chosen)
  std::vector<LightClusterStats::CountTrial> count_trials;  // auto clusters
  std::string count_reason;                                 // auto clusters
};

// What one frame's maps are built from, besides the compiled scene.
struct FrameInputs {
  const SceneBuffers* scene = nullptr;
  std::vector<Light> lights;
  std::vector<uint64_t> light_ids;           // per light: a stable identity (handles)
  std::vector<uint64_t> object_ids;          // per compiled object: a stable identity
  std::vector<uint64_t> object_generations;  // per compiled object: its content generation
  Camera camera;
  ShadowSettings settings;
  // Auto resolution: bytes the maps' texels may take (memory_budget.h
  // map_texel_budget: the limit less everything else the frame needs).
  double map_texel_budget = 1e300;
  bool keep_previous = false;  // keep the last frame's replaced maps alive one frame (popping probe)
  // Keep the light-view fragment lists of this frame's maps for the next
  // frame: a map rebuilt from the same view, members and geometry (an ε or
  // layout edit) takes them instead of producing them again.
  // `geometry_epoch` changes whenever anything the producer reads may
  // have changed (any compiled content, the producer itself).
  bool keep_fragments = false;
  uint64_t geometry_epoch = 0;
  // Optional progress of the builds (read by other threads): maps to build
  // this frame, and built so far.
  std::atomic<uint32_t>* maps_to_build = nullptr;
  std::atomic<uint32_t>* maps_built = nullptr;
};

// State kept across frames: the built maps by key, the clusters per light.
struct MapCache {
  struct Entry {
    uint64_t key = 0;
    MapId id = 0;
    DsmBuildStats stats;
    // Its slot, to tell why a replacement was built.
    uint64_t light_id = 0;
    uint32_t slot = 0;        // map index within its light
    uint64_t light_hash = 0;  // the light's kernel data
    uint64_t settings_hash = 0;
    PinholeView view{};
    std::vector<uint64_t> member_ids;
  };
  std::vector<Entry> entries;
  std::vector<MapId> retired;  // replaced last frame, freed at the next (keep_previous)
  struct LightState {
    LightClusters clusters;
    uint64_t signature = 0;  // a change drops the hysteresis
    std::vector<int> rungs;  // auto resolution: each map's ladder rung (its hysteresis)
  };
  std::unordered_map<uint64_t, LightState> lights;  // by light identity
  DsmLayoutParams layout;                           // of the stored maps
  // Unsorted fragment lists of the last frame's maps (keep_fragments), held
  // by the backend.
  struct KeptFragments {
    uint64_t key = 0;  // view, members and their generations, geometry epoch
    ListsId lists = 0;
    bool taken = false;
  };
  std::vector<KeptFragments> fragments;
  // Frees every map and kept list (the backend's memory) and forgets the
  // clusters.
  void clear(ShadowBackend& backend);
};

struct ShadowFrame {
  LightSetup setup;
  std::vector<LightClusters> clusters;          // per light
  std::vector<MapId> maps;                      // per map: the backend's map
  std::vector<DsmMap> headers;                  // per map: its header (refreshed by refresh_headers)
  std::vector<DsmBuildStats> map_stats;         // per map (reused maps: their build's stats)
  std::vector<uint8_t> map_rebuilt;             // per map: built this frame
  std::vector<MapResolutionStats> resolutions;  // per map: its resolution and why
  std::vector<MapRebuild> rebuilds;             // why each rebuilt map was rebuilt
  uint32_t rebuilt = 0, reused = 0, freed = 0;
  bool previous_kept = false;  // the last frame's maps are all still stored (popping probe)
  double fragments_ms = 0.0;
  uint32_t fragment_lists_reused = 0;  // rebuilt maps whose lists came from MapCache::fragments
  uint32_t fragment_lists_redone = 0;  // lists made again: made unchecked, they did not fit their guess
  uint64_t fragment_cache_bytes = 0;   // MapCache::fragments after this frame
  double build_ms = 0.0;
  double cluster_ms = 0.0;
  uint64_t fragments = 0;
  const ShadowBackend* backend = nullptr;  // holds the maps
  // What the user should hear about this frame's maps (one line each, at
  // most one per light): e.g. a map whose casters are all smaller than a texel.
  std::vector<std::string> warnings;
  // The lookup over this frame's maps with the lookup settings of `s`.
  // `with_storage` false: storage left empty (its caller fetches it, or
  // only its extent: engine/src/system_gl.h).
  ShadowView view(const ShadowSettings& s, bool with_storage = true) const;
  void refresh_headers();
};

// The lookup settings of `s` (filtering, penumbra, the receivers' offsets)
// in v: every ShadowView takes them from here.
void set_lookup(ShadowView& v, const ShadowSettings& s);

// Builds every light's maps with the scene's shadow casters; with
// settings.clustering(), one focused map per cluster (thesis Alg. 4.2).
// Maps whose key is in `cache` are reused; the others are built by
// `backend` and replaced ones freed; the cache is updated.
void build_shadow_frame(const FrameInputs& in, const FragmentProducer& produce, ShadowBackend& backend, MapCache& cache,
                        ShadowFrame& frame);

}  // namespace cdsm
