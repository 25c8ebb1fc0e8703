// The interface between the frame (engine/src/frame.h: lights -> map plans
// -> clustering -> map cache -> build or reuse -> camera pass) and a
// backend that runs the CDSM_HD kernels: the cpu backend (TBB,
// shadows/cpu/cpu_backend.h) first, a cuda backend second. A backend holds
// no frame logic: it keeps the scene buffers it was given, builds and stores
// maps it is asked for, hands out the lookup over a list of them and runs
// the camera pass (DESIGN.md §5).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "cpu/backend.h"
#include "cpu/scene_buffers.h"
#include "hd/lights.h"

namespace cdsm {

// What changed in the scene buffers since the backend last saw them.
struct SceneChange {
  bool everything = false;      // first upload, objects or volumes added or removed
  uint32_t first_tri = 0;       // else: triangles [first_tri, first_tri + tri_count) moved
  uint32_t tri_count = 0;       //   (vertices, normals, the BVH refitted)
  bool objects = false;         // per-object data (materials, interiors, volume placement)
};

// A map the backend stores; valid until free_map().
using MapId = uint32_t;

// Bytes a backend holds for maps: `live` in maps still in use, `allocated`
// including the holes freed maps left (reclaimed by compaction).
struct MapStoreStats {
  uint64_t live_bytes = 0;
  uint64_t allocated_bytes = 0;
  uint64_t compactions = 0;      // cumulative
  uint64_t compacted_bytes = 0;  // cumulative bytes moved by compaction
  uint32_t maps = 0;             // maps stored
};

class ShadowBackend {
 public:
  virtual ~ShadowBackend() = default;
  virtual const char* name() const = 0;

  // The scene the next calls use. `sb` stays owned by the caller and alive
  // (unchanged) until the next update_scene(); `change` says what moved.
  virtual void update_scene(const SceneBuffers& sb, const SceneChange& change) = 0;

  // Builds one map from its light-view fragment lists (sorted in place) and
  // keeps it; its stats (in its layout) go to `stats`.
  virtual MapId build_map(const LightPassParams& params, FragmentLists frags, const DsmLayoutParams& layout,
                          DsmBuildStats& stats) = 0;
  // Releases a map's memory (the id is then invalid).
  virtual void free_map(MapId id) = 0;

  // A stored map's header (its view and where its texels lie in storage()).
  // Both change when the store compacts (in free_map): fetch them again
  // after building or freeing.
  virtual DsmMap map_header(MapId id) const = 0;
  // Every stored map's texels and nodes, the storage a ShadowView reads.
  virtual DsmStorage storage() const = 0;
  // Bumped whenever bytes already in storage() move or vanish (compaction,
  // the store emptied). Between two bumps the arrays only grow at their
  // ends, so a mirror of the storage (GL buffers, engine/gl/map_buffers.h)
  // copies just the new tails: the maps built since it last looked.
  virtual uint64_t storage_epoch() const = 0;

  // Shades every pixel of the camera view into `rgb` (3 floats per pixel,
  // linear), read back to the host; fragments are sorted in place.
  virtual void camera_pass(const ShadowView& shadows, const CameraPassParams& params, FragmentLists frags,
                           std::vector<float>& rgb, WalkStats& walk) = 0;

  virtual MapStoreStats map_store() const = 0;
};

}  // namespace cdsm
