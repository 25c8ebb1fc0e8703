// The fragment-list format shared by every producer (CPU ray caster, OpenGL
// rasterizer) and every consumer (segment walker, light and camera passes).
// DESIGN.md §2.1. The same bytes live in a GL shader-storage buffer (std430).
#pragma once

#include "hd/span.h"

namespace cdsm {

// One surface crossing of a pixel's ray.
struct Fragment {
  float depth;    // radial distance from the eye, world units
  uint32_t bits;  // bits 0..28 primitive index, bit 29 clipped, bit 30 scratch (walker),
                  // bit 31 front-facing
};
static_assert(sizeof(Fragment) == 8, "Fragment is 8 bytes in std430");

inline constexpr uint32_t kFragFrontBit = 0x80000000u;
inline constexpr uint32_t kFragScratchBit = 0x40000000u;
// A clipped fragment lies outside the view's [near, far] on the view axis:
// its surface is not seen (not shaded, casts nothing), but it bounds a
// medium, so the walker still matches it (DESIGN.md §2.3, media rule below).
inline constexpr uint32_t kFragClippedBit = 0x20000000u;
inline constexpr uint32_t kFragPrimMask = 0x1fffffffu;
inline constexpr uint32_t kMaxPrimitives = kFragPrimMask;  // primitive ids must stay below

CDSM_HD CDSM_INLINE Fragment make_fragment(float depth, uint32_t prim, bool front, bool clipped = false) {
  return Fragment{depth, (prim & kFragPrimMask) | (front ? kFragFrontBit : 0u) | (clipped ? kFragClippedBit : 0u)};
}
CDSM_HD CDSM_INLINE uint32_t frag_prim(Fragment f) { return f.bits & kFragPrimMask; }
CDSM_HD CDSM_INLINE bool frag_front(Fragment f) { return (f.bits & kFragFrontBit) != 0u; }
CDSM_HD CDSM_INLINE bool frag_clipped(Fragment f) { return (f.bits & kFragClippedBit) != 0u; }

// Deterministic order: depth, then primitive id, then facing (DESIGN.md §2.2).
CDSM_HD CDSM_INLINE bool frag_less(Fragment a, Fragment b) {
  if (a.depth != b.depth) return a.depth < b.depth;
  uint32_t pa = a.bits & (kFragPrimMask | kFragFrontBit), pb = b.bits & (kFragPrimMask | kFragFrontBit);
  return pa < pb;
}

// How a ray crosses a surface. A closed object's front face is where the
// ray enters it, its back face where it leaves; an open mesh has no inside.
// The ranks order surfaces that touch (closer than kRelativeDepthOffset of
// their depth): the light leaves one closed object before it crosses an
// open surface lying there, and both before it enters another closed
// object. A surface of lower rank is in front of one of higher rank (a glass
// resting on a slab, a decal on the ground shadow them); two of the same
// rank (two slabs' coplanar tops) lie side by side, neither in front.
inline constexpr uint32_t kRankExit = 0u;
inline constexpr uint32_t kRankOpen = 1u;
inline constexpr uint32_t kRankEntry = 2u;
CDSM_HD CDSM_INLINE uint32_t surface_rank(bool closed, bool front) {
  return closed ? (front ? kRankEntry : kRankExit) : kRankOpen;
}

// Surfaces closer than this, relative to their depth, touch: about twice
// the largest relative depth difference measured between the GL and the
// CPU fragment producers (8.9e-6, tests/gl) plus float rounding.
inline constexpr float kRelativeDepthOffset = 2e-5f;

// Per-pixel fragment lists of one view: pixel i owns
// fragments[offsets[i] .. offsets[i+1]). Row-major, py = 0 first.
struct FragmentLists {
  int32_t width = 0;
  int32_t height = 0;
  Span<const uint32_t> offsets;  // width*height + 1 entries
  Span<Fragment> fragments;      // mutable: consumers sort in place
  CDSM_HD Span<Fragment> pixel(int px, int py) const {
    uint64_t i = uint64_t(py) * uint64_t(width) + uint64_t(px);
    return fragments.subspan(offsets[i], offsets[i + 1] - offsets[i]);
  }
};

}  // namespace cdsm
