// The exact ray-cast fragment producer on CPU threads: the executor's
// (exec/camera_pass.h), the same code the cuda backend launches.
#include "exec/host_exec.h"

#include "exec/camera_pass.h"
#include "scene/fragments.h"

namespace cdsm {

void cast_fragments(const SceneView& scene, const PinholeView& view, ObjectMask mask, FragmentBuffers& out) {
  exec::HostExec ex;
  exec::ExecArray<uint32_t, exec::HostExec> counts(ex), offsets(ex);
  exec::ExecArray<Fragment, exec::HostExec> fragments(ex);
  exec::ExecArray<unsigned long long, exec::HostExec> sums(ex);
  exec::cast_fragments_exec(ex, scene, view, mask, mask_has_media(scene, mask), counts, offsets, fragments, sums);
  out.width = view.width;
  out.height = view.height;
  offsets.read(out.offsets);
  fragments.read(out.fragments);
}

}  // namespace cdsm
