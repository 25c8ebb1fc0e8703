// The media of a homogeneous segment (DESIGN.md §2.3): the objects
// enclosing it with their nesting (EnclosingSet, and the constant media a
// full set keeps as a sum), entering and leaving them, and the counters a
// ray's walk reports.
#pragma once

#include "hd/channels.h"
#include "hd/fragment.h"
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

}  // namespace cdsm
