// FrameSnapshot and SystemHooks (frame_snapshot.h): reads of what a
// ShadowSystem built, and the few hooks tests need.
#include "frame_snapshot.h"

#include "cdsm/error.h"
#include "shadow_system_impl.h"

namespace cdsm {

FrameSnapshot::FrameSnapshot(const ShadowSystem& system) : I_(*system.impl_) {}

const Scene& FrameSnapshot::scene() const { return I_.scene; }
const SceneBuffers& FrameSnapshot::compiled() const { return I_.sb; }
SceneView FrameSnapshot::scene_view() const { return I_.sb.view(); }
const ShadowFrame& FrameSnapshot::frame() const { return I_.frame; }
ShadowView FrameSnapshot::shadow_view() const { return I_.shadow_view(); }
const ShadowBackend& FrameSnapshot::backend() const { return *I_.backend; }
const FrameStats& FrameSnapshot::stats() const { return I_.update_stats; }

bool FrameSnapshot::has_camera_pass() const { return I_.has_camera_lists; }

const CameraPassParams& FrameSnapshot::camera() const {
  CDSM_CHECK(I_.has_camera_lists, I_.scene.source + ": no camera pass yet (render() first)");
  return I_.cam;
}

FragmentLists FrameSnapshot::camera_fragments() const { return I_.camera_fragments(); }

ListsId FrameSnapshot::camera_lists() const {
  CDSM_CHECK(I_.has_camera_lists, I_.scene.source + ": no camera pass yet (render() first)");
  return I_.camera_lists;
}

void SystemHooks::limit_fragment_pool(ShadowSystem& system, uint64_t initial_bytes, uint64_t max_bytes) {
  system.impl_->fragments.limit_pool(initial_bytes, max_bytes);
}

void SystemHooks::limit_gl_map_block(ShadowSystem& system, uint64_t bytes) {
  ShadowSystem::Impl& I = *system.impl_;
  if (!I.gl) throw Error(I.scene.source, "limit_gl_map_block needs a system on the application's GL context");
  set_gl_map_block_limit(*I.gl, bytes);
  I.gl_published = false;
}

void SystemHooks::wrap_backend(ShadowSystem& system, const BackendWrap& wrap) {
  ShadowSystem::Impl& I = *system.impl_;
  I.backend = wrap(std::move(I.backend));
  CDSM_CHECK(I.backend != nullptr, "wrap_backend: the wrap returned no backend");
  I.fragments.use_backend(I.backend.get());
  I.gl_published = false;
}

void SystemHooks::keep_replaced_maps(ShadowSystem& system, bool keep) { system.impl_->keep_previous = keep; }

ShadowBackend& SystemHooks::backend(ShadowSystem& system) { return *system.impl_->backend; }

}  // namespace cdsm
