// Visibility-function compression (thesis Alg. 3.2, Lokovic & Veach 2000),
// generalized to non-uniform depth spacing and clamped so the result stays
// physical: slopes >= 0 and the line never exceeds 1 (DESIGN.md §2.4).
// Guarantee: at every pushed sample |alpha'(z) - alpha(z)| <= eps (+ float
// rounding); alpha' is monotone and within [0, 1].
#pragma once

#include "cdsm/math.h"
#include "hd/span.h"

namespace cdsm {

// One node of a visibility function: accumulated opacity alpha at depth z.
// Two nodes with equal z form a step (a surface). std430: 8 bytes.
struct DsmNode {
  float z;      // radial depth from the light, world units
  float alpha;  // accumulated opacity 1 - V(z), in [0, 1]
};
static_assert(sizeof(DsmNode) == 8, "DsmNode is 8 bytes");

// Nodes written straight into memory the caller sized (re-compression).
struct RawSink {
  DsmNode* nodes;
  int count = 0;
  CDSM_HD void emit(float z, float a) { nodes[count++] = DsmNode{z, a}; }
};

// A bounded node buffer. When full, the nodes already emitted are compressed
// again with a larger tolerance until half the buffer is free; the extra
// error is recorded, nothing is dropped.
struct NodeBuffer {
  DsmNode* nodes;
  int capacity;
  int count = 0;
  float extra_error = 0.0f;  // added by re-compressions (bound at samples)
  int recompressions = 0;
  float eps = 0.0f;          // tolerance of the compressor feeding it
  CDSM_HD inline void emit(float z, float a);
};

// The clamped wedge. Feed samples in non-decreasing z with push(); a surface
// is push(z, before) followed by step(z, after); finish() closes the
// function. Sink: emit(z, a), `nodes` and `count` (NodeBuffer or RawSink).
template <class Sink>
struct Wedge {
  float eps = 0.0f;
  bool has_origin = false;
  float z0 = 0.0f, a0 = 0.0f;    // origin: the last emitted node
  float lo = 0.0f, hi = 0.0f;    // admissible slopes of the current line
  bool pending = false;          // samples accepted since the origin
  float zl = 0.0f, al = 0.0f;    // last accepted sample

  CDSM_HD explicit Wedge(float e) : eps(e) {}

  CDSM_HD void set_origin(Sink& buf, float z, float a) {
    buf.emit(z, a);
    z0 = z;
    a0 = buf.nodes[buf.count - 1].alpha;  // a re-compression may have moved it
    pending = false;
  }

  // Value of the current line at the last accepted sample, chosen inside the
  // wedge as close as possible to that sample (exact when the wedge allows;
  // the thesis takes the wedge's midpoint, equally admissible).
  CDSM_HD float line_end() const {
    float dz = zl - z0;
    return clampf(al, a0 + lo * dz, a0 + hi * dz);
  }

  // Starts a new wedge from the origin through sample (z, a), z > z0.
  CDSM_HD void restart(float z, float a) {
    float dz = z - z0;
    lo = fmaxf(0.0f, (a - eps - a0) / dz);
    hi = fminf((a + eps - a0) / dz, (1.0f - a0) / dz);
    if (hi < lo) hi = lo;  // only by rounding
    zl = z;
    al = a;
    pending = true;
  }

  CDSM_HD void push(Sink& buf, float z, float a) {
    a = clampf(a, 0.0f, 1.0f);
    if (!has_origin) {
      has_origin = true;
      set_origin(buf, z, a);
      return;
    }
    if (!pending) {
      if (z <= z0) {  // same depth as the origin: a jump is a step
        if (a > a0) step(buf, z, a);
        return;
      }
      restart(z, a);
      return;
    }
    if (z <= zl) {  // same depth as the last sample
      if (a != al) {
        set_origin(buf, zl, line_end());
        step(buf, z, a);
      }
      return;
    }
    float dz = z - z0;
    float nlo = fmaxf(lo, (a - eps - a0) / dz);
    float nhi = fminf(hi, fminf((a + eps - a0) / dz, (1.0f - a0) / dz));
    if (nlo <= nhi) {
      lo = nlo;
      hi = nhi;
      zl = z;
      al = a;
      return;
    }
    set_origin(buf, zl, line_end());  // the wedge emptied: close the line
    restart(z, a);
  }

  // A surface at depth z raises alpha to `after` (push(z, before) came first).
  CDSM_HD void step(Sink& buf, float z, float after) {
    after = clampf(after, 0.0f, 1.0f);
    if (!has_origin) {
      has_origin = true;
      set_origin(buf, z, 0.0f);
    }
    if (pending) set_origin(buf, zl, line_end());
    after = fmaxf(after, a0);  // monotone
    // Coincident surfaces: raise the step's upper node instead of adding one.
    if (buf.count >= 2 && buf.nodes[buf.count - 1].z == z && buf.nodes[buf.count - 2].z == z) {
      buf.nodes[buf.count - 1].alpha = after;
      a0 = after;
      return;
    }
    set_origin(buf, z, after);
  }

  CDSM_HD void finish(Sink& buf) {
    if (pending) set_origin(buf, zl, line_end());
  }
};

using WedgeCompressor = Wedge<NodeBuffer>;

// Re-compresses buf's nodes in place with tolerance max(2 eps, 1e-3),
// doubling until at most half the capacity is used. Steps (equal z) stay
// steps while the tolerance is below 1; beyond, a step is merged into the
// line (its lower node dropped), so the count always falls below half the
// capacity. The added error is recorded. The output never overtakes the
// input, so in place is safe.
CDSM_HD inline void recompress(NodeBuffer& buf) {
  float e = fmaxf(2.0f * buf.eps, 1e-3f);
  while (buf.count > buf.capacity / 2) {
    const bool merge_steps = e >= 1.0f;
    int n = buf.count;
    RawSink out{buf.nodes, 0};
    Wedge<RawSink> c(e);
    DsmNode prev{0.0f, 0.0f};
    float merged = 0.0f;  // largest step merged into a line
    for (int i = 0; i < n; ++i) {
      DsmNode nd = buf.nodes[i];  // read before the output can overwrite it
      if (merge_steps && i + 1 < n && buf.nodes[i + 1].z == nd.z && buf.nodes[i + 1].alpha > nd.alpha) {
        merged = fmaxf(merged, buf.nodes[i + 1].alpha - nd.alpha);  // drop a step's lower node
        prev = nd;
        continue;
      }
      bool step = i > 0 && nd.z == prev.z && nd.alpha > prev.alpha;
      if (step && !merge_steps)
        c.step(out, nd.z, nd.alpha);
      else
        c.push(out, nd.z, nd.alpha);
      prev = nd;
    }
    c.finish(out);
    buf.count = out.count;
    buf.extra_error += fmaxf(e, merged);
    buf.recompressions += 1;
    if (merge_steps && e >= 4.0f) break;  // every line fits: at most a handful of nodes left
    e *= 2.0f;
  }
}

CDSM_HD inline void NodeBuffer::emit(float z, float a) {
  if (count >= capacity) {
    recompress(*this);
    // Keep the function monotone: a re-compressed last node may lie above `a`.
    if (count > 0) a = fmaxf(a, nodes[count - 1].alpha);
  }
  if (count < capacity) nodes[count++] = DsmNode{z, a};
}

}  // namespace cdsm
