// cpu driver of the camera pass.
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include "cpu/backend.h"

namespace cdsm {

void render_camera(const SceneView& scene, const ShadowView& shadows, const CameraPassParams& params,
                   FragmentLists frags, std::vector<float>& rgb, WalkStats& walk) {
  const int w = params.view.width, h = params.view.height;
  rgb.assign(size_t(w) * h * 3, 0.0f);
  DsmVisibility vis{shadows};
  tbb::combinable<WalkStats> partial;
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    WalkStats& st = partial.local();
    NoRecorder rec;
    for (int py = rows.begin(); py < rows.end(); ++py)
      for (int px = 0; px < w; ++px) {
        PixelResult r = shade_pixel(scene, shadows.lights, vis, params, frags.pixel(px, py), px, py, rec, st);
        float* o = rgb.data() + (size_t(py) * w + px) * 3;
        o[0] = r.color.x;
        o[1] = r.color.y;
        o[2] = r.color.z;
      }
  });
  partial.combine_each([&](const WalkStats& p) { walk.add(p); });
}

}  // namespace cdsm
