// What a frame cost and did: FrameStats, filled by ShadowSystem::update()
// and render() (engine figures: times, memory, maps rebuilt and why, bytes
// moved) and by the research harness's Renderer (the error against the
// exact reference, popping). Plain values, cheap to copy.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "cdsm/image.h"
#include "cdsm/scene.h"

namespace cdsm {

// Time inside one launch name of a backend's kernels (the cuda backend:
// CUDA events around every launch; the CPU threads: the wall clock).
struct KernelTime {
  std::string name;  // "light pass: write", "camera pass", ...
  double ms = 0.0;
  uint64_t launches = 0;
};

struct StageTimes {
  double compile_ms = 0.0;    // scene -> buffers + BVH
  double fragments_ms = 0.0;  // light-view fragment lists (all maps)
  double dsm_build_ms = 0.0;  // segments -> samples -> compressed nodes
  double camera_fragments_ms = 0.0;
  double camera_ms = 0.0;     // camera pass (lookups, shading, compositing)
  double reference_ms = 0.0;  // reference image / error evaluation
  double total_ms = 0.0;
  // The same stages measured inside the backend's kernels: on the cuda
  // backend CUDA events around each launch (device time, without uploads,
  // read-backs and host work), on the exec backend over CPU threads the wall
  // clock of each parallel_for; all 0 on the cpu backend (its stages are the
  // host times above). The map build's launches hold sorting, segments and
  // compression together (one per-texel function: count, reserve, write;
  // spilled texels, layouts and store compaction included).
  double kernel_fragments_ms = 0.0;         // the CUDA fragment producer, light views (--fragments cuda)
  double kernel_dsm_build_ms = 0.0;         // light pass, compaction
  double kernel_camera_fragments_ms = 0.0;  // the CUDA fragment producer, camera view
  double kernel_camera_ms = 0.0;            // camera pass
  std::vector<KernelTime> kernels;          // every launch name of this frame, in first-launch order
};

struct DsmMemory {
  uint64_t maps = 0;
  uint64_t texels = 0;
  uint64_t nodes = 0;
  uint64_t index_bytes = 0;    // per-texel headers
  uint64_t node_bytes = 0;     // nodes used
  uint64_t slack_bytes = 0;    // allocated but unused node memory
  uint64_t tag_bytes = 0;      // the node slots' surface tags (2 bytes each: which surface made a step)
  uint64_t pyramid_bytes = 0;  // blocker pyramids of the maps of lights with a size (about 1.3 bytes per texel)
  double avg_nodes_per_texel = 0.0;
  uint32_t max_nodes_per_texel = 0;
  uint64_t overflow_texels = 0;  // re-compressed to fit the per-texel buffer
  uint64_t rewalked_texels = 0;  // light rays walked twice: more nodes than the first walk's buffer holds
  float max_extra_error = 0.0f;  // error those re-compressions added (bound)
  // Per map kind: grey maps store scalar nodes (8 bytes; chunked slots 12),
  // RGB maps (a coloured caster among their members) 16 bytes (chunked 20).
  uint64_t rgb_maps = 0;
  uint64_t grey_bytes = 0;  // index + node + slack + tag + pyramid bytes of the grey maps
  uint64_t rgb_bytes = 0;   // the same of the RGB maps
  uint64_t rgb_nodes = 0;   // nodes in RGB maps (of `nodes`)
};

// Compositing-weighted statistics of one kind of transmittance error.
struct ErrorSummary {
  double mean = 0.0;
  double p99 = 0.0;  // weighted 99th percentile
  double max = 0.0;
  double rmse = 0.0;
};

// The error of the shadow lookups the camera pass made (every shaded point x
// lit light, sampled), decomposed at each point with the filtered exact
// reference T_f = sum_i w_i T_exact(tap_i): the exact transmittance along
// each lookup tap's texel-centre light ray at the depth the tap reads (the
// receiver's plane, or a volume sample's depth), through the tap's map's
// members only, with the lookup's own weights, combined over maps as the
// lookup combines them (thesis eq. 3.12).
//   map error        |T_dsm - T_f|   compression, offsets, depth sampling: what eps controls
//   resolution error |T_f - T_exact| filtering at texel spacing: what resolution and clustering control
//   total            |T_dsm - T_exact|
// A point is an edge point when its taps' exact transmittances and its own
// differ by more than 0.05 (a shadow edge within a texel, or a feature
// finer than one), else interior.
struct ErrorClass {
  double share = 0.0;  // fraction of the points in this class
  ErrorSummary map, resolution, total;
};

struct TransmittanceError {
  uint64_t points = 0;  // lookups compared
  double mean = 0.0;    // total error over all points (as `total`)
  double p99 = 0.0;
  double max = 0.0;
  double rmse = 0.0;
  ErrorSummary map, resolution, total;  // over all points
  ErrorClass edge, interior;
  // Every figure above is the largest over the colour channels of that
  // figure per channel (grey scenes: the one value); the mean total error
  // per channel:
  double channel_mean[3] = {0, 0, 0};
};

// The clusters of one light in a frame (thesis Alg. 4.2).
struct LightClusterStats {
  bool clustered = false;  // false: unclustered maps (m = 1 or a fallback)
  std::string fallback_reason;
  bool reclustered = false;               // membership recomputed this frame (else kept by hysteresis)
  std::vector<std::vector<int>> members;  // object indices per cluster
  std::vector<uint8_t> changed;           // per cluster: member set or frustum changed since the last frame
  uint32_t maps = 0;                      // DSMs of this light
  int32_t directions = 0;                 // light directions the clustering measured (1 or 6)
  int32_t warped_directions = 0;          // of those, measured in LiSPSM space (the rest: uniform light
                                          // space, where the view is parallel to the light)
  // Auto clusters (ShadowSettings::auto_clusters): each count tried, the
  // one chosen and why.
  struct CountTrial {
    int32_t clusters = 0;        // m tried (1: the light's unclustered maps)
    uint32_t maps = 0;           // maps it gave
    double wanted_texels = 0.0;  // texels per side its neediest map wants (0: no map seen)
    double texels = 0.0;         // texels of all its maps (auto resolution: at their rungs)
    bool reaches = false;        // within the size limit (half a ladder step)
  };
  std::vector<CountTrial> count_trials;
  int32_t chosen_clusters = 0;  // 0: not auto
  // Why (pick_cluster_count): the least texels x maps of the counts that
  // reach the density, or within a ladder step of the best where none
  // does, or kept from the last frame (hysteresis).
  std::string count_reason;
};

// One map's resolution (ShadowSettings::resolution; auto: chosen from the
// screen: about texels_per_pixel texels across a pixel at its median receiver).
struct MapResolutionStats {
  uint32_t light = 0;      // light index of the frame
  int32_t resolution = 0;  // texels per side
  // Auto resolution only: the camera's sampled receivers this map serves,
  // and the texels across one image pixel there (median, 5th percentile).
  uint32_t receivers = 0;
  double texels_per_pixel_median = 0.0;
  double texels_per_pixel_p5 = 0.0;
  // Why this resolution: "fixed" (the setting), "target" (about
  // texels_per_pixel at the median receiver), "ladder top" (max_resolution),
  // "ladder bottom", "not seen" (no sampled receiver: the smallest useful),
  // "budget" (stepped down to keep the maps within shadows.max_memory, the
  // maps serving the fewest receivers first).
  std::string limit = "fixed";
};

// Change of shadowing at static receivers when a light's maps changed
// (re-clustering makes shadows "pop", thesis §6.1): |T_new - T_old| at the
// previous frame's sampled surface points.
struct PoppingStats {
  bool measured = false;
  uint64_t points = 0;
  double mean = 0.0;
  double p99 = 0.0;
  double max = 0.0;
};

// Why a map was built this frame (checked in this order against the map
// the same light had in the same place the frame before).
enum class RebuildReason : uint32_t {
  New = 0,       // no map in that place before (first frame, a light added, more clusters)
  Settings = 1,  // the map settings changed (epsilon, resolution, layout, method)
  Light = 2,     // the light moved or changed
  Members = 3,   // its caster set changed (clustering, objects added, removed or moved across)
  Frustum = 4,   // the same casters, a new frustum (focusing followed them or the camera)
  Content = 5,   // the same casters and frustum, a caster's content changed (moved, edited)
};
inline constexpr int kRebuildReasons = 6;
const char* to_string(RebuildReason reason);
// Auto clusters: the count chosen, why, and the counts tried, in a line
// ("" when the light's count was not chosen automatically).
std::string cluster_count_text(const LightClusterStats& c);

struct MapRebuild {
  uint32_t light = 0;  // light index of the frame
  uint32_t map = 0;    // map index within that light
  RebuildReason reason = RebuildReason::New;
};

// What the frame's update did to the persistent state (ShadowSystem).
struct UpdateStats {
  uint32_t frames_planned = 0;         // 1: lights, clusters and maps planned again (an edit since the last update)
  uint32_t full_compiles = 0;          // geometry arrays and BVH rebuilt from every object (objects added / removed)
  uint32_t objects_compiled = 0;       // objects whose world-space data was recomputed (moved, added)
  uint32_t volumes_compiled = 0;       // volumes whose grid was compiled (voxels copied, macro-cells built)
  uint32_t bvh_refits = 0;             // BVH refitted after objects moved
  uint32_t bvh_rebuilds = 0;           // BVH built (full compiles, or a refit that degraded the tree)
  uint64_t gl_upload_bytes = 0;        // bytes uploaded to GL buffers (scene geometry)
  uint32_t maps_freed = 0;             // maps whose memory was released
  uint32_t fragment_lists_reused = 0;  // maps rebuilt from kept fragment lists (SystemOptions::keep_fragment_lists)
  uint32_t fragment_lists_redone = 0;  // light views' GL lists made again: handed to the device without a count
                                       // read, they had more fragments than the capacity guessed from earlier frames
  uint64_t fragment_cache_bytes = 0;   // the kept fragment lists, allocated
  uint32_t rebuilt_by_reason[kRebuildReasons] = {};  // maps_rebuilt split by RebuildReason
  std::vector<MapRebuild> rebuilds;                  // every rebuilt map and why
  uint64_t map_store_bytes = 0;                      // the backend's map store, allocated (holes included)
  uint64_t map_live_bytes = 0;                       // of which in maps of this frame (or kept for the popping probe)
  uint64_t scene_bytes = 0;                          // the compiled scene's arrays (triangles, BVH, voxels), allocated
  uint64_t gl_scene_bytes = 0;                       // GL buffers holding the scene geometry, allocated
  // Maps in GL buffers (SystemOptions::gl_context = Application):
  uint64_t gl_map_upload_bytes = 0;  // host -> GL bytes of map data this update (new maps' nodes,
                                     // the frame block when it changed; 0 when nothing changed)
  uint64_t gl_map_device_bytes = 0;  // map array bytes the backend wrote into the GL buffers itself, in
                                     // device memory (the cuda backend, CUDA-GL interop; then
                                     // gl_map_upload_bytes holds only the frame block)
  uint64_t gl_map_copy_bytes = 0;    // GL-side copies when a map buffer grew (no host traffic)
  bool gl_map_full_upload = false;   // every map array uploaded (first frame, store compacted or emptied)
  uint64_t gl_map_bytes = 0;         // GL map buffers, allocated
  uint64_t gl_readback_bytes = 0;    // bytes read back from application buffers (read_gl_mesh) since
                                     // the last update
  // Bytes between the host and the backend's memory this frame (update and
  // render): on a GPU the transfers; on CPU threads the copies the backend
  // still makes (the scene's changed arrays; fragment lists are used where
  // they are). 0 in a frame where nothing changed and nothing is drawn.
  uint64_t host_to_backend_bytes = 0;  // scene changes, fragment lists on a device
  uint64_t backend_to_host_bytes = 0;  // the image, the builds' counters, the map store when inspected
};

// What a frame asked of the machine (update and render), counted the same
// on every backend: the CPU threads count what the CUDA device would do (a
// read-back there is a synchronization), so a test on CPU threads checks a
// frame's structure as a GPU would run it. The bytes each way are in
// UpdateStats (host_to_backend_bytes, backend_to_host_bytes).
struct FrameCounters {
  uint64_t host_syncs = 0;           // the host waited for the backend (a stream synchronization, a read-back)
  uint64_t backend_allocations = 0;  // buffers allocated in the backend's memory (device memory on a GPU)
  uint64_t launches = 0;             // kernel launches (parallel_for over a non-empty range)
  uint64_t gl_readbacks = 0;         // blocking reads of GL buffers (each waits for the GL work queued before it)
  uint64_t gl_allocations = 0;       // GL buffers given new storage
};

struct FrameStats {
  StageTimes times;
  FrameCounters counters;
  std::string backend;         // "cpu" or "cuda": where the kernels ran
  std::string backend_reason;  // why (SystemOptions::backend Auto: the device found, or why none serves)
  DsmMemory memory;
  uint32_t lights = 0;
  uint32_t maps_rebuilt = 0;  // DSMs built this frame
  uint32_t maps_reused = 0;   // DSMs whose inputs did not change (kept from an earlier frame)
  UpdateStats update;
  double cluster_ms = 0.0;
  std::vector<LightClusterStats> clusters;          // per light
  std::vector<MapResolutionStats> map_resolutions;  // per map, in the frame's map order
  PoppingStats popping;
  uint64_t light_fragments = 0;
  uint64_t camera_fragments = 0;
  std::string fragment_source;         // "gl", "cuda" or "cpu"
  std::string fragment_source_reason;  // why it was chosen
  // Segment walker counters over the frame's maps and camera pass:
  uint64_t unmatched_fragments = 0;   // entries/exits without partner (open meshes), ignored
  uint64_t enclosing_overflow = 0;    // volume entries left out: inside kMaxEnclosing volumes already
  uint64_t match_overflow = 0;        // rays with more than kMaxRayObjects objects (matched in
                                      // extra passes: the answer is unchanged, only slower)
  uint64_t march_lengthened = 0;      // volume segments marched with a step lengthened to the
                                      // float resolution at their depth (volumes far from the
                                      // eye or light; warned about)
  std::vector<std::string> warnings;  // scene content that could not be honoured
  bool has_reference = false;
  TransmittanceError transmittance;
  ImageError image;
};

// ---- each figure's name, written down once ------------------------------------
// f(name, value) for every scalar figure of a part of FrameStats, in
// declaration order: the one list `cdsm render --stats` writes to JSON and
// `cdsm bench` to its columns (a figure added here reaches both).
template <class F>
void for_each_stat(const DsmMemory& m, F&& f) {
  f("maps", m.maps);
  f("texels", m.texels);
  f("nodes", m.nodes);
  f("index_bytes", m.index_bytes);
  f("node_bytes", m.node_bytes);
  f("slack_bytes", m.slack_bytes);
  f("tag_bytes", m.tag_bytes);
  f("pyramid_bytes", m.pyramid_bytes);
  f("avg_nodes_per_texel", m.avg_nodes_per_texel);
  f("max_nodes_per_texel", m.max_nodes_per_texel);
  f("overflow_texels", m.overflow_texels);
  f("rewalked_texels", m.rewalked_texels);
  f("overflow_extra_error", m.max_extra_error);
  f("rgb_maps", m.rgb_maps);
  f("grey_map_bytes", m.grey_bytes);
  f("rgb_map_bytes", m.rgb_bytes);
  f("rgb_nodes", m.rgb_nodes);
}

template <class F>
void for_each_stat(const FrameCounters& c, F&& f) {
  f("host_syncs", c.host_syncs);
  f("backend_allocations", c.backend_allocations);
  f("launches", c.launches);
  f("gl_readbacks", c.gl_readbacks);
  f("gl_allocations", c.gl_allocations);
}

// The scalars of UpdateStats (rebuilt_by_reason and rebuilds are lists).
template <class F>
void for_each_stat(const UpdateStats& u, F&& f) {
  f("frames_planned", u.frames_planned);
  f("full_compiles", u.full_compiles);
  f("objects_compiled", u.objects_compiled);
  f("volumes_compiled", u.volumes_compiled);
  f("bvh_refits", u.bvh_refits);
  f("bvh_rebuilds", u.bvh_rebuilds);
  f("gl_upload_bytes", u.gl_upload_bytes);
  f("maps_freed", u.maps_freed);
  f("fragment_lists_reused", u.fragment_lists_reused);
  f("fragment_lists_redone", u.fragment_lists_redone);
  f("fragment_cache_bytes", u.fragment_cache_bytes);
  f("map_store_bytes", u.map_store_bytes);
  f("map_live_bytes", u.map_live_bytes);
  f("scene_bytes", u.scene_bytes);
  f("gl_scene_bytes", u.gl_scene_bytes);
  f("gl_map_upload_bytes", u.gl_map_upload_bytes);
  f("gl_map_device_bytes", u.gl_map_device_bytes);
  f("gl_map_copy_bytes", u.gl_map_copy_bytes);
  f("gl_map_full_upload", u.gl_map_full_upload);
  f("gl_map_bytes", u.gl_map_bytes);
  f("gl_readback_bytes", u.gl_readback_bytes);
  f("host_to_backend_bytes", u.host_to_backend_bytes);
  f("backend_to_host_bytes", u.backend_to_host_bytes);
}

}  // namespace cdsm
