// The interface between the frame (engine/src/frame.h: lights -> map plans
// -> clustering -> map cache -> build or reuse -> camera pass) and the
// backend that runs the CDSM_HD kernels: one implementation,
// shadows/exec/exec_backend.h, over CPU threads (the cpu backend) or a CUDA
// device (the cuda backend). A backend holds no frame logic: it keeps the
// scene buffers it was given, builds and stores maps it is asked for, hands
// out the lookup over a list of them and runs the camera pass (DESIGN.md §5).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "cdsm/error.h"
#include "exec/exec.h"
#include "hd/camera_pass.h"
#include "hd/light_pass.h"
#include "hd/map_build.h"
#include "scene/fragments.h"
#include "scene/scene_buffers.h"

namespace cdsm {

// What changed in the scene buffers since the backend last saw them: the
// backend brings only that into its memory (a moved object: its triangles
// and the BVH nodes whose boxes moved with them).
struct SceneChange {
  bool everything = false;            // the first upload; objects added or removed: every array
  std::vector<IndexRange> triangles;  // triangles that moved (their vertices and normals)
  bool bvh = false;                   // the BVH was rebuilt (every node, the primitive order)
  std::vector<IndexRange> bvh_nodes;  // else: the nodes whose boxes a refit changed
  bool objects = false;               // per-object data (materials, interiors, flags)
  bool volumes = false;               // volume placements (a moved volume's object)
  bool grids = false;                 // volume grids compiled again (voxels, NanoVDB pool, macro cells)
  static SceneChange all() {
    SceneChange c;
    c.everything = true;
    return c;
  }
};

// The eight arrays of DsmStorage, in its order (texels, nodes, chunks, the
// RGB maps' three, then the grey and the RGB maps' surface tags).
enum class StorageArray : int { Texels = 0, Nodes, Chunks, RgbTexels, RgbNodes, RgbChunks, Tags, RgbTags, Count };
inline constexpr int kStorageArrays = int(StorageArray::Count);

// Storage array `a` of `s` as bytes: where it starts (null where the host
// cannot read it) and how long it is. The one map from StorageArray to
// DsmStorage's arrays (the GL blocks, the executor's writes to them).
struct StorageBytes {
  const void* data = nullptr;
  uint64_t bytes = 0;
};
template <class T>
inline StorageBytes storage_bytes_of(Span<const T> span) {
  return {span.data(), span.size() * sizeof(T)};
}
inline StorageBytes storage_bytes(const DsmStorage& s, StorageArray a) {
  switch (a) {
    case StorageArray::Texels: return storage_bytes_of(s.grey.texels);
    case StorageArray::Nodes: return storage_bytes_of(s.grey.nodes);
    case StorageArray::Chunks: return storage_bytes_of(s.grey.chunks);
    case StorageArray::RgbTexels: return storage_bytes_of(s.rgb.texels);
    case StorageArray::RgbNodes: return storage_bytes_of(s.rgb.nodes);
    case StorageArray::RgbChunks: return storage_bytes_of(s.rgb.chunks);
    case StorageArray::Tags: return storage_bytes_of(s.grey.tags);
    case StorageArray::RgbTags: return storage_bytes_of(s.rgb.tags);
    case StorageArray::Count: break;
  }
  return {};
}

// Bytes [offset, offset + bytes) of one storage() array to be written at the
// same offset into a GL buffer object (name `gl_buffer`, `gl_buffer_bytes`
// long) — by the backend itself, from its own memory (write_gl_maps).
// `gl_buffer_generation` changes whenever the array gets a new buffer object
// (GL may reuse a deleted buffer's name): a backend that registers the
// buffers registers again then.
struct GlMapWrite {
  StorageArray array = StorageArray::Texels;
  uint32_t gl_buffer = 0;
  uint64_t gl_buffer_bytes = 0;
  uint64_t gl_buffer_generation = 0;
  uint64_t offset = 0;
  uint64_t bytes = 0;
};

// `s` with every array's data pointer null (the sizes only): what
// storage_extent() returns over memory the host cannot read.
inline DsmStorage storage_sizes(DsmStorage s) {
  const auto sizes_only = [](auto& a) {
    a.texels.ptr = nullptr;
    a.nodes.ptr = nullptr;
    a.chunks.ptr = nullptr;
    a.tags.ptr = nullptr;
    a.pyramid.ptr = nullptr;
  };
  sizes_only(s.grey);
  sizes_only(s.rgb);
  return s;
}

// A map the backend stores; valid until free_map().
using MapId = uint32_t;
// Fragment lists the backend holds; valid until free_lists().
using ListsId = uint32_t;

// The map ids of a backend that appends maps to one store: a slot per id
// (freed ids are given again), and the bytes in live maps and in the store
// since its last compaction. `Stored` has `bool live` and `uint64_t
// bytes()`. The compaction rule: the bytes of freed maps still in the
// store are reclaimed once they exceed a quarter of it — counted in map
// bytes, not in the arrays' capacity (growth slack is not a hole).
template <class Stored>
struct MapSlots {
  std::vector<Stored> maps;  // by MapId
  std::vector<MapId> free_ids;
  uint64_t live_bytes = 0;
  uint64_t stored_bytes = 0;  // of maps appended since the last compaction or reset (live + holes)

  uint32_t live() const { return uint32_t(maps.size() - free_ids.size()); }
  MapId add(const Stored& m) {
    live_bytes += m.bytes();
    stored_bytes += m.bytes();
    if (free_ids.empty()) {
      maps.push_back(m);
      return MapId(maps.size() - 1);
    }
    const MapId id = free_ids.back();
    free_ids.pop_back();
    maps[id] = m;
    return id;
  }
  // Map `id`; throws std::logic_error naming `what` when it is not stored.
  const Stored& at(MapId id, const char* what) const {
    CDSM_CHECK(id < maps.size() && maps[id].live, std::string(what) + ": map " + std::to_string(id) + " is not stored");
    return maps[id];
  }
  void free(MapId id) {
    at(id, "free_map");
    live_bytes -= maps[id].bytes();
    maps[id].live = false;
    free_ids.push_back(id);
  }
  bool needs_compaction() const { return stored_bytes - live_bytes > stored_bytes / 4; }
  void compacted() { stored_bytes = live_bytes; }
  void clear() { *this = MapSlots{}; }
};

// Bytes a backend holds for maps: `live` in maps still in use, `allocated`
// including the holes freed maps left (reclaimed by compaction).
struct MapStoreStats {
  uint64_t live_bytes = 0;
  uint64_t allocated_bytes = 0;
  uint64_t compactions = 0;       // cumulative
  uint64_t compacted_bytes = 0;   // cumulative bytes moved by compaction
  uint32_t maps = 0;              // maps stored
  uint32_t lists = 0;             // fragment lists held (ListsId)
  uint64_t list_bytes = 0;        // their bytes
  uint64_t spare_list_bytes = 0;  // capacity of freed lists kept for the next ones
};

class ShadowBackend {
 public:
  virtual ~ShadowBackend() = default;
  virtual const char* name() const = 0;

  // The scene the next calls use. `sb` stays owned by the caller and alive
  // (unchanged) until the next update_scene(); `change` says what moved.
  virtual void update_scene(const SceneBuffers& sb, const SceneChange& change) = 0;

  // ---- fragment lists, held where they are used ----
  // One view's lists in the backend's memory, made there (cast_lists) or
  // handed over once (adopt_lists); build_map and camera_pass read them
  // where they are, and a kept copy (copy_lists) never leaves the backend.
  // Valid until free_lists().
  // The backend's exact ray caster over the scene of the last update_scene
  // (on a CUDA device the lists never leave it); `mask` a host mask.
  virtual ListsId cast_lists(const PinholeView& view, ObjectMask mask) = 0;
  // Several views' lists as cast_lists makes them (ids[i] view i's; all or
  // nothing). The exec backend counts every view before it reads a total:
  // one host synchronization for them all. By default one cast_lists after
  // another.
  virtual void cast_views(const PinholeView* views, const ObjectMask* masks, size_t n, ListsId* ids) {
    size_t made = 0;
    try {
      for (; made < n; ++made) ids[made] = cast_lists(views[made], masks[made]);
    } catch (...) {
      for (size_t i = 0; i < made; ++i) free_lists(ids[i]);
      throw;
    }
  }
  // Lists made on the host (the GL rasterizer's read-back, the host ray
  // caster): moved in where the backend's memory is host memory, else
  // uploaded once (counted in take_counters).
  virtual ListsId adopt_lists(FragmentBuffers&& lists) = 0;
  // A copy of lists `id` in the backend's memory (the light pass sorts the
  // lists it reads in place; a copy kept for a later rebuild stays intact).
  virtual ListsId copy_lists(ListsId id) = 0;
  virtual void free_lists(ListsId id) = 0;
  // Lists `id`'s fragment count and the bytes they hold (offsets included).
  virtual uint64_t lists_fragments(ListsId id) const = 0;
  virtual uint64_t lists_bytes(ListsId id) const = 0;
  // Lists `id` to the host, on request (probes, inspection, tests): a copy,
  // counted in take_counters.
  virtual void read_lists(ListsId id, FragmentBuffers& out) = 0;

  // Fragments a GL rasterizer made for several views at once: piece p holds
  // fragments [first, first + count) of view `view`'s lists, at fragment
  // `at` of the GL buffer the sink is given.
  struct GlPiece {
    uint32_t view = 0;
    uint64_t first = 0;
    uint64_t count = 0;
    uint64_t at = 0;
  };
  // Each filling of the rasterizer's pool: `n` pieces in GL buffer
  // `gl_buffer` (current context, `gl_buffer_bytes` long, `generation` new
  // with each new buffer object); per view, pieces come in order.
  using GlTileSink = std::function<void(const GlPiece* pieces, size_t n, uint32_t gl_buffer, uint64_t gl_buffer_bytes,
                                        uint64_t generation)>;
  // A band of a view's offsets the rasterizer scanned: values [at, at +
  // count] of its offsets buffer (uint32, count + 1 of them: the last is
  // where the next band starts) are offsets [first, first + count] of view
  // `view`'s lists, each plus `shift` (modulo 2^32).
  struct GlOffsets {
    uint32_t view = 0;
    uint64_t first = 0;
    uint64_t count = 0;
    uint64_t at = 0;
    uint32_t shift = 0;
  };
  // Each batch's scanned offsets: `n` bands in GL buffer `gl_buffer` (as
  // GlTileSink's), handed over before the batch's fragments.
  using GlOffsetsSink = std::function<void(const GlOffsets* bands, size_t n, uint32_t gl_buffer,
                                           uint64_t gl_buffer_bytes, uint64_t generation)>;
  // The lists of `views` views rasterized by GL together straight into the
  // backend's memory, never through the host (CUDA-GL interop; only where
  // can_write_gl_maps() holds for the current context, else
  // std::logic_error): `rasterize(tiles, offsets, outs)` runs the
  // rasterizer, handing each batch's offsets and each filled pool to the
  // sinks (copied on the device, under one map of the buffer, before they
  // return), and leaves each view's size in outs[v] and its fragment count
  // in outs[v].offsets (one value). ids[v] view v's. All or nothing.
  // `slots[v]` names view v's lists from frame to frame (with their size;
  // 0 none): their count is the next guess of lists_from_gl_unchecked for
  // the slot.
  using GlRasterize = std::function<void(const GlTileSink& tiles, const GlOffsetsSink& offsets, FragmentBuffers* outs)>;
  virtual void lists_from_gl(size_t views, const uint64_t* slots, const GlRasterize& rasterize, ListsId* ids) {
    (void)views;
    (void)slots;
    (void)rasterize;
    (void)ids;
    throw std::logic_error(std::string(name()) +
                           " backend: lists_from_gl is not supported (can_write_gl_maps is false)");
  }

  // A view's part of a batch the GL rasterizer left on the GPU for
  // lists_from_gl_unchecked: pixels [first, first + count) of view `view`,
  // whose offsets are values [at, at + count] of the batch's offsets buffer
  // (batch offsets: the part's fragments are pool fragments [offsets[at],
  // offsets[at + count]), where the pool holds them).
  struct GlPart {
    uint32_t view = 0;
    uint64_t first = 0;
    uint64_t count = 0;
    uint64_t at = 0;
  };
  // A batch left in two GL buffers (current context; a generation new with
  // each new buffer object): the scanned offsets (uint32, the batch's total
  // at `total_at`, the scan's carry flag after it) and the fragment pool,
  // which holds the batch's first `pool_fragments` fragments (a fill writes
  // no fragment past them). The host read neither.
  struct GlBatch {
    const GlPart* parts = nullptr;
    size_t n = 0;
    uint32_t offsets_buffer = 0;
    uint64_t offsets_bytes = 0, offsets_generation = 0, total_at = 0;
    uint32_t pool_buffer = 0;
    uint64_t pool_bytes = 0, pool_generation = 0, pool_fragments = 0;
  };
  using GlBatchSink = std::function<void(const GlBatch& batch)>;
  // Runs the rasterizer with a pool of at least `pool_fragments` fragments,
  // handing each batch to the sink (taken on the device before it returns)
  // and each view's size to outs[v]; false when the pool cannot be that
  // large (nothing rasterized).
  using GlRasterizeUnchecked =
      std::function<bool(uint64_t pool_fragments, const GlBatchSink& batches, FragmentBuffers* outs)>;
  // lists_from_gl without the host reading a count: each view's lists go
  // into fragment arrays of a capacity guessed from the counts of earlier
  // frames, re-based and copied on the device within the capacities (the
  // GL pool's and the lists'), the true count kept on the device. Whether
  // they fit is read with the next build_maps' counters (one read for the
  // frame): lists that did not are reported by ListsShortError, and are
  // made again with lists_from_gl. `slots[v]` names view v's lists as for
  // lists_from_gl: the slot's last count is their guess. False (nothing
  // made) where the backend has no count of a slot yet (a map's first
  // frame, a new size) or cannot.
  virtual bool lists_from_gl_unchecked(size_t views, const uint64_t* slots, const GlRasterizeUnchecked& rasterize,
                                       ListsId* ids) {
    (void)views;
    (void)slots;
    (void)rasterize;
    (void)ids;
    return false;
  }

  // Builds one map from the light-view fragment lists `lists` (sorted in
  // place, still held afterwards) and keeps it; its stats (in its layout)
  // go to `stats`.
  virtual MapId build_map(const LightPassParams& params, ListsId lists, const DsmLayoutParams& layout,
                          DsmBuildStats& stats) = 0;
  // One map of build_maps: its parameters and lists.
  struct MapBuild {
    LightPassParams params;
    ListsId lists = 0;
  };
  // Builds several maps of one layout as build_map does, ids[i] and
  // stats[i] map i's. All or nothing: when one fails, none is kept. The
  // exec backend walks them all before it reads a count (one host
  // synchronization for the frame's maps, exec/light_pass.h); by default
  // one build_map after another.
  virtual void build_maps(const MapBuild* builds, size_t n, const DsmLayoutParams& layout, MapId* ids,
                          DsmBuildStats* stats) {
    size_t built = 0;
    try {
      for (; built < n; ++built)
        ids[built] = build_map(builds[built].params, builds[built].lists, layout, stats[built]);
    } catch (...) {
      for (size_t i = 0; i < built; ++i) free_map(ids[i]);
      throw;
    }
  }
  // Releases a map's memory (the id is then invalid).
  virtual void free_map(MapId id) = 0;
  // Releases several maps with one decision about the store (a frame's
  // replaced maps: freed one by one, each could compact it again).
  virtual void free_maps(const std::vector<MapId>& ids) {
    for (MapId id : ids) free_map(id);
  }

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
  // Per storage array (StorageArray order), how many of its first bytes
  // hold what they held at storage epoch `since`: a mirror that copied the
  // storage then needs only the bytes after these (and the new tails). Every
  // byte when `since` is the current epoch; 0 where the backend does not
  // know (by default, for any older epoch).
  virtual void storage_kept_bytes(uint64_t since, uint64_t* kept) const {
    for (int a = 0; a < kStorageArrays; ++a) kept[a] = since == storage_epoch() ? ~uint64_t(0) : 0;
  }
  // storage()'s layout and array sizes, without its bytes: every span's
  // size() is that of storage(), its data() may be null (over device memory
  // no host mirror is downloaded for it). For callers that only need sizes,
  // e.g. before write_gl_maps.
  virtual DsmStorage storage_extent() const { return storage(); }

  // Whether write_gl_maps can run with the GL context current on this thread:
  // the backend's store is in memory that context's buffers live in (the cuda
  // backend with the context on its CUDA device). False by default (cpu
  // backend, the exec backend on CPU threads): the caller then uploads the
  // bytes from storage() itself (engine/gl/map_buffers.h).
  virtual bool can_write_gl_maps() const { return false; }
  // Writes each range of storage() into its GL buffer (current context; the
  // buffers exist and are at least offset + bytes long). Only after
  // can_write_gl_maps() said true; throws std::logic_error otherwise.
  virtual void write_gl_maps(const GlMapWrite* writes, int count) {
    (void)writes;
    (void)count;
    throw std::logic_error(std::string(name()) +
                           " backend: write_gl_maps is not supported (can_write_gl_maps is false)");
  }
  // GL buffer `name` (current context) is about to be deleted or replaced
  // by its owner (engine/gl/map_buffers.h): a backend that registered it
  // (CUDA-GL interop) unregisters it now, before GL deletes it. No-op by
  // default; never throws.
  virtual void gl_buffer_released(uint32_t name) { (void)name; }

  // Shades every pixel of the camera view into `rgb` (3 floats per pixel,
  // linear), read back to the host, from the camera's fragment lists
  // `lists` (sorted in place). The lookup reads the backend's own store:
  // `shadows.storage` is not used.
  virtual void camera_pass(const ShadowView& shadows, const CameraPassParams& params, ListsId lists,
                           std::vector<float>& rgb, WalkStats& walk) = 0;

  // camera_pass() writing its image (the same 3 floats per pixel, in the
  // same order) into a GL buffer object — a pixel buffer the application
  // then copies into a texture or reads — instead of the host: `gl_buffer`
  // (current context) of `gl_buffer_bytes` >= width * height * 12 bytes;
  // `gl_buffer_generation` changes whenever the application made a new
  // buffer object under that name. Only where can_write_gl_maps() holds (the
  // store and that context share memory); throws std::logic_error otherwise.
  virtual void camera_pass_to_gl(const ShadowView& shadows, const CameraPassParams& params, ListsId lists,
                                 uint32_t gl_buffer, uint64_t gl_buffer_bytes, uint64_t gl_buffer_generation,
                                 WalkStats& walk) {
    (void)shadows, (void)params, (void)lists, (void)gl_buffer, (void)gl_buffer_bytes, (void)gl_buffer_generation,
        (void)walk;
    throw std::logic_error(std::string(name()) +
                           " backend: camera_pass_to_gl is not supported (can_write_gl_maps is false)");
  }

  virtual MapStoreStats map_store() const = 0;

  // Milliseconds per kernel launch name since the last call (CUDA events on
  // the cuda backend, the wall clock on CPU threads).
  virtual std::vector<exec::StageTime> take_stage_times() = 0;
  // What the backend's executor did since the last call (exec/exec.h: bytes
  // each way, host synchronizations, allocations, launches), counted alike
  // on the device and on CPU threads (FrameStats::counters, ::update).
  virtual exec::ExecCounters take_counters() = 0;
};

// build_maps found lists made by lists_from_gl_unchecked that did not fit
// their capacities (a frame with more fragments than the guess): no map was
// kept; `lists` are those ids, `fragments` their true counts (each ids'
// lists stay held, to be freed and made again).
class ListsShortError : public std::runtime_error {
 public:
  ListsShortError(std::vector<ListsId> lists, std::vector<uint64_t> fragments)
      : std::runtime_error(std::to_string(lists.size()) +
                           " view(s)' fragment lists did not fit the capacity guessed for them"),
        lists(std::move(lists)),
        fragments(std::move(fragments)) {}
  std::vector<ListsId> lists;
  std::vector<uint64_t> fragments;
};

// Host lists handed to `backend` for one build (adopt_lists, build_map,
// free_lists): tests and tools that make their lists on the host.
inline MapId build_map_from_host(ShadowBackend& backend, const LightPassParams& params, FragmentBuffers lists,
                                 const DsmLayoutParams& layout, DsmBuildStats& stats) {
  const ListsId id = backend.adopt_lists(std::move(lists));
  try {
    const MapId map = backend.build_map(params, id, layout, stats);
    backend.free_lists(id);
    return map;
  } catch (...) {
    backend.free_lists(id);
    throw;
  }
}

// The cpu backend: the exec backend (backend/exec_backend.h) over CPU
// threads (exec/host_exec.h).
std::unique_ptr<ShadowBackend> make_cpu_backend();

}  // namespace cdsm
