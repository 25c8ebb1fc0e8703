// The segment walker (DESIGN.md §2.3): walks one ray's sorted fragments,
// matches entries to exits per object like brackets, and reports surfaces
// and the homogeneous segments between them to a visitor. Volume marching
// with empty-space skipping is a helper the visitors call.
#pragma once

#include "hd/channels.h"
#include "hd/explog.h"
#include "hd/fragment.h"
#include "hd/sort.h"
#include "hd/volume.h"

namespace cdsm {

// The objects enclosing a segment, with their nesting depth.
struct EnclosingSet {
  uint32_t object[kMaxEnclosing];
  uint32_t depth[kMaxEnclosing];
  int count = 0;

  CDSM_HD int find(uint32_t o) const {
    for (int i = 0; i < count; ++i)
      if (object[i] == o) return i;
    return -1;
  }
  // Returns false if the set is full (the walker keeps the entry in an
  // EnclosingOverflow).
  CDSM_HD bool enter(uint32_t o) {
    int i = find(o);
    if (i >= 0) {
      ++depth[i];
      return true;
    }
    if (count >= kMaxEnclosing) return false;
    object[count] = o;
    depth[count] = 1;
    ++count;
    return true;
  }
  CDSM_HD bool exit(uint32_t o) {
    int i = find(o);
    if (i < 0) return false;
    if (--depth[i] == 0) {
      object[i] = object[count - 1];
      depth[i] = depth[count - 1];
      --count;
    }
    return true;
  }
};

// The entries a full EnclosingSet cannot hold (issue 25 b). An interior
// that needs no identity in a segment — a constant medium, whose sigma only
// adds, or none at all — is kept as a sum: its sigma is added at its entry
// and taken off at its exit (the walker knows the object there), so
// constant media nest to any depth. A volume entering a full set takes the
// place of such a member (moved to the sum); only when every member is a
// volume (or nested in itself) is a volume left out: counted in
// WalkStats::enclosing_overflow, and warned about per frame.
struct EnclosingOverflow {
  Vec3 sigma{0, 0, 0};  // summed extinction of the constant media held here
  uint32_t count = 0;   // entries held here (or left out) whose exits are still to come
};

// Whether a segment's media need to know this interior (a volume is marched).
CDSM_HD CDSM_INLINE bool interior_needs_identity(const ObjectData& o) {
  return o.interior == InteriorKind::Volume && o.volume >= 0;
}

// The media of one homogeneous segment.
struct SegmentMedia {
  Vec3 sigma{0, 0, 0};             // summed extinction of enclosing constant media, per channel
  float step = 3.0e38f;            // smallest march step of the enclosing volumes
  uint32_t* lengthened = nullptr;  // counts segments whose march step had to grow to float resolution
  int volume_count = 0;
  uint32_t volume[kMaxEnclosing];
  uint32_t volume_object[kMaxEnclosing];  // the object bounding each volume
};

CDSM_HD CDSM_INLINE SegmentMedia media_of(const SceneView& s, const EnclosingSet& set, const EnclosingOverflow& over) {
  SegmentMedia m;
  m.sigma = over.sigma;
  for (int i = 0; i < set.count; ++i) {
    const ObjectData& o = s.objects[set.object[i]];
    if (o.interior == InteriorKind::Constant) {
      m.sigma += o.sigma;
    } else if (o.interior == InteriorKind::Volume && o.volume >= 0) {
      const VolumeData& v = s.volumes[uint32_t(o.volume)];
      m.volume[m.volume_count] = uint32_t(o.volume);
      m.volume_object[m.volume_count] = set.object[i];
      ++m.volume_count;
      m.step = fminf(m.step, v.step);
    }
  }
  return m;
}

// Counters a walk reports (summed into frame statistics).
struct WalkStats {
  uint32_t enclosing_overflow = 0;  // volume entries left out: inside kMaxEnclosing volumes already
  uint32_t match_overflow = 0;      // rays with more than kMaxRayObjects distinct objects (matched
                                    // in further passes: same answer)
  uint32_t unmatched = 0;           // entries or exits without a partner, ignored
  uint32_t march_lengthened = 0;    // volume segments whose march step was below the float
                                    // resolution of their depth and was lengthened to it
  CDSM_HD void add(const WalkStats& o) {
    enclosing_overflow += o.enclosing_overflow;
    match_overflow += o.match_overflow;
    unmatched += o.unmatched;
    march_lengthened += o.march_lengthened;
  }
};

// The shortest march step a segment ending at depth t1 can take and still
// advance in float: 4 ulps of |t1| (an ulp is at most |t| 2^-23). Marching a
// volume far from the eye (or light) with a finer step would never advance.
CDSM_HD CDSM_INLINE float min_march_step(float t0, float t1) {
  return fmaxf(fmaxf(fabsf(t0), fabsf(t1)) * 4.77e-7f, 1e-30f);
}

// An object's exit sorted before its own entry by less than this relative
// depth is one crossing point of its silhouette (an edge or vertex where the
// ray touches the mesh): the ray enters and leaves there. The producers
// compute each triangle's depth of that point separately; GL interpolates it
// at a pixel centre that may lie a snapping step outside the exact triangle,
// which at grazing incidence moves the depth by up to 1.4e-3 relative
// (measured over 3,000 random views of a box at 32..254 px). A genuine exit
// and re-entry this close changes only the medium of the gap between them.
inline constexpr float kCrossingTolerance = 4e-3f;

// After sorting: each exit of an object followed (within kCrossingTolerance)
// by an entry of the same object with none of its fragments between them is
// a silhouette crossing: the entry moves before the exit and takes its
// depth, so the bracket matcher sees enter-then-leave and the list stays
// sorted. Without this, both would be unmatched and ignored.
CDSM_HD inline void order_crossings(const SceneView& s, Span<Fragment> f) {
  const uint64_t n = f.size();
  for (uint64_t i = 0; i + 1 < n; ++i) {
    if (frag_front(f[i])) continue;
    const uint32_t o = s.tri_object[frag_prim(f[i])];
    const float limit = f[i].depth + kCrossingTolerance * fabsf(f[i].depth);
    for (uint64_t j = i + 1; j < n && f[j].depth <= limit; ++j) {
      if (s.tri_object[frag_prim(f[j])] != o) continue;
      if (frag_front(f[j])) {  // move the entry to i, shifting [i, j) up by one
        Fragment entry = f[j];
        entry.depth = f[i].depth;
        for (uint64_t k = j; k > i; --k) f[k] = f[k - 1];
        f[i] = entry;
        ++i;  // now at the exit
      }
      break;  // the next fragment of o decides
    }
  }
}

// After sorting: surfaces of different objects that touch (fragments within
// kRelativeDepthOffset of the first of a run) are put in the order of
// their ranks (hd/fragment.h surface_rank: leaving, open, entering), each
// object's own fragments keeping their order, and take the run's first
// depth. So a glass resting on an opaque slab, or a decal on it, comes
// before the slab's surface whatever the float ties, in the maps (which
// end at an opaque step) and in the camera pass (which shades the decal
// over the ground). Runs of one object are left as they are.
CDSM_HD inline void order_touching(const SceneView& s, Span<Fragment> f) {
  const uint64_t n = f.size();
  const auto rank = [&](Fragment x) {
    const uint32_t o = s.tri_object[frag_prim(x)];
    return surface_rank((s.objects[o].flags & kObjClosed) != 0u, frag_front(x));
  };
  uint64_t i = 0;
  while (i + 1 < n) {
    const float limit = f[i].depth + kRelativeDepthOffset * fabsf(f[i].depth);
    uint64_t j = i + 1;
    bool mixed = false;
    const uint32_t first = s.tri_object[frag_prim(f[i])];
    while (j < n && f[j].depth <= limit) {
      mixed = mixed || s.tri_object[frag_prim(f[j])] != first;
      ++j;
    }
    if (mixed) {
      const float depth = f[i].depth;
      // Adjacent swaps across objects only (runs are a few fragments).
      for (bool swapped = true; swapped;) {
        swapped = false;
        for (uint64_t k = i; k + 1 < j; ++k) {
          if (s.tri_object[frag_prim(f[k])] == s.tri_object[frag_prim(f[k + 1])] || rank(f[k + 1]) >= rank(f[k]))
            continue;
          const Fragment t = f[k];
          f[k] = f[k + 1];
          f[k + 1] = t;
          swapped = true;
        }
      }
      for (uint64_t k = i; k < j; ++k) f[k].depth = depth;
    }
    i = j;
  }
}

// Marks (kFragScratchBit) every front-facing fragment that has a matching
// back-facing fragment of the same object later on the ray; unmatched
// entries (open meshes, one-ulp silhouette ties) are then ignored. Objects
// are matched independently (an entry is matched by a later exit of its own
// object, scanning backwards), kMaxRayObjects at a time: a ray crossing more
// objects takes further passes over the objects with higher ids — the same
// answer, bounded work (counted in match_overflow).
CDSM_HD inline void mark_matched_entries(const SceneView& s, Span<Fragment> frags, WalkStats& st) {
  uint32_t obj[kMaxRayObjects];
  uint32_t pending[kMaxRayObjects];  // exits seen (scanning backwards) not yet matched
  // First pass: the first kMaxRayObjects objects met scanning backwards.
  int n = 0;
  bool overflow = false;
  for (uint64_t k = frags.size(); k-- > 0;) {
    Fragment& f = frags[k];
    f.bits &= ~kFragScratchBit;
    uint32_t o = s.tri_object[frag_prim(f)];
    int i = 0;
    while (i < n && obj[i] != o) ++i;
    if (i == n) {
      if (n == kMaxRayObjects) {
        overflow = true;
        continue;
      }
      obj[n] = o;
      pending[n] = 0;
      ++n;
    }
    if (!frag_front(f)) {
      ++pending[i];
    } else if (pending[i] > 0) {
      --pending[i];
      f.bits |= kFragScratchBit;
    }
  }
  if (!overflow) return;
  ++st.match_overflow;
  // More objects than the table holds: redo by object id, the
  // kMaxRayObjects smallest ids not yet handled per pass (sorted table).
  for (uint64_t k = 0; k < frags.size(); ++k) frags[k].bits &= ~kFragScratchBit;
  uint32_t lo = 0;  // ids below lo are done
  for (bool more = true; more;) {
    more = false;
    n = 0;
    for (uint64_t k = 0; k < frags.size(); ++k) {  // collect the next ids
      uint32_t o = s.tri_object[frag_prim(frags[k])];
      if (o < lo) continue;
      int i = 0;
      while (i < n && obj[i] < o) ++i;
      if (i < n && obj[i] == o) continue;
      if (n == kMaxRayObjects) {
        more = true;
        if (i == n) continue;  // larger than every id kept: a later pass
        --n;                   // drop the largest kept id: a later pass
      }
      for (int j = n; j > i; --j) obj[j] = obj[j - 1];
      obj[i] = o;
      ++n;
    }
    for (int i = 0; i < n; ++i) pending[i] = 0;
    for (uint64_t k = frags.size(); k-- > 0;) {  // match them
      Fragment& f = frags[k];
      uint32_t o = s.tri_object[frag_prim(f)];
      int i = 0;
      while (i < n && obj[i] != o) ++i;
      if (i == n) continue;
      if (!frag_front(f)) {
        ++pending[i];
      } else if (pending[i] > 0) {
        --pending[i];
        f.bits |= kFragScratchBit;
      }
    }
    if (n > 0) lo = obj[n - 1] + 1;
  }
}

// Enters object o: into the set, else (full) as EnclosingOverflow says.
CDSM_HD inline void enter_object(const SceneView& s, EnclosingSet& set, EnclosingOverflow& over, uint32_t o,
                                 WalkStats& st) {
  if (set.enter(o)) return;
  const ObjectData& od = s.objects[o];
  if (interior_needs_identity(od)) {
    for (int i = 0; i < set.count; ++i) {
      const ObjectData& member = s.objects[set.object[i]];
      if (set.depth[i] != 1u || interior_needs_identity(member)) continue;
      if (member.interior == InteriorKind::Constant) over.sigma += member.sigma;  // the member moves to the sum
      ++over.count;
      set.object[i] = o;
      return;
    }
    ++st.enclosing_overflow;  // left out
  } else if (od.interior == InteriorKind::Constant) {
    over.sigma += od.sigma;
  }
  ++over.count;
}

// Leaves object o; false if nothing entered it (an unmatched exit).
CDSM_HD inline bool exit_object(const SceneView& s, EnclosingSet& set, EnclosingOverflow& over, uint32_t o) {
  if (set.exit(o)) return true;
  if (over.count == 0) return false;
  const ObjectData& od = s.objects[o];
  if (od.interior ==
      InteriorKind::Constant)  // (never below 0: an unmatched exit meeting the sum takes off at most what is there)
    over.sigma = Vec3{fmaxf(over.sigma.x - od.sigma.x, 0.0f), fmaxf(over.sigma.y - od.sigma.y, 0.0f),
                      fmaxf(over.sigma.z - od.sigma.z, 0.0f)};
  if (--over.count == 0) over.sigma = Vec3{0, 0, 0};  // exactly: no rounding left behind
  return true;
}

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

// One march sample of the volumes in a segment.
struct MarchSample {
  float t0, t1;     // the sample's interval along the ray
  Vec3 extinction;  // summed sigma_t per channel at the interval's midpoint (constant media included;
                    // a step the tolerance bounds: the mean of its ends, march_segment)
  Vec3 color;       // extinction-weighted colour of the volumes there, per channel
  int dominant;     // index into media.volume of the largest extinction (any channel), -1 if none
};

// The opacity of one march sample per channel: 1 - exp(-sigma_k dt).
// (With the extinction in N channels, hd/channels.h: a grey map's one value.)
CDSM_HD CDSM_INLINE float sample_alpha(const MarchSample& ms, float extinction) {
  return 1.0f - expf_hd(-extinction * (ms.t1 - ms.t0));
}
CDSM_HD CDSM_INLINE Vec3 sample_alpha(const MarchSample& ms, Vec3 extinction) {
  const float dt = ms.t1 - ms.t0;
  return {1.0f - expf_hd(-extinction.x * dt), 1.0f - expf_hd(-extinction.y * dt), 1.0f - expf_hd(-extinction.z * dt)};
}
CDSM_HD CDSM_INLINE Vec3 sample_alpha(const MarchSample& ms) { return sample_alpha(ms, ms.extinction); }

// The parameter interval [enter, leave] of the index-space ray qo + t qd
// inside box [lo, hi] (enter > leave: it misses).
CDSM_HD CDSM_INLINE void ray_box_span(Vec3 qo, Vec3 qd, Vec3 lo, Vec3 hi, float& enter, float& leave) {
  enter = -3.0e38f;
  leave = 3.0e38f;
  for (int a = 0; a < 3; ++a) {
    if (qd[a] == 0.0f) {
      if (qo[a] < lo[a] || qo[a] > hi[a]) leave = -3.0e38f;
      continue;
    }
    float u = (lo[a] - qo[a]) / qd[a], w = (hi[a] - qo[a]) / qd[a];
    enter = fmaxf(enter, fminf(u, w));
    leave = fminf(leave, fmaxf(u, w));
  }
}

// The light pass's tolerances for marching a volume (issue 25 a), where
// the ray's transmittance is T (the largest over channels). Between two
// samples the map is linear while alpha(z) = 1 - T exp(-sigma z): their
// chord deviates by at most T h^2 sigma^2 / 8 (as for constant media,
// sample_constant_medium), within e = kVolumeChordError for steps h <=
// sqrt(8 e / T) / sigma. The step grows as the ray saturates: about
// 2 / sqrt(8 e) (16) samples reach saturation however dense the volume.
// An edge of the extinction (a thresholded transfer function) inside a
// step moves the optical depth by up to its height dsigma times h / 2
// (trapezoid rule): within kVolumeEdgeError / 2 where T dsigma h <=
// kVolumeEdgeError. With the compression's eps: within eps + e +
// kVolumeEdgeError / 2 wherever the volume's own step resolves its data.
inline constexpr float kVolumeChordError = 0.002f;
inline constexpr float kVolumeEdgeError = 0.004f;
inline constexpr int kMaxEdgeHalvings = 24;       // a float step halves to 4 ulps of t in fewer
inline constexpr float kSaturationDepth = 9.22f;  // optical depth of saturation: -ln(1 - kSaturatedAlpha)

struct MarchTolerance {
  float T;  // transmittance where the step starts (the largest over channels)
  // Whether a step of length h keeps its chords within kVolumeChordError
  // where the extinction is at most sigma.
  CDSM_HD bool allows(float sigma, float h) const { return T * (sigma * h) * (sigma * h) <= 8.0f * kVolumeChordError; }
  // The longest such step.
  CDSM_HD float step(float sigma) const {
    return sigma > 0.0f && T > 0.0f ? sqrtf(8.0f * kVolumeChordError / T) / sigma : 3.0e38f;
  }
  // Whether a step of length h whose ends read extinctions at most sigma,
  // differing by dsigma, keeps both bounds.
  CDSM_HD bool resolved(float sigma, float dsigma, float h) const {
    return allows(sigma, h) && T * dsigma * h <= kVolumeEdgeError;
  }
};

// A march with each volume's own step (the camera pass, the baselines,
// probes): no tolerance is asked.
struct NoMarchTolerance {
  CDSM_HD MarchTolerance operator()() const { return MarchTolerance{1.0f}; }
};
template <class Tolerance>
struct IsToleranceBounded {
  static constexpr bool value = true;
};
template <>
struct IsToleranceBounded<NoMarchTolerance> {
  static constexpr bool value = false;
};

// The largest extinction volume v can have around t on the ray (any
// channel): its macro-cell's maximum inside its cells box (the one-voxel
// apron: half a voxel beyond the cell too), its background's elsewhere;
// `until`: where that answer may change (the cell's or box's end).
CDSM_HD CDSM_INLINE float volume_bound_at(const SceneView& s, const VolumeData& v, Vec3 qo, Vec3 qd, float enter,
                                          float leave, float t, float& until) {
  const bool inside = t >= enter && t < leave;
  until = inside ? fminf(macro_cell_exit(qo, qd, t), leave) : enter > t ? enter : 3.0e38f;
  const float mx = inside ? macro_max_at(s, v, qo + qd * t) : -1.0f;
  return mx < 0.0f ? max_channel(apply_transfer(v.tf, v.background).extinction) : mx;
}

// Whether marching m can need a MarchTolerance: not where each volume's
// step allows the largest extinction of all the transfer functions (at T =
// 1, the strictest), unless constant media or a background fill the
// stretches outside the volumes' boxes (one sample each).
CDSM_HD inline bool may_need_tolerance(const SceneView& s, const SegmentMedia& m) {
  if (max_channel(m.sigma) > 0.0f) return true;
  float sigma_all = 0.0f, step_all = 0.0f;
  for (int i = 0; i < m.volume_count; ++i) {
    const VolumeData& v = s.volumes[m.volume[i]];
    if (max_channel(apply_transfer(v.tf, v.background).extinction) > 0.0f) return true;
    sigma_all += v.tf.max_extinction;
    step_all = fmaxf(step_all, v.step);
  }
  return !MarchTolerance{1.0f}.allows(sigma_all, step_all);
}

// Marches [t0, t1] through the segment's volumes, each with its own step
// where it can hold data (inside its cells box, VolumeData::cells_lo/hi)
// and not at all elsewhere (there it reads its background: constant), and
// skips stretches where every volume's macro-cell is empty of extinction
// (transfer-function output). Every iteration ends at a sample, a cell
// boundary, or a box boundary, each found from the index-space ray, at
// least 4 ulps of t on (a step below that is lengthened and counted in
// *m.lengthened): the work is bounded by the cells along the ray and by each
// volume's extent over its step, whatever the depth. A sample's extinction
// is read at its interval's midpoint.
// `tolerance()` (the light pass; NoMarchTolerance: none) gives the
// MarchTolerance where a step starts. A step of the volumes' own length
// whose macro-cells (at its two ends, volume_bound_at) may hold more
// extinction than it allows is bounded instead: it reads the media at both
// its ends, is at most the volumes' step, twice the last bounded step and
// the step the extinction at its start allows, and is halved until the two
// reads are resolved; the sample is their mean (trapezoid rule; the end's
// colour). Elsewhere (thin and empty stretches) the march takes the same
// samples as without a tolerance. Each volume's macro-cell is read once
// per cell the ray crosses, not per step.
// Callback: bool sample(const MarchSample&) (false stops), and
// void skip(float ta, float tb) for an empty stretch (so visitors can
// keep flat runs in the visibility function).
template <class OnSample, class OnSkip, class Tolerance = NoMarchTolerance>
CDSM_HD bool march_segment(const SceneView& s, const SegmentMedia& m, Vec3 org, Vec3 dir, float t0, float t1,
                           OnSample&& on_sample, OnSkip&& on_skip, const Tolerance& tolerance = Tolerance{}) {
  constexpr bool kBounded = IsToleranceBounded<Tolerance>::value;
  if (kBounded && !may_need_tolerance(s, m))  // the march without one: the same samples, no bookkeeping
    return march_segment(s, m, org, dir, t0, t1, on_sample, on_skip, NoMarchTolerance{});
  Vec3 qo[kMaxEnclosing], qd[kMaxEnclosing];
  float enter[kMaxEnclosing], leave[kMaxEnclosing];
  for (int i = 0; i < m.volume_count; ++i) {
    const VolumeData& v = s.volumes[m.volume[i]];
    qo[i] = v.world_to_index.point(org);
    qd[i] = v.world_to_index.vector(dir);
    ray_box_span(qo[i], qd[i], v.cells_lo, v.cells_hi, enter[i], leave[i]);
  }
  // The media at point p into ms (its interval untouched): summed
  // extinction per channel (constant media included), the volumes'
  // extinction-weighted colour and the dominant volume.
  const auto media_at = [&](Vec3 p, MarchSample& ms) {
    ms.extinction = m.sigma;
    ms.color = Vec3{0, 0, 0};
    ms.dominant = -1;
    float best = 0.0f;
    for (int i = 0; i < m.volume_count; ++i) {
      const VolumeData& v = s.volumes[m.volume[i]];
      TransferSample ts = apply_transfer(v.tf, density_at(s, v, p));
      ms.extinction += ts.extinction;
      ms.color += ts.color * ts.extinction;
      const float strongest = max_channel(ts.extinction);
      if (strongest > best) {
        best = strongest;
        ms.dominant = i;
      }
    }
    const Vec3 vol_ext = ms.extinction - m.sigma;
    ms.color = {vol_ext.x > 0.0f ? ms.color.x * (1.0f / vol_ext.x) : 0.0f,
                vol_ext.y > 0.0f ? ms.color.y * (1.0f / vol_ext.y) : 0.0f,
                vol_ext.z > 0.0f ? ms.color.z * (1.0f / vol_ext.z) : 0.0f};
  };
  bool lengthened = false;
  // Each volume's volume_bound_at, valid from t to cell_until; the
  // tolerance's state: the media read at the end of the last bounded step
  // (at bounded_end), and twice that step's length (steps grow back after
  // an edge).
  float cell_max[kMaxEnclosing], cell_until[kMaxEnclosing];
  for (int i = 0; i < m.volume_count; ++i) {
    cell_until[i] = -3.0e38f;  // probed at the first iteration
    cell_max[i] = 0.0f;
  }
  float bounded_end = -3.0e38f, grow = 3.0e38f;
  MarchSample start;
  float t = t0;
  while (t < t1) {
    // No step below float resolution here (4 ulps of t): counted once.
    const float progress = min_march_step(t, t);
    // Each volume's macro-cell bound, probed again only where the ray
    // crosses into another cell or box (a NanoVDB probe walks the tree).
    for (int i = 0; i < m.volume_count; ++i)
      if (t >= cell_until[i])
        cell_max[i] = volume_bound_at(s, s.volumes[m.volume[i]], qo[i], qd[i], enter[i], leave[i], t, cell_until[i]);
    // This stretch: the finest step of the volumes whose box holds t, and
    // the next box boundary of any volume.
    float h = 3.0e38f, next = t1;
    bool empty = max_channel(m.sigma) <= 0.0f;
    float empty_until = t1;
    for (int i = 0; i < m.volume_count; ++i) {
      const VolumeData& v = s.volumes[m.volume[i]];
      const bool inside = t >= enter[i] && t < leave[i];
      if (inside) {
        if (v.step < progress && !lengthened && m.lengthened) {
          lengthened = true;
          ++*m.lengthened;
        }
        h = fminf(h, fmaxf(v.step, progress));
        next = fminf(next, leave[i]);
      } else if (enter[i] > t && enter[i] <= leave[i]) {
        next = fminf(next, enter[i]);
      }
      if (!empty) continue;
      if (cell_max[i] > 0.0f) {
        empty = false;
      } else {
        empty_until = fminf(empty_until, inside ? cell_until[i] : next);  // inside: next <= leave[i]
      }
    }
    if (empty) {
      float tb = fminf(t1, fmaxf(fminf(empty_until, next), t + progress));
      on_skip(t, tb);
      t = tb;
      continue;
    }
    float te = fminf(fminf(t + h, next), t1);  // h = 3e38 outside every box: one sample to the next event
    if (!(te > t)) te = fminf(t + progress, t1);
    if (!(te > t)) te = t1;
    bool bounded = false;
    MarchTolerance tol{1.0f};
    if (kBounded) {
      tol = tolerance();
      float sigma_max = max_channel(m.sigma);
      for (int i = 0; i < m.volume_count; ++i) {
        float ahead = cell_max[i], until;
        if (te > cell_until[i])  // the step runs into the next cell
          ahead = volume_bound_at(s, s.volumes[m.volume[i]], qo[i], qd[i], enter[i], leave[i], te, until);
        sigma_max += fmaxf(cell_max[i], ahead);
      }
      bounded = !tol.allows(sigma_max, te - t);
    }
    // The reads of this step, through one call (so it is inlined): the
    // midpoint; or, bounded, the start where it is not known yet, then the
    // end of the step that start allows, halving it until the two are
    // resolved.
    bool need_start = bounded && bounded_end != t;
    if (need_start) grow = 3.0e38f;
    const float proposed = te - t;
    bool unresolved = false;  // the chords need a step below float resolution here
    MarchSample ms;
    for (int k = 0;; ++k) {
      if (bounded && !need_start && k == 0) {
        const float sigma0 = max_channel(start.extinction), fine = tol.step(sigma0);
        // Below float resolution (4 ulps of t) the ray saturates within a
        // few ulps: one step of kSaturationDepth optical depths stands for it.
        unresolved = fine < progress;
        const float h_step = unresolved ? fminf(proposed, fmaxf(progress, kSaturationDepth / sigma0))
                                        : fmaxf(fminf(fminf(proposed, grow), fine), progress);
        te = fminf(t + h_step, t1);
      }
      media_at(org + dir * (!bounded ? 0.5f * (t + te) : need_start ? t : te), ms);
      if (!bounded) break;
      if (need_start) {
        start = ms;
        need_start = false;
        k = -1;
        continue;
      }
      const Vec3 d = ms.extinction - start.extinction;
      const float sigma = fmaxf(max_channel(start.extinction), max_channel(ms.extinction));
      const float jump = fmaxf(fmaxf(fabsf(d.x), fabsf(d.y)), fabsf(d.z));
      const float half = t + 0.5f * (te - t);
      if (k == kMaxEdgeHalvings || unresolved || tol.resolved(sigma, jump, te - t) || !(half - t >= progress)) {
        const MarchSample end = ms;
        ms.extinction = (start.extinction + end.extinction) * 0.5f;
        start = end;
        bounded_end = te;
        grow = 2.0f * (te - t);
        break;
      }
      te = half;
    }
    ms.t0 = t;
    ms.t1 = te;
    if (!on_sample(ms)) return false;
    t = te;
  }
  return true;
}

// Sampling of a constant medium (extinction sigma) for a compressor (the
// light pass, the baselines): the
// chord of alpha(z) = 1 - T0 exp(-sigma (z - z0)) over a spacing h deviates
// from it by at most T h^2 sigma^2 / 8, T the transmittance at the chord's
// start. Spacing h = sqrt(8 e / T) / sigma keeps every chord within e, and
// grows as the medium saturates, so about 2 / sqrt(8 e) samples reach
// transmittance kConstantTail whatever sigma * length is (224 for e = 1e-5);
// sampling ends there. Chord and compression errors add: within eps + e.
inline constexpr float kConstantChordError = 1e-5f;
inline constexpr float kConstantTail = 1e-5f;     // transmittance where sampling ends (< 1 - kSaturatedAlpha)
inline constexpr int kMaxConstantSamples = 1024;  // bound against float luck; the spacing needs about 224

// The samples of a constant medium from t0 (transmittance T0 there) to t1,
// chord error `e`, in N channels (hd/channels.h: a float, or a Vec3 when the
// extinction differs between channels): calls emit(z, alpha) for each. The
// spacing is the smallest any channel still above the tail needs
// (sqrt(8 e / T_k) / sigma_k), so every channel's chord stays within e;
// sampling ends when every channel reaches kConstantTail.
template <class Alpha, class Emit>
CDSM_HD void sample_constant_medium(float t0, float t1, Alpha T0, Alpha sigma, float e, Emit&& emit) {
  constexpr int N = sizeof(Alpha) / sizeof(float);
  float z = t0;
  Alpha T = T0;
  for (int i = 0; i < kMaxConstantSamples && z < t1 && max_channel(T) > kConstantTail; ++i) {
    float h = 3.0e38f;
    for (int k = 0; k < N; ++k)
      if (channel(sigma, k) > 0.0f && channel(T, k) > kConstantTail)
        h = fminf(h, sqrtf(8.0f * e / channel(T, k)) / channel(sigma, k));
    float zn = fminf(z + h, t1);
    if (!(zn > z)) zn = fminf(nextafterf(z, 3.0e38f), t1);  // sigma beyond float resolution: a jump
    if (i + 1 == kMaxConstantSamples) zn = t1;
    const float d = zn - t0;
    for (int k = 0; k < N; ++k) set_channel(T, k, channel(T0, k) * expf_hd(-channel(sigma, k) * d));
    emit(zn, one_minus(T));
    z = zn;
  }
}

}  // namespace cdsm
