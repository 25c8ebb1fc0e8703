// Write side of the `fixed` layout (thesis §4.2.1, the "3D texture";
// DESIGN.md §3): every texel owns L node slots, its nodes first, then pads
// (hd/dsm.h, kFixedPadZ). A texel with more than L nodes is re-compressed
// until it fits — never truncated:
//   1. the wedge again over its nodes with a larger tolerance e (doubling
//      from max(2 eps, 1e-3) like compress.h's recompress, then bisected),
//      which keeps every node within e;
//   2. when steps alone need more than L nodes (the wedge keeps every
//      surface as two nodes at any e), greedy removal: stream the nodes
//      through the L slots, dropping each time the node whose removal changes
//      alpha least.
// The extra error returned is the true sup over z of |alpha_fit(z) -
// alpha(z)| (hd/dsm.h max_change).
#pragma once

#include "hd/dsm.h"

namespace cdsm {

// A wedge sink over the L slots: the first L nodes land in the slots, later
// ones are only counted (a two-node ring keeps what the wedge reads back).
template <class NodeT>
struct FixedSlotSink {
  using Node = NodeT;
  using Alpha = Channels<Node::kChannels>;
  struct Nodes {
    FixedSlotSink* s;
    CDSM_HD Node& operator[](int i) const { return i < s->cap ? s->slots[i] : s->spill[i & 1]; }
  };
  Node* slots;
  int cap;
  SurfaceTag* tags;  // per slot (cap entries), or null: the tags are not kept
  int count = 0;
  Node spill[2];
  SurfaceTag last_tag_ = kNoSurface;
  Nodes nodes;

  CDSM_HD FixedSlotSink(Node* sl, int c, SurfaceTag* t = nullptr) : slots(sl), cap(c), tags(t), spill{}, nodes{this} {}
  FixedSlotSink(const FixedSlotSink&) = delete;
  FixedSlotSink& operator=(const FixedSlotSink&) = delete;
  CDSM_HD void emit(float z, Alpha a, SurfaceTag tag = kNoSurface) {
    if (tags && count < cap) tags[count] = tag;
    last_tag_ = tag;
    nodes[count++] = Node{z, a};
  }
  CDSM_HD SurfaceTag last_tag() const { return last_tag_; }
  CDSM_HD int size() const { return count; }
  CDSM_HD Node& last() { return nodes[count - 1]; }
  CDSM_HD Node& before_last() { return nodes[count - 2]; }
  CDSM_HD void raise_last(Alpha a) { last().alpha = a; }
  CDSM_HD void compact() {}
};

// The tag of node i of a list whose tags may be absent (null: none kept).
CDSM_HD CDSM_INLINE SurfaceTag tag_at(const SurfaceTag* tags, uint64_t i) { return tags ? tags[i] : kNoSurface; }

// Re-compresses a node list (tags: per node, or null) with tolerance e into
// `out` (steps stay steps, with their surfaces' tags); every input node
// stays within e (+ float rounding) of the output.
template <class Node, class Sink>
CDSM_HD void rewedge_nodes(Span<const Node> in, const SurfaceTag* tags, float e, Sink& out) {
  Wedge<Sink> c(e);
  for (uint64_t i = 0; i < in.size(); ++i) {
    const Node nd = in[i];
    if (i > 0 && nd.z == in[i - 1].z && (rises(nd.alpha, in[i - 1].alpha) || tag_at(tags, i) != kNoSurface))
      c.step(out, nd.z, nd.alpha, tag_at(tags, i));
    else
      c.push(out, nd.z, nd.alpha);
  }
  c.finish(out);
}

// How much alpha changes (at z_m, where it changes most) when node m is
// removed from between its neighbours a and b; of RGB nodes, the largest
// channel's change.
template <int N>
CDSM_HD CDSM_INLINE float removal_cost(const DsmNodeN<N>& a, const DsmNodeN<N>& m, const DsmNodeN<N>& b) {
  if (b.z <= a.z) return 0.0f;  // all three at one depth: m is never seen
  const Channels<N> line = m.z <= a.z ? a.alpha : (m.z >= b.z ? b.alpha : alpha_between(a, b, m.z));
  return max_channel(abs_channels(m.alpha - line));
}

// Stage 2: keeps at most L >= 2 nodes of `in` in `slots`, streaming; the
// first and the last node are always kept. Returns the sum of the removal
// costs (each removal changes alpha by at most its cost, so the sum bounds
// the total change); `count` receives the nodes kept.
template <class Node>
CDSM_HD inline float greedy_fit_nodes(Span<const Node> in, const SurfaceTag* in_tags, Node* slots,
                                      SurfaceTag* slot_tags, int L, int& count) {
  int n = 0;
  float err = 0.0f;
  for (uint64_t i = 0; i < in.size(); ++i) {
    const Node x = in[i];
    if (n < L) {
      if (slot_tags) slot_tags[n] = tag_at(in_tags, i);
      slots[n++] = x;
      continue;
    }
    int best = 1;
    float best_cost = 3.0e38f;
    for (int k = 1; k < L; ++k) {
      float c = removal_cost(slots[k - 1], slots[k], k + 1 < L ? slots[k + 1] : x);
      if (c < best_cost) {
        best_cost = c;
        best = k;
      }
    }
    for (int k = best; k + 1 < L; ++k) slots[k] = slots[k + 1];
    slots[L - 1] = x;
    if (slot_tags) {
      for (int k = best; k + 1 < L; ++k) slot_tags[k] = slot_tags[k + 1];
      slot_tags[L - 1] = tag_at(in_tags, i);
    }
    err += best_cost;
  }
  count = n;
  return err;
}

// What writing one texel did.
struct FixedFit {
  int count = 0;              // nodes stored (<= L)
  float extra_error = 0.0f;   // the change the re-compression made, sup over z (0 if none)
  bool recompressed = false;  // the texel had more than L nodes
};

// Stage 1 for tolerance e: writes into the slots, returns the node count
// (the slots hold a valid result only when it is <= L).
template <class Node>
CDSM_HD CDSM_INLINE int fixed_rewedge(Span<const Node> in, const SurfaceTag* in_tags, float e, Node* slots,
                                      SurfaceTag* slot_tags, int L) {
  FixedSlotSink<Node> sink(slots, L, slot_tags);
  rewedge_nodes(in, in_tags, e, sink);
  return sink.count;
}

// Writes a texel's nodes `in` (eps: the tolerance they were built with) into
// its L slots, re-compressing them when there are more than L, and pads the
// rest; their tags (in_tags: per node, or null) into slot_tags (L entries,
// or null: not kept; pads kNoSurface). L >= 2. Scalar or RGB nodes.
template <class Node>
CDSM_HD inline FixedFit write_fixed_texel(Span<const Node> in, const SurfaceTag* in_tags, float eps, Node* slots,
                                          SurfaceTag* slot_tags, int L) {
  CDSM_HD_ASSERT(L >= 2);
  FixedFit r;
  if (in.size() <= uint64_t(L)) {
    for (uint64_t i = 0; i < in.size(); ++i) slots[i] = in[i];
    if (slot_tags)
      for (uint64_t i = 0; i < in.size(); ++i) slot_tags[i] = tag_at(in_tags, i);
    r.count = int(in.size());
  } else {
    r.recompressed = true;
    // Doubling: the first tolerance that fits, as compress.h's recompress.
    float lo = 0.0f, hi = -1.0f;
    for (float e = fmaxf(2.0f * eps, 1e-3f); e < 2.0f; e *= 2.0f) {
      if (fixed_rewedge(in, in_tags, e, slots, slot_tags, L) <= L) {
        hi = e;
        break;
      }
      lo = e;
    }
    if (hi > 0.0f) {
      // A few bisection steps towards the smallest tolerance that fits.
      for (int it = 0; it < 4 && lo > 0.0f; ++it) {
        float mid = 0.5f * (lo + hi);
        if (fixed_rewedge(in, in_tags, mid, slots, slot_tags, L) <= L)
          hi = mid;
        else
          lo = mid;
      }
      r.count =
          fixed_rewedge(in, in_tags, hi, slots, slot_tags, L);  // the slots hold the last trial: redo the one that fits
    }
    if (hi <= 0.0f || r.count > L) greedy_fit_nodes(in, in_tags, slots, slot_tags, L, r.count);
  }
  if (r.recompressed) r.extra_error = max_change(in, Span<const Node>{slots, uint64_t(r.count)});  // the true change
  const Node last = r.count > 0 ? slots[r.count - 1] : Node{};
  for (int k = r.count; k < L; ++k) {
    slots[k] = last;
    slots[k].z = kFixedPadZ;
    if (slot_tags) slot_tags[k] = kNoSurface;
  }
  return r;
}

}  // namespace cdsm
