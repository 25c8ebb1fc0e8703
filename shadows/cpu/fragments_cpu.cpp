// CPU fragment producer: count pass -> prefix sum -> fill pass, rows in
// parallel with TBB. Each pixel's ray goes through its centre.
#include "cpu/fragments_cpu.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_scan.h>

#include "hd/cast.h"

namespace cdsm {

void cast_fragments(const SceneView& scene, const PinholeView& view, ObjectMask mask,
                    FragmentBuffers& out) {
  const int w = view.width, h = view.height;
  const size_t n = size_t(w) * size_t(h);
  out.width = w;
  out.height = h;
  out.offsets.assign(n + 1, 0u);
  const bool any_media = mask_has_media(scene, mask);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int py = rows.begin(); py < rows.end(); ++py)
      for (int px = 0; px < w; ++px) {
        uint32_t count = 0;
        cast_pixel(scene, view, mask, any_media, px, py, [&](Fragment) { ++count; });
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
        uint32_t at = out.offsets[size_t(py) * w + px];
        cast_pixel(scene, view, mask, any_media, px, py, [&](Fragment f) { out.fragments[at++] = f; });
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
