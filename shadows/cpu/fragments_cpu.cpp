// CPU fragment producer: count pass -> prefix sum -> fill pass, rows in
// parallel with TBB. Each pixel's ray goes through its centre.
#include "cpu/fragments_cpu.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_scan.h>

#include "hd/bvh.h"

namespace cdsm {

void cast_fragments(const SceneView& scene, const PinholeView& view, ObjectMask mask,
                    FragmentBuffers& out) {
  const int w = view.width, h = view.height;
  const size_t n = size_t(w) * size_t(h);
  out.width = w;
  out.height = h;
  out.offsets.assign(n + 1, 0u);
  // Surfaces are kept where the axial coordinate lies in [near, far]; the
  // boundaries of media (bounds_medium) also before near and beyond far, as
  // clipped fragments, so the walker keeps the media open (view.h).
  bool any_media = false;
  for (uint32_t o = 0; o < scene.objects.size(); ++o)
    any_media = any_media || (mask.contains(o) && bounds_medium(scene.objects[o]));
  const float clip_axial = media_clip_axial(view);
  auto ray_range = [&](int px, int py, Vec3& dir, float& t0, float& t1) {
    dir = pixel_ray(view, px, py);
    float c = dot(dir, view.forward);
    // tmin is exclusive in the test: start just below the first kept depth.
    t0 = (any_media ? clip_axial : view.near) / c * 0.999f;
    t1 = any_media ? 3.0e38f : view.far / c * 1.001f;
  };
  // 0: dropped, 1: kept, 2: kept as clipped.
  auto keep = [&](const Vec3& dir, uint32_t tri, float t) {
    float ax = t * dot(dir, view.forward);
    if (ax >= view.near && ax <= view.far) return 1;
    return ax >= clip_axial && bounds_medium(scene.objects[scene.tri_object[tri]]) ? 2 : 0;
  };
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int py = rows.begin(); py < rows.end(); ++py)
      for (int px = 0; px < w; ++px) {
        Vec3 dir;
        float t0, t1;
        ray_range(px, py, dir, t0, t1);
        uint32_t count = 0;
        for_each_hit(scene, mask, view.eye, dir, t0, t1, [&](uint32_t tri, const TriHit& hit) {
          if (keep(dir, tri, hit.t)) ++count;
        });
        out.offsets[size_t(py) * w + px] = count;
      }
  });
  // Exclusive prefix sum.
  uint64_t total = 0;
  for (size_t i = 0; i < n; ++i) {
    uint32_t c = out.offsets[i];
    out.offsets[i] = uint32_t(total);
    total += c;
  }
  out.offsets[n] = uint32_t(total);
  out.fragments.resize(total);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int py = rows.begin(); py < rows.end(); ++py)
      for (int px = 0; px < w; ++px) {
        Vec3 dir;
        float t0, t1;
        ray_range(px, py, dir, t0, t1);
        size_t i = size_t(py) * w + px;
        uint32_t at = out.offsets[i];
        for_each_hit(scene, mask, view.eye, dir, t0, t1, [&](uint32_t tri, const TriHit& hit) {
          int k = keep(dir, tri, hit.t);
          if (k) out.fragments[at++] = make_fragment(hit.t, tri, hit.front, k == 2);
        });
      }
  });
}

std::vector<uint32_t> objects_containing(const SceneView& scene, Vec3 point, ObjectMask mask) {
  // Parity along a fixed, axis-avoiding direction: an odd number of
  // crossings of a closed object's surface means the point is inside it.
  const Vec3 dir = normalize(Vec3{0.5773f, 0.5779f, 0.5767f});
  std::vector<uint32_t> crossings(scene.objects.size(), 0u);
  for_each_hit(scene, mask, point, dir, 0.0f, 3.0e38f,
               [&](uint32_t tri, const TriHit&) { ++crossings[scene.tri_object[tri]]; });
  std::vector<uint32_t> inside;
  for (uint32_t o = 0; o < crossings.size(); ++o)
    if ((crossings[o] & 1u) && (scene.objects[o].flags & kObjClosed)) inside.push_back(o);
  return inside;
}

}  // namespace cdsm
