// The state behind cdsm::ShadowSystem (engine/include/cdsm/shadow_system.h),
// the system's own: others read it through FrameSnapshot (frame_snapshot.h).
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "cdsm/shadow_system.h"
#include "fragment_source.h"
#include "frame.h"
#include "scene_compile.h"
#include "slot_map.h"
#include "system_gl.h"

namespace cdsm {

struct ShadowSystem::Impl {
  SystemOptions options;
  // The state as public scene values, in handle order (objects' `volume`
  // is the index of their volume here).
  Scene scene;

  struct ObjectRec {
    uint64_t id = 0;
    uint64_t generation = 1;  // bumped by every edit of its content
    uint64_t volume = 0;      // its interior's volume handle, 0 for none
    bool closed = false;      // is_closed(mesh), taken when the mesh was given
    bool moved = false;       // transform changed: world data to recompute in place
    bool surface = false;     // material / shadow flag changed: kernel data only
    // A mesh that stays on the GPU (add_gpu_object): where it is in the
    // application's buffers; its Object holds a placeholder mesh of as many
    // degenerate triangles. Null for meshes on the host.
    std::shared_ptr<GpuMesh> gpu;
    bool gpu_changed = false;  // mark_changed(): its triangles to read again, its bounds to take again
  };
  struct VolumeRec {
    uint64_t id = 0;
    bool dirty = true;                          // grid or transfer function to compile
    bool compiled = false;                      // its data lies in sb's arrays
    uint64_t voxel_begin = 0, voxel_count = 0;  // dense: floats of sb.voxels
    uint64_t block_begin = 0, block_count = 0;  // sparse: blocks of sb.nano_pool
    uint64_t macro_begin = 0, macro_count = 0;
  };
  std::vector<ObjectRec> objects;  // parallel to scene.objects
  std::vector<VolumeRec> volumes;  // parallel to scene.volumes
  std::vector<uint64_t> lights;    // ids, parallel to scene.lights
  // Handle ids -> positions in the arrays above (slot_map.h): O(1) lookups,
  // stale handles named as such.
  SlotMap object_slots, volume_slots, light_slots;
  // is_closed per mesh, the mesh kept alive so its address cannot be reused.
  std::unordered_map<const TriangleMesh*, std::pair<std::shared_ptr<const TriangleMesh>, bool>> closed_meshes;

  bool structure_dirty = true;  // geometry arrays and BVH to rebuild from every object
  bool compile_pending = true;  // content edited since the last compile
  bool changed = true;          // anything since the last update()

  SceneBuffers sb;
  double bvh_built_cost = 0.0;  // bvh_cost() when the BVH was last built
  // The application's GL context and the maps' GL buffers (GlContextUse::
  // Application); declared before `fragments`, whose rasterizer uses it.
  SystemGlPtr gl;
  uint64_t gl_readback_bytes = 0;  // read_gl_mesh() bytes since the last update
  uint64_t gl_readbacks = 0;       // and its blocking reads
  // The GL buffers hold the current frame (publish() since anything
  // changed): an update() with nothing new publishes nothing.
  bool gl_published = false;
  uint64_t gl_map_bytes = 0;  // the last publish's GL buffer bytes (reported again while nothing changes)
  FragmentSourceSelector fragments;
  std::string fragment_name, fragment_reason;
  // Changes whenever compiled content or the fragment producer changes:
  // kept fragment lists (SystemOptions::keep_fragment_lists) of an older
  // epoch are never used.
  uint64_t geometry_epoch = 0;
  std::string epoch_fragment_name;
  std::unique_ptr<ShadowBackend> backend;
  std::string backend_name, backend_reason;  // which backend and why (backend_select.h)
  MapCache cache;
  ShadowFrame frame;
  bool keep_previous = false;  // popping probe: replaced maps live one more frame
  FrameStats update_stats;     // of the last update()
  // The last render()'s camera pass inputs (the error and popping probes use them).
  CameraPassParams cam{};
  std::vector<uint32_t> cam_inside;
  // The last render()'s camera fragment lists, held by the backend (sorted
  // by its camera pass); read to the host only when a probe asks.
  ListsId camera_lists = 0;
  bool has_camera_lists = false;
  mutable FragmentBuffers camera_frags;  // camera_fragments()'s copy
  mutable bool camera_frags_read = false;
  FragmentLists camera_fragments() const;

  explicit Impl(const SystemOptions& o);
  ~Impl();

  size_t object_index(ObjectHandle h) const;
  size_t volume_index(uint64_t id) const;
  size_t light_index(LightHandle h) const;
  bool is_closed_mesh(const std::shared_ptr<const TriangleMesh>& mesh);
  void touch_object(size_t i);

  void compile(FrameStats& st);                                // the scene part of update()
  void update(FrameStats& st);                                 // build() + publish()
  void build(FrameStats& st);                                  // compile, fragments, maps (GL only with GL fragments)
  void build_maps(FrameStats& st);                             // build() less its counters
  void publish(FrameStats& st);                                // the map buffers (GlContextUse::Application)
  std::atomic<uint32_t> progress_built{0}, progress_total{0};  // of the running build
  void compile_volumes(FrameStats& st);
  void erase_volume_data(size_t vi);
  void compile_structure(FrameStats& st);
  void compile_moves(FrameStats& st, SceneChange& change);
  bool refresh_gpu_bounds(const SceneChange& moved);
  bool refresh_surfaces();
  std::string object_where(size_t i) const;
  // A GPU mesh's world box (given bounds transformed, or computed on the
  // GPU) into `co`, whose placeholder vertices say nothing.
  void gpu_bounds(size_t oi, CompiledObject& co);
  // Throws cdsm::Error naming the first mesh that stays on the GPU: `what`
  // (render(), the reference) needs every triangle on the host.
  void require_host_meshes(const std::string& what) const;
  // The lookup over the last update's maps with the current settings.
  ShadowView shadow_view() const { return frame.view(scene.shadows); }
};

}  // namespace cdsm
