// Fragment lists on the host (DESIGN.md §2.1): their owner, and the exact
// ray-cast producer on CPU threads — the executor's (shadows/exec/
// camera_pass.h cast_fragments_exec over HostExec), the same code a CUDA
// device runs — one list per pixel, the OpenGL rasterizer's format.
#pragma once

#include <vector>

#include "hd/fragment.h"
#include "hd/scene_data.h"
#include "hd/view.h"

namespace cdsm {

// Owner of one view's fragment lists (also the read-back target of GL).
struct FragmentBuffers {
  int32_t width = 0, height = 0;
  std::vector<uint32_t> offsets;  // width*height + 1
  std::vector<Fragment> fragments;
  FragmentLists lists() {
    FragmentLists l;
    l.width = width;
    l.height = height;
    l.offsets = {offsets.data(), offsets.size()};
    l.fragments = {fragments.data(), fragments.size()};
    return l;
  }
  size_t total() const { return fragments.size(); }
};

// Every crossing of every pixel-centre ray with the triangles of objects in
// `mask`, whose view-axis coordinate lies in [near, far]. Lists are not
// sorted (consumers sort). Count pass, prefix sum, fill pass, on CPU
// threads (defined in shadows/exec/host_exec.cpp).
void cast_fragments(const SceneView& scene, const PinholeView& view, ObjectMask mask, FragmentBuffers& out);

}  // namespace cdsm

namespace cdsm {
// The closed objects (of `mask`) containing `point` (parity ray), decided
// once per view for the segment walker's inside-at-start set.
std::vector<uint32_t> objects_containing(const SceneView& scene, Vec3 point, ObjectMask mask);
}  // namespace cdsm
