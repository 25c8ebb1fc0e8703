// Visibility-function compression (thesis Alg. 3.2, Lokovic & Veach 2000),
// generalized to non-uniform depth spacing and clamped so the result stays
// physical: slopes >= 0 and the line never exceeds 1 (DESIGN.md §2.4).
// Guarantee: at every pushed sample |alpha'(z) - alpha(z)| <= eps (+ float
// rounding); alpha' is monotone and within [0, 1].
// Written once over N colour channels (hd/channels.h): a coloured map's
// channels share node depths, each keeps its own admissible slopes and
// stays within eps; a line closes as soon as any channel's would empty.
// With N = 1 every operation is the scalar one, in the same order.
#pragma once

#include "cdsm/math.h"
#include "hd/channels.h"
#include "hd/fragment.h"
#include "hd/span.h"

namespace cdsm {

// One node of a visibility function: accumulated opacity alpha at depth z,
// per channel. Two nodes with equal z form a step (a surface). std430:
// 8 bytes (grey) or 16 (RGB: a vec4 z, r, g, b).
template <int N>
struct DsmNodeN {
  static constexpr int kChannels = N;
  float z;            // radial depth from the light, world units
  Channels<N> alpha;  // accumulated opacity 1 - V_k(z), each in [0, 1]
};
using DsmNode = DsmNodeN<1>;
using DsmNodeRgb = DsmNodeN<3>;
static_assert(sizeof(DsmNode) == 8, "DsmNode is 8 bytes");
static_assert(sizeof(DsmNodeRgb) == 16, "DsmNodeRgb is 16 bytes (std430 vec4)");
CDSM_HD CDSM_INLINE float node_alpha(const DsmNode& n) { return n.alpha; }
CDSM_HD CDSM_INLINE Vec3 node_alpha(const DsmNodeRgb& n) { return n.alpha; }

// Which surface a step belongs to (DESIGN.md §8: receivers leave out their
// own surface by identity). Kept per node beside the nodes (one 16-bit tag
// per node slot, in a parallel array): a step's upper node carries the tag
// of the surface that made it, every other node kNoSurface. A tag holds
//   bits 0-13   the object: its index modulo 16383, plus 1 (0: no surface);
//   bits 14-15  how the light ray crossed it (hd/fragment.h surface_rank):
//               leaving a closed object, an open surface, or entering one.
// Up to 16383 casters no two objects share a tag; beyond, two objects 16383
// apart do, which matters only where both have a step within a receiver's
// search window of its plane in one texel.
using SurfaceTag = uint16_t;
inline constexpr SurfaceTag kNoSurface = 0u;
inline constexpr uint32_t kTagObjectBits = 0x3fffu;
CDSM_HD CDSM_INLINE uint32_t tag_object(uint32_t object) { return object % kTagObjectBits + 1u; }
CDSM_HD CDSM_INLINE SurfaceTag surface_tag(uint32_t object, uint32_t rank) {
  return SurfaceTag((rank << 14) | tag_object(object));
}
CDSM_HD CDSM_INLINE uint32_t tag_object_of(SurfaceTag t) { return uint32_t(t) & kTagObjectBits; }
CDSM_HD CDSM_INLINE uint32_t tag_rank_of(SurfaceTag t) { return uint32_t(t) >> 14; }

// Working memory of a node buffer that overflows (NodeBuffer): per slot a
// linked list (prev, next), a min-heap of removal costs (heap, pos, cost) and
// a bound on how far the function over the span ending at the slot has moved
// from the one fed in (span_error). Each array holds `capacity` entries.
struct RemovalScratch {
  uint32_t* prev = nullptr;
  uint32_t* next = nullptr;
  uint32_t* heap = nullptr;
  uint32_t* pos = nullptr;
  float* cost = nullptr;
  float* span_error = nullptr;
  CDSM_HD bool empty() const { return prev == nullptr; }
};

// A bounded node buffer of a texel's visibility function. While the nodes
// fit, they are stored as emitted. Beyond, every new node streams in and the
// interior node whose removal changes the function least goes (greedy
// removal, as AVSM does and the fixed layout's write_fixed_texel): the
// triangle it spans with its neighbours has the smallest area, ties by the
// smallest change of alpha. First and last nodes stay and kept nodes keep
// their values, so the function stays monotone, within [0, 1], and spans
// its depth range; a step becomes a ramp only where that is cheapest.
// Measured on 40 translucent steps into 8..128 nodes: within 1.95x of the
// minimax-optimal fit with as many nodes (tests/unit/test_compress.cpp);
// a minimum-change (L-infinity) criterion gave up to 2.4x there.
// `extra_error` bounds the change of alpha(z) over all z (per span: the
// removed node's change plus the larger of its two spans' bounds) — never
// below the true change. Nothing is dropped silently.
//
// A buffer holds at most node_limit(capacity) = capacity - max(1,
// capacity/8) nodes. With scratch (RemovalScratch), removal costs live in a
// heap and removed slots are unlinked, compacted once per capacity/8 new
// nodes: O(log K) per node. Without scratch the same nodes are chosen by a
// scan and the slots shifted, O(K) per node, and the bound is the sum of the
// changes instead of the per-span one (looser, still never below the truth).
// Capacity >= 4. Either node kind: the removal cost of an RGB node is the
// largest over its channels (removal_cost_of below).
template <int N>
struct NodeBufferN {
  using Node = DsmNodeN<N>;
  using Alpha = Channels<N>;
  Node* nodes;
  int capacity;
  int count = 0;             // slots used (with scratch after an overflow: removed ones among them)
  float extra_error = 0.0f;  // bound of the change of alpha(z) caused by removals (max over spans)
  int removed = 0;           // nodes removed to fit
  float eps = 0.0f;          // tolerance of the compressor feeding it
  RemovalScratch scratch;
  SurfaceTag* tags = nullptr;         // per slot, the node's SurfaceTag (capacity entries); null: not kept
  SurfaceTag last_tag_ = kNoSurface;  // the last node's tag (kept also without `tags`)
  // A first walk into a small buffer (shadows/exec/light_pass.h): beyond
  // node_limit(capacity) nodes nothing is removed or stored, `removed`
  // only says the texel needs a larger buffer (it is walked again).
  bool stop_when_full = false;
  // Overflow state (with scratch): nodes are linked over slots [0, count).
  bool linked = false;
  int alive = 0;  // nodes of the function when linked
  uint32_t heap_size = 0;

  CDSM_HD inline void emit(float z, Alpha a, SurfaceTag tag = kNoSurface);
  CDSM_HD inline CDSM_NOINLINE void emit_full(float z, Alpha a,
                                              SurfaceTag tag);  // emit() past node_limit or once linked
  CDSM_HD int size() const { return linked ? alive : count; }   // nodes of the function
  CDSM_HD Node& last() { return nodes[count - 1]; }             // the last node is always slot count - 1
  CDSM_HD SurfaceTag last_tag() const { return last_tag_; }
  CDSM_HD Node& before_last() { return nodes[linked ? scratch.prev[count - 1] : uint32_t(count - 2)]; }
  CDSM_HD inline void raise_last(Alpha a);  // a coincident surface raises the last node
  CDSM_HD inline void compact();            // the function's nodes into slots [0, size()), in order
};
using NodeBuffer = NodeBufferN<1>;
using RgbNodeBuffer = NodeBufferN<3>;

// The clamped wedge. Feed samples in non-decreasing z with push(); a surface
// is push(z, before) followed by step(z, after, tag); finish() closes the
// function. Sink: emit(z, a, tag), size(), last(), last_tag(), before_last(),
// raise_last(a) over nodes of N channels (NodeBufferN, or hd/dsm_fixed.h's
// FixedSlotSink); the wedge keeps per channel k its admissible slopes
// (lo_k, hi_k), accepts a sample while every channel's interval stays
// non-empty and closes the line of all channels as soon as one's would
// empty. A step's upper node carries its surface's tag; coincident steps
// of one object share their upper node (with the first one's tag: an edge
// or silhouette crossed twice), those of different objects each keep their
// own (so a receiver can leave out exactly its own, DESIGN.md §8).
template <class Sink>
struct Wedge {
  static constexpr int N = Sink::Node::kChannels;
  using Alpha = Channels<N>;
  float eps = 0.0f;
  // The largest alpha a line may reach: 1, or a total the caller knows
  // (tabulate_absorbance: a reconstruction never above its exact total).
  float cap = 1.0f;
  bool has_origin = false;
  float z0 = 0.0f;
  Alpha a0{};                    // origin: the last emitted node
  float lo[N] = {}, hi[N] = {};  // admissible slopes of the current line, per channel
  bool pending = false;          // samples accepted since the origin
  float zl = 0.0f;
  Alpha al{};  // last accepted sample

  CDSM_HD explicit Wedge(float e) : eps(e) {}

  CDSM_HD void set_origin(Sink& buf, float z, Alpha a, SurfaceTag tag = kNoSurface) {
    buf.emit(z, a, tag);
    z0 = z;
    a0 = buf.last().alpha;
    pending = false;
  }

  // Value of each channel's line at the last accepted sample, chosen inside
  // its wedge as close as possible to that sample (exact when the wedge
  // allows; the thesis takes the wedge's midpoint, equally admissible).
  CDSM_HD Alpha line_end() const {
    const float dz = zl - z0;
    Alpha e{};
    for (int k = 0; k < N; ++k) {
      const float a0k = channel(a0, k);
      set_channel(
          e, k,
          fminf(clampf(channel(al, k), a0k + lo[k] * dz, a0k + hi[k] * dz), cap));  // the bounds can round past it
    }
    return e;
  }

  // Starts a new wedge from the origin through sample (z, a), z > z0.
  CDSM_HD void restart(float z, Alpha a) {
    const float dz = z - z0;
    for (int k = 0; k < N; ++k) {
      const float ak = channel(a, k), a0k = channel(a0, k);
      lo[k] = fmaxf(0.0f, (ak - eps - a0k) / dz);
      hi[k] = fminf((ak + eps - a0k) / dz, (cap - a0k) / dz);
      if (hi[k] < lo[k]) hi[k] = lo[k];  // only by rounding
    }
    zl = z;
    al = a;
    pending = true;
  }

  // The common case inline: a sample the current wedge still admits
  // narrows it. Every other case (the first sample, a new line, a jump at
  // one depth) goes out of line: a walk pushes from many places, and a
  // GPU kernel would otherwise carry a copy of all of it at each.
  CDSM_HD void push(Sink& buf, float z, Alpha a) {
    a = clamp01(a);
    if (has_origin && pending && !(z <= zl)) {  // (as push_rest tests it: a NaN z too)
      const float dz = z - z0;
      float nlo[N], nhi[N];
      bool fits = true;
      for (int k = 0; k < N; ++k) {
        const float ak = channel(a, k), a0k = channel(a0, k);
        nlo[k] = fmaxf(lo[k], (ak - eps - a0k) / dz);
        nhi[k] = fminf(hi[k], fminf((ak + eps - a0k) / dz, (cap - a0k) / dz));
        fits = fits && nlo[k] <= nhi[k];
      }
      if (fits) {
        for (int k = 0; k < N; ++k) {
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

  // push() of a sample the current wedge does not narrow to.
  CDSM_HD CDSM_NOINLINE void push_rest(Sink& buf, float z, Alpha a) {
    if (!has_origin) {
      has_origin = true;
      set_origin(buf, z, a);
      return;
    }
    if (!pending) {
      if (z <= z0) {  // same depth as the origin: a jump is a step
        if (rises(a, a0)) step(buf, z, a);
        return;
      }
      restart(z, a);
      return;
    }
    if (z <= zl) {  // same depth as the last sample
      if (!same_channels(a, al)) {
        set_origin(buf, zl, line_end());
        step(buf, z, a);
      }
      return;
    }
    // Beyond the last sample: push() found that some channel's wedge is empty.
    set_origin(buf, zl, line_end());  // close the line
    restart(z, a);
  }

  // A surface (tag: which one) at depth z raises alpha to `after`
  // (push(z, before) came first).
  CDSM_HD CDSM_NOINLINE void step(Sink& buf, float z, Alpha after, SurfaceTag tag = kNoSurface) {
    after = clamp01(after);
    if (!has_origin) {
      has_origin = true;
      set_origin(buf, z, Alpha{});
    }
    if (pending) set_origin(buf, zl, line_end());
    after = channel_max(after, a0);  // monotone, per channel
    // Coincident crossings of one surface: raise the step's upper node
    // instead of adding one.
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
    buf.compact();  // the function's nodes in order from slot 0
  }
};

using WedgeCompressor = Wedge<NodeBuffer>;
using WedgeCompressorRgb = Wedge<RgbNodeBuffer>;

// Cost of removing node m between a and b: the area of the triangle the
// three span (what the function loses), and the change of alpha at m. A
// vertical run (a.z == b.z) hides m: free.
struct RemovalCost {
  float area, change;
};
// Over channels: the largest channel's change (and so its area).
template <int N>
CDSM_HD CDSM_INLINE RemovalCost removal_cost_of(const DsmNodeN<N>& a, const DsmNodeN<N>& m, const DsmNodeN<N>& b) {
  if (!(b.z > a.z)) return {0.0f, 0.0f};
  const float w = clampf((m.z - a.z) / (b.z - a.z), 0.0f, 1.0f);
  float change = 0.0f;
  for (int k = 0; k < N; ++k) {
    const float ak = channel(a.alpha, k);
    const float ck = fabsf(channel(m.alpha, k) - (ak + (channel(b.alpha, k) - ak) * w));
    change = k == 0 ? ck : fmaxf(change, ck);
  }
  return {0.5f * change * (b.z - a.z), change};
}
// Smaller area first; at equal area the smaller change (then the first node).
CDSM_HD CDSM_INLINE bool cheaper(RemovalCost x, RemovalCost y) {
  return x.area < y.area || (x.area == y.area && x.change < y.change);
}

// ---- without scratch: scan and shift ----------------------------------------

// Makes room for `incoming` in a full buffer nodes[0, count) (count >= 2):
// removes the cheapest of nodes 1 .. count-1 (the last one is interior once
// `incoming` follows it), the first of equally cheap ones, and adds its
// change to the error bound (without per-span memory, the sum of the
// changes bounds the total).
// Either node kind (removal_cost_of: the largest channel's cost).
template <class Node>
CDSM_HD inline void remove_cheapest_scan(Node* n, int& count, Node incoming, float& extra_error,
                                         SurfaceTag* tags = nullptr) {
  int best = 1;
  RemovalCost best_cost{3.0e38f, 3.0e38f};
  for (int i = 1; i < count; ++i) {
    RemovalCost c = removal_cost_of(n[i - 1], n[i], i + 1 < count ? n[i + 1] : incoming);
    if (cheaper(c, best_cost)) {
      best_cost = c;
      best = i;
    }
  }
  for (int i = best; i + 1 < count; ++i) n[i] = n[i + 1];
  if (tags)
    for (int i = best; i + 1 < count; ++i) tags[i] = tags[i + 1];
  --count;
  extra_error += best_cost.change;
}

// ---- with scratch: a heap over linked slots -----------------------------------

namespace node_heap {

// Heap order of two linked interior nodes: cost[] holds the area; equal
// areas compare the change (recomputed: ties are rare), then the slot.
template <class Node>
CDSM_HD inline bool less(const RemovalScratch& w, const Node* n, uint32_t x, uint32_t y) {
  if (w.cost[x] != w.cost[y]) return w.cost[x] < w.cost[y];
  float cx = removal_cost_of(n[w.prev[x]], n[x], n[w.next[x]]).change;
  float cy = removal_cost_of(n[w.prev[y]], n[y], n[w.next[y]]).change;
  return cx < cy || (cx == cy && x < y);
}
CDSM_HD CDSM_INLINE void place(const RemovalScratch& w, uint32_t slot, uint32_t node) {
  w.heap[slot] = node;
  w.pos[node] = slot;
}
template <class Node>
CDSM_HD inline void sift_up(const RemovalScratch& w, const Node* n, uint32_t slot) {
  uint32_t node = w.heap[slot];
  while (slot > 0) {
    uint32_t parent = (slot - 1) / 2;
    if (!less(w, n, node, w.heap[parent])) break;
    place(w, slot, w.heap[parent]);
    slot = parent;
  }
  place(w, slot, node);
}
template <class Node>
CDSM_HD inline void sift_down(const RemovalScratch& w, const Node* n, uint32_t slot, uint32_t size) {
  uint32_t node = w.heap[slot];
  for (;;) {
    uint32_t c = 2 * slot + 1;
    if (c >= size) break;
    if (c + 1 < size && less(w, n, w.heap[c + 1], w.heap[c])) ++c;
    if (!less(w, n, w.heap[c], node)) break;
    place(w, slot, w.heap[c]);
    slot = c;
  }
  place(w, slot, node);
}

inline constexpr uint32_t kNone = 0xffffffffu;

}  // namespace node_heap

// The heap's key: the area (node_heap::less breaks ties as the scan does).
template <class Node>
CDSM_HD CDSM_INLINE float removal_key(const Node& a, const Node& m, const Node& b) {
  return removal_cost_of(a, m, b).area;
}

// (Re)computes the heap key of interior node m and restores heap order.
template <int N>
CDSM_HD inline void update_node(NodeBufferN<N>& b, uint32_t m) {
  const RemovalScratch& w = b.scratch;
  w.cost[m] = removal_key(b.nodes[w.prev[m]], b.nodes[m], b.nodes[w.next[m]]);
  if (w.pos[m] == node_heap::kNone) {
    node_heap::place(w, b.heap_size++, m);
  }
  node_heap::sift_up(w, b.nodes, w.pos[m]);
  node_heap::sift_down(w, b.nodes, w.pos[m], b.heap_size);
}

// Links the nodes in slots [0, count) and builds the heap of the interior.
template <int N>
CDSM_HD inline void link_nodes(NodeBufferN<N>& b, bool keep_span_errors) {
  const RemovalScratch& w = b.scratch;
  const uint32_t n = uint32_t(b.count);
  for (uint32_t i = 0; i < n; ++i) {
    w.prev[i] = i == 0 ? node_heap::kNone : i - 1;
    w.next[i] = i + 1 == n ? node_heap::kNone : i + 1;
    w.pos[i] = node_heap::kNone;
    if (!keep_span_errors) w.span_error[i] = 0.0f;
  }
  b.heap_size = 0;
  for (uint32_t i = 1; i + 1 < n; ++i) {
    w.cost[i] = removal_key(b.nodes[i - 1], b.nodes[i], b.nodes[i + 1]);
    node_heap::place(w, b.heap_size++, i);
  }
  for (uint32_t k = b.heap_size / 2; k-- > 0;) node_heap::sift_down(w, b.nodes, k, b.heap_size);
  b.alive = b.count;
  b.linked = true;
}

// Removes the cheapest interior node of a linked buffer.
template <int N>
CDSM_HD inline void remove_cheapest_linked(NodeBufferN<N>& b) {
  const RemovalScratch& w = b.scratch;
  uint32_t i = w.heap[0];
  w.pos[i] = node_heap::kNone;
  if (--b.heap_size > 0) {
    node_heap::place(w, 0, w.heap[b.heap_size]);
    node_heap::sift_down(w, b.nodes, 0, b.heap_size);
  }
  uint32_t a = w.prev[i], c = w.next[i];
  RemovalCost cost = removal_cost_of(b.nodes[a], b.nodes[i], b.nodes[c]);
  // The new span (a, c): its change from the function fed in is at most the
  // change at i plus the larger bound of the two spans it replaces.
  w.span_error[c] = cost.change + fmaxf(w.span_error[i], w.span_error[c]);
  b.extra_error = fmaxf(b.extra_error, w.span_error[c]);
  w.next[a] = c;
  w.prev[c] = a;
  --b.alive;
  if (w.prev[a] != node_heap::kNone) update_node(b, a);
  if (w.next[c] != node_heap::kNone) update_node(b, c);
}

template <int N>
CDSM_HD inline void NodeBufferN<N>::compact() {
  if (!linked) return;
  const RemovalScratch& w = scratch;
  int out = 0;
  for (uint32_t i = 0; i != node_heap::kNone; i = w.next[i]) {
    nodes[out] = nodes[i];  // out <= i: in place
    if (tags) tags[out] = tags[i];
    w.span_error[out] = w.span_error[i];
    ++out;
  }
  count = out;
  linked = false;
}

template <int N>
CDSM_HD inline void NodeBufferN<N>::raise_last(Alpha a) {
  nodes[count - 1].alpha = a;
  if (linked && scratch.prev[count - 1] != node_heap::kNone && scratch.pos[scratch.prev[count - 1]] != node_heap::kNone)
    update_node(*this, scratch.prev[count - 1]);
}

// Most nodes a buffer holds: capacity less the slack the linked version
// needs to reuse removed slots (compaction once per `slack` new nodes). The
// scan version keeps the same limit, so both choose the same nodes.
CDSM_HD CDSM_INLINE int node_limit(int capacity) { return capacity - (capacity / 8 > 1 ? capacity / 8 : 1); }

template <int N>
CDSM_HD inline void NodeBufferN<N>::emit(float z, Alpha a, SurfaceTag tag) {
  const int limit = node_limit(capacity);
  if (stop_when_full && count >= limit) {
    ++removed;
    return;
  }
  last_tag_ = tag;
  if (!linked && count < limit) {  // room: appended as emitted (with or without scratch)
    if (tags) tags[count] = tag;
    nodes[count++] = Node{z, a};
    return;
  }
  emit_full(z, a, tag);
}

template <int N>
CDSM_HD void NodeBufferN<N>::emit_full(float z, Alpha a, SurfaceTag tag) {
  const int limit = node_limit(capacity);
  if (scratch.empty()) {
    if (count >= limit && count >= 2) {
      remove_cheapest_scan(nodes, count, Node{z, a}, extra_error, tags);
      ++removed;
    }
    if (count < capacity) {
      if (tags) tags[count] = tag;
      nodes[count++] = Node{z, a};
    }
    return;
  }
  if (!linked) link_nodes(*this, false);
  if (count == capacity) {
    compact();
    link_nodes(*this, true);
  }
  const uint32_t t = uint32_t(count);
  nodes[t] = Node{z, a};
  if (tags) tags[t] = tag;
  scratch.prev[t] = t - 1;
  scratch.next[t] = node_heap::kNone;
  scratch.next[t - 1] = t;
  scratch.pos[t] = node_heap::kNone;
  scratch.span_error[t] = 0.0f;
  ++count;
  ++alive;
  if (scratch.prev[t - 1] != node_heap::kNone) update_node(*this, t - 1);  // the old last node is interior now
  if (alive > limit) {
    remove_cheapest_linked(*this);
    ++removed;
  }
}

}  // namespace cdsm
