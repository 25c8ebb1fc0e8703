// A read-only snapshot of the frame a ShadowSystem built (DESIGN.md §8,
// "one frame path"): what the research harness (cdsm::Renderer's error and
// popping probes, cdsm bench), the editor's inspectors and the tests read.
// ShadowSystem is the only thing that builds a frame; a snapshot only reads
// what its last update() and render() left, in the algorithm's own types.
//
//   ShadowSystem sys(options);
//   sync_scene(sys, scene);          // or the handle API
//   sys.render();                    // or update()
//   const FrameSnapshot snap(sys);
//   ShadowView maps = snap.shadow_view();     // lookups over the frame's maps
//   SceneView compiled = snap.scene_view();   // the compiled scene
//
// Cheap to take: a read-only view of the system (it must outlive the
// snapshot); each call reads the system's state at that moment, and what a
// call returns (references, spans, views) is valid until the system's next
// edit, update() or render(). Nothing here changes what the system built;
// reading the camera fragments copies them from the backend once per
// render().
#pragma once

#include <cstdint>
#include <functional>
#include <memory>

#include "backend/backend.h"
#include "cdsm/frame_stats.h"
#include "cdsm/shadow_system.h"
#include "frame.h"
#include "scene/fragments.h"
#include "scene/scene_buffers.h"

namespace cdsm {

class FrameSnapshot {
 public:
  explicit FrameSnapshot(const ShadowSystem& system);

  // The state as scene values (objects, volumes, lights in handle order).
  const Scene& scene() const;
  // The compiled scene (geometry arrays, BVH, volumes) and its kernel view.
  const SceneBuffers& compiled() const;
  SceneView scene_view() const;

  // The last update()'s frame: kernel lights and map plans (setup), the
  // maps (backend ids, headers with their views), per-map build stats and
  // rebuild flags, the clusters per light.
  const ShadowFrame& frame() const;
  // The lookup over the frame's maps with the current lookup settings
  // (filtering, penumbra, receiver offsets); its storage is the backend's
  // host view of the maps.
  ShadowView shadow_view() const;
  // Where the maps live (their storage, headers by id, the store's figures).
  const ShadowBackend& backend() const;
  // What the last update() reported.
  const FrameStats& stats() const;

  // The last render()'s camera pass: its view and inputs, and its camera
  // fragment lists (held by the backend, sorted by the pass; copied to the
  // host on the first call after each render()). False / throws before the
  // first render().
  bool has_camera_pass() const;
  const CameraPassParams& camera() const;
  FragmentLists camera_fragments() const;
  ListsId camera_lists() const;

 private:
  const ShadowSystem::Impl& I_;
};

// Test and research hooks that change how a system works, not what it
// builds. Each names what it is for; engines never need them.
struct SystemHooks {
  // The GL rasterizer's fragment pool: its first and largest size in bytes
  // (0: the defaults), to reach pool growth and tiling with small scenes.
  // Before the system's first update().
  static void limit_fragment_pool(ShadowSystem& system, uint64_t initial_bytes, uint64_t max_bytes);
  // The largest block the GL map buffers may use (0: the driver's); the
  // buffers are dropped and made again at the next publish
  // (GlContextUse::Application only).
  static void limit_gl_map_block(ShadowSystem& system, uint64_t bytes);
  // Replaces the system's backend by what `wrap` makes of it (a wrapper
  // that counts or refuses calls and forwards to it, or another backend);
  // the fragment producer follows. Before the system's first update():
  // nothing is stored in the old one yet.
  using BackendWrap = std::function<std::unique_ptr<ShadowBackend>(std::unique_ptr<ShadowBackend>)>;
  static void wrap_backend(ShadowSystem& system, const BackendWrap& wrap);
  // The popping probe (cdsm::Renderer): maps an update() replaces stay in
  // the backend one more frame, so the last frame's lookups can be
  // compared with this one's (ShadowFrame::previous_kept).
  static void keep_replaced_maps(ShadowSystem& system, bool keep);
  // The backend itself, to call it as the system would (e.g. a camera pass
  // into a GL buffer over the frame's maps).
  static ShadowBackend& backend(ShadowSystem& system);
};

}  // namespace cdsm
