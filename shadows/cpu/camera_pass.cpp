// cpu driver of the camera pass: the exec camera pass (shadows/exec/
// camera_pass.h) on CPU threads — the code the cuda backend launches.
#include "cpu/backend.h"
#include "exec/camera_pass.h"
#include "exec/host_exec.h"

namespace cdsm {

void render_camera(const SceneView& scene, const ShadowView& shadows, const CameraPassParams& params,
                   FragmentLists frags, std::vector<float>& rgb, WalkStats& walk) {
  rgb.assign(size_t(params.view.width) * size_t(params.view.height) * 3, 0.0f);
  uint32_t counts[4] = {0, 0, 0, 0};
  exec::HostExec ex;
  exec::shade_pixels(ex, scene, shadows, params, frags, rgb.data(), counts);
  walk.enclosing_overflow += counts[0];
  walk.match_overflow += counts[1];
  walk.unmatched += counts[2];
  walk.march_lengthened += counts[3];
}

}  // namespace cdsm
