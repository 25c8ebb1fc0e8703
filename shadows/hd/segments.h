// The segment walker (DESIGN.md §2.3): walks one ray's sorted fragments,
// matches entries to exits per object like brackets, and reports surfaces
// and the homogeneous segments between them to a visitor. Volume marching
// with empty-space skipping is a helper the visitors call.
// The parts: hd/enclosing.h (the media of a segment), hd/crossings.h (a
// ray's fragments ordered and matched), hd/march.h (volume marching),
// hd/constant_medium.h (sampling an absorber for a compressor).
#pragma once

#include "hd/constant_medium.h"
#include "hd/crossings.h"
#include "hd/enclosing.h"
#include "hd/march.h"
#include "hd/sort.h"

namespace cdsm {

// Walks a ray through its fragments. `frags` are sorted here (in place).
// `inside` lists objects containing the eye (decided once per view).
// Visitor interface:
//   bool surface(float t, uint32_t tri, bool front)     -> false stops the walk
//   bool segment(float t0, float t1, const SegmentMedia&) -> false stops
// Segments are reported only where some object encloses them, within
// [t_start, t_end]. Clipped fragments (outside the view's [near, far]) bound
// media but are never reported as surfaces: media absorb from t_start (the
// eye) to t_end (the far distance) wherever their boundaries lie.
// A ray's fragments in walking order, entries matched: sorted by depth,
// crossings and touching surfaces ordered, matched entries marked. The same
// for every visitor, so compiled once (out of line on a GPU).
CDSM_HD CDSM_NOINLINE inline void prepare_fragments(const SceneView& s, Span<Fragment> frags, WalkStats& st) {
  sort_fragments(frags);
  order_crossings(s, frags);
  order_touching(s, frags);
  mark_matched_entries(s, frags, st);
}

template <class Visitor>
CDSM_HD void walk_ray(const SceneView& s, Span<Fragment> frags, Span<const uint32_t> inside, float t_start, float t_end,
                      Visitor& vis, WalkStats& st) {
  prepare_fragments(s, frags, st);
  EnclosingSet set;
  EnclosingOverflow over;
  for (uint64_t i = 0; i < inside.size(); ++i) enter_object(s, set, over, inside[i], st);
  float t_prev = t_start;
  for (uint64_t k = 0; k < frags.size(); ++k) {
    Fragment f = frags[k];
    float t = fminf(fmaxf(f.depth, t_start), t_end);
    if ((set.count > 0 || over.count > 0) && t > t_prev) {
      SegmentMedia m = media_of(s, set, over);
      m.lengthened = &st.march_lengthened;
      if ((max_channel(m.sigma) > 0.0f || m.volume_count > 0) && !vis.segment(t_prev, t, m)) return;
    }
    t_prev = fmaxf(t_prev, t);
    if (frag_clipped(f) && f.depth > t_end) continue;  // beyond far: bounds nothing left to report
    uint32_t tri = frag_prim(f);
    if (!frag_clipped(f) && !vis.surface(f.depth, tri, frag_front(f))) return;
    uint32_t o = s.tri_object[tri];
    if ((s.objects[o].flags & kObjClosed) == 0u) continue;  // open meshes have no interior
    if (frag_front(f)) {
      if ((f.bits & kFragScratchBit) != 0u)
        enter_object(s, set, over, o, st);
      else
        ++st.unmatched;
    } else if (!exit_object(s, set, over, o)) {
      ++st.unmatched;
    }
  }
  if ((set.count > 0 || over.count > 0) && t_end > t_prev) {
    SegmentMedia m = media_of(s, set, over);
    m.lengthened = &st.march_lengthened;
    if (max_channel(m.sigma) > 0.0f || m.volume_count > 0) vis.segment(t_prev, t_end, m);
  }
}

}  // namespace cdsm
