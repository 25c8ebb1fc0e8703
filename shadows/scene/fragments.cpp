// The closed objects containing a point (the walker's inside-at-start set).
// The exact ray caster itself runs through an executor
// (shadows/exec/host_exec.cpp).
#include "scene/fragments.h"

#include "hd/cast.h"

namespace cdsm {

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
