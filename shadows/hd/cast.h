// The ray-casting fragment producer's per-pixel work (DESIGN.md §2.1), the
// same on CPU threads (cpu/fragments_cpu.cpp) and in CUDA kernels: every
// crossing of a pixel-centre ray with the triangles of the objects in a
// mask. Surfaces are kept where the view-axis coordinate lies in [near,
// far]; the boundaries of media (bounds_medium) also before near (down to
// media_clip_axial) and beyond far, flagged clipped, so the segment walker
// keeps media open (hd/segments.h).
#pragma once

#include "hd/bvh.h"
#include "hd/fragment.h"
#include "hd/view.h"

namespace cdsm {

// Whether any object of `mask` bounds a medium (then rays reach beyond far).
CDSM_HD inline bool mask_has_media(const SceneView& s, ObjectMask mask) {
  for (uint32_t o = 0; o < s.objects.size(); ++o)
    if (mask.contains(o) && bounds_medium(s.objects[o])) return true;
  return false;
}

// Calls emit(Fragment) for each fragment of pixel (px, py), in traversal
// order (consumers sort). `any_media`: mask_has_media(s, mask).
template <class Emit>
CDSM_HD void cast_pixel(const SceneView& s, const PinholeView& view, ObjectMask mask, bool any_media, int px, int py,
                        Emit&& emit) {
  const Vec3 dir = pixel_ray(view, px, py);
  const float c = dot(dir, view.forward);
  const float clip_axial = media_clip_axial(view);
  // tmin is exclusive in the test: start just below the first kept depth.
  const float t0 = (any_media ? clip_axial : view.near) / c * 0.999f;
  const float t1 = any_media ? 3.0e38f : view.far / c * 1.001f;
  for_each_hit(s, mask, pixel_origin(view, px, py), dir, t0, t1, [&](uint32_t tri, const TriHit& hit) {
    const float ax = hit.t * c;
    if (ax >= view.near && ax <= view.far) {
      emit(make_fragment(hit.t, tri, hit.front));
    } else if (ax >= clip_axial && bounds_medium(s.objects[s.tri_object[tri]])) {
      emit(make_fragment(hit.t, tri, hit.front, /*clipped=*/true));
    }
  });
}

}  // namespace cdsm
