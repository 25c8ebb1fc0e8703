// The clamped wedge over three channels (issue "Coloured shadows"): one
// piecewise-linear visibility function per colour channel, compressed with
// shared node depths. Each channel keeps its own admissible-slope interval
// (lo_k, hi_k), exactly as the scalar wedge (hd/compress.h) keeps one; a
// sample is accepted when every channel's interval stays non-empty, and the
// line of all three is closed (a node emitted) as soon as any channel's
// would empty. Guarantee, per channel k, at every pushed sample:
// |alpha'_k(z) - alpha_k(z)| <= eps (+ float rounding); every alpha'_k is
// monotone and within [0, 1]. With equal channels (a grey caster) every
// decision and value is the scalar wedge's, bit for bit.
#pragma once

#include "hd/compress.h"

namespace cdsm {

// One node of an RGB visibility function: accumulated opacity per channel
// at depth z. std430: 16 bytes (a vec4: z, then r, g, b).
struct DsmNodeRgb {
  float z;
  float r, g, b;  // 1 - V_k(z), each in [0, 1]
};
static_assert(sizeof(DsmNodeRgb) == 16, "DsmNodeRgb is 16 bytes (std430 vec4)");

CDSM_HD CDSM_INLINE float channel(const Vec3& v, int k) { return k == 0 ? v.x : (k == 1 ? v.y : v.z); }
CDSM_HD CDSM_INLINE Vec3 rgb_of(const DsmNodeRgb& n) { return {n.r, n.g, n.b}; }

// Sink: emit(z, Vec3 a), size(), last(), before_last() (DsmNodeRgb&),
// raise_last(Vec3 a), compact() — the scalar wedge's interface with RGB nodes.
template <class Sink>
struct WedgeRgb {
  float eps = 0.0f;
  bool has_origin = false;
  float z0 = 0.0f;
  Vec3 a0{0, 0, 0};                          // origin: the last emitted node
  float lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};  // admissible slopes per channel
  bool pending = false;                      // samples accepted since the origin
  float zl = 0.0f;
  Vec3 al{0, 0, 0};                          // last accepted sample

  CDSM_HD explicit WedgeRgb(float e) : eps(e) {}

  CDSM_HD void set_origin(Sink& buf, float z, Vec3 a, SurfaceTag tag = kNoSurface) {
    buf.emit(z, a, tag);
    z0 = z;
    a0 = rgb_of(buf.last());
    pending = false;
  }

  // Each channel's line value at the last accepted sample, inside its
  // wedge, as close as possible to that sample, and never above 1 (the
  // wedge's bounds can round past it).
  CDSM_HD Vec3 line_end() const {
    const float dz = zl - z0;
    return {fminf(clampf(al.x, a0.x + lo[0] * dz, a0.x + hi[0] * dz), 1.0f),
            fminf(clampf(al.y, a0.y + lo[1] * dz, a0.y + hi[1] * dz), 1.0f),
            fminf(clampf(al.z, a0.z + lo[2] * dz, a0.z + hi[2] * dz), 1.0f)};
  }

  CDSM_HD void restart(float z, Vec3 a) {
    const float dz = z - z0;
    for (int k = 0; k < 3; ++k) {
      const float ak = channel(a, k), a0k = channel(a0, k);
      lo[k] = fmaxf(0.0f, (ak - eps - a0k) / dz);
      hi[k] = fminf((ak + eps - a0k) / dz, (1.0f - a0k) / dz);
      if (hi[k] < lo[k]) hi[k] = lo[k];  // only by rounding
    }
    zl = z;
    al = a;
    pending = true;
  }

  static CDSM_HD Vec3 clamp01(Vec3 a) { return {clampf(a.x, 0.0f, 1.0f), clampf(a.y, 0.0f, 1.0f), clampf(a.z, 0.0f, 1.0f)}; }
  static CDSM_HD bool same(Vec3 a, Vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }
  static CDSM_HD bool above(Vec3 a, Vec3 b) { return a.x > b.x || a.y > b.y || a.z > b.z; }

  // As Wedge::push: a sample the wedges still admit inline, the rest out
  // of line.
  CDSM_HD void push(Sink& buf, float z, Vec3 a) {
    a = clamp01(a);
    if (has_origin && pending && !(z <= zl)) {  // (as push_rest tests it: a NaN z too)
      const float dz = z - z0;
      float nlo[3], nhi[3];
      bool fits = true;
      for (int k = 0; k < 3; ++k) {
        const float ak = channel(a, k), a0k = channel(a0, k);
        nlo[k] = fmaxf(lo[k], (ak - eps - a0k) / dz);
        nhi[k] = fminf(hi[k], fminf((ak + eps - a0k) / dz, (1.0f - a0k) / dz));
        fits = fits && nlo[k] <= nhi[k];
      }
      if (fits) {
        for (int k = 0; k < 3; ++k) {
          lo[k] = nlo[k];
          hi[k] = nhi[k];
        }
        zl = z;
        al = a;
        return;
      }
    }
    push_rest(buf, z, a);
  }

  // push() of a sample the wedges do not narrow to.
  CDSM_HD CDSM_NOINLINE void push_rest(Sink& buf, float z, Vec3 a) {
    if (!has_origin) {
      has_origin = true;
      set_origin(buf, z, a);
      return;
    }
    if (!pending) {
      if (z <= z0) {  // same depth as the origin: a jump is a step
        if (above(a, a0)) step(buf, z, a);
        return;
      }
      restart(z, a);
      return;
    }
    if (z <= zl) {  // same depth as the last sample
      if (!same(a, al)) {
        set_origin(buf, zl, line_end());
        step(buf, z, a);
      }
      return;
    }
    // Beyond the last sample: push() found some channel's wedge empty.
    set_origin(buf, zl, line_end());  // close every line
    restart(z, a);
  }

  // A surface (tag: which one) at depth z raises alpha to `after`
  // (push(z, before) came first).
  CDSM_HD CDSM_NOINLINE void step(Sink& buf, float z, Vec3 after, SurfaceTag tag = kNoSurface) {
    after = clamp01(after);
    if (!has_origin) {
      has_origin = true;
      set_origin(buf, z, Vec3{0, 0, 0});
    }
    if (pending) set_origin(buf, zl, line_end());
    after = vmax(after, a0);  // monotone per channel
    // Coincident crossings of one surface: raise the step's upper node
    // instead of adding one (hd/compress.h Wedge::step).
    if (buf.size() >= 2 && buf.last().z == z && buf.before_last().z == z &&
        tag_object_of(buf.last_tag()) == tag_object_of(tag)) {
      buf.raise_last(after);
      a0 = after;
      return;
    }
    set_origin(buf, z, after, tag);
  }

  CDSM_HD void finish(Sink& buf) {
    if (pending) set_origin(buf, zl, line_end());
    buf.compact();
  }
};

CDSM_HD CDSM_INLINE Vec3 node_alpha(const DsmNodeRgb& n) { return rgb_of(n); }
CDSM_HD CDSM_INLINE float node_alpha(const DsmNode& n) { return n.alpha; }

// Cost of removing RGB node m between a and b: the largest over channels
// of the scalar cost (hd/compress.h removal_cost_of).
CDSM_HD CDSM_INLINE RemovalCost removal_cost_of(const DsmNodeRgb& a, const DsmNodeRgb& m, const DsmNodeRgb& b) {
  RemovalCost worst{0.0f, 0.0f};
  for (int k = 0; k < 3; ++k) {
    const RemovalCost c = removal_cost_of(DsmNode{a.z, channel(rgb_of(a), k)}, DsmNode{m.z, channel(rgb_of(m), k)},
                                          DsmNode{b.z, channel(rgb_of(b), k)});
    worst.area = fmaxf(worst.area, c.area);
    worst.change = fmaxf(worst.change, c.change);
  }
  return worst;
}

// A bounded node buffer of an RGB visibility function: nodes as emitted
// while they fit; beyond node_limit(capacity), each new node streams in and
// the interior node whose removal changes the function least goes (the
// largest channel's triangle area, as the scalar NodeBuffer without
// scratch: a scan, O(K) per node, only on overflow). `extra_error` bounds
// the change of every channel over all z (the sum of the removed nodes'
// changes); nothing is dropped silently. Capacity >= 4.
struct RgbNodeBuffer {
  DsmNodeRgb* nodes;
  int capacity;
  int count = 0;
  float extra_error = 0.0f;
  int removed = 0;
  float eps = 0.0f;  // tolerance of the compressor feeding it
  SurfaceTag* tags = nullptr;         // per slot, the node's SurfaceTag; null: not kept
  SurfaceTag last_tag_ = kNoSurface;  // the last node's tag
  bool stop_when_full = false;        // as NodeBuffer's: a first walk that only learns it needs more
  CDSM_HD void emit(float z, Vec3 a, SurfaceTag tag = kNoSurface) {
    if (stop_when_full && count >= node_limit(capacity)) {
      ++removed;
      return;
    }
    const DsmNodeRgb incoming{z, a.x, a.y, a.z};
    if (count >= node_limit(capacity) && count >= 2) make_room(incoming);
    if (tags) tags[count] = tag;
    last_tag_ = tag;
    nodes[count++] = incoming;
  }
  // Full: the cheapest interior node goes (out of line: the overflow path).
  CDSM_HD CDSM_NOINLINE void make_room(const DsmNodeRgb& incoming) {
    remove_cheapest_scan(nodes, count, incoming, extra_error, tags);
    ++removed;
  }
  CDSM_HD int size() const { return count; }
  CDSM_HD SurfaceTag last_tag() const { return last_tag_; }
  CDSM_HD DsmNodeRgb& last() { return nodes[count - 1]; }
  CDSM_HD DsmNodeRgb& before_last() { return nodes[count - 2]; }
  CDSM_HD void raise_last(Vec3 a) {
    nodes[count - 1].r = a.x;
    nodes[count - 1].g = a.y;
    nodes[count - 1].b = a.z;
  }
  CDSM_HD void compact() {}
};

using WedgeCompressorRgb = WedgeRgb<RgbNodeBuffer>;

// alpha'(z) of an RGB node list, channel by channel (linear between nodes,
// the first node's value before it, the last's after it; at a step's depth
// the upper value).
CDSM_HD CDSM_INLINE Vec3 eval_rgb(Span<const DsmNodeRgb> n, float z) {
  if (n.size() == 0) return {0, 0, 0};
  uint32_t lo = 0, hi = uint32_t(n.size());
  while (lo < hi) {  // first node with depth > z
    const uint32_t mid = (lo + hi) >> 1;
    if (n[mid].z <= z) lo = mid + 1;
    else hi = mid;
  }
  if (lo == 0) return {n[0].r, n[0].g, n[0].b};
  const DsmNodeRgb& a = n[lo - 1];
  if (lo == n.size() || a.z == z) return {a.r, a.g, a.b};
  const DsmNodeRgb& b = n[lo];
  const float w = (z - a.z) / (b.z - a.z);
  return {a.r + (b.r - a.r) * w, a.g + (b.g - a.g) * w, a.b + (b.b - a.b) * w};
}

}  // namespace cdsm
