// Light pass (DESIGN.md §2.4): one texel's visibility function — walk the
// light ray's segments, accumulate alpha, compress on the fly.
#pragma once

#include "hd/baselines.h"
#include "hd/compress.h"
#include "hd/dsm_fixed.h"
#include "hd/segments.h"
#include "hd/view.h"

namespace cdsm {

struct LightPassParams {
  PinholeView view;                         // the map's view from the light
  float epsilon;                            // compression bound
  Span<const uint32_t> inside;              // caster objects containing the light
  ShadowMethod method = ShadowMethod::Dsm;  // DSM, or a baseline (hd/baselines.h)
  float method_param = 0.0f;                // the baseline's parameter (0: its default)
  float layer_thickness = 0.0f;             // deep opacity maps: along the ray (0: each texel's caster extent / N)
  bool rgb = false;                         // RGB nodes (a coloured caster among the map's members; DSM only)
  bool blocker_pyramid = false;             // with its blocker pyramid (hd/blocker_pyramid.h): a light with a size
};

// One texel's walk in N colour channels (hd/channels.h; N from the sink's
// nodes): alpha per channel, one wedge with shared node depths, each
// channel within eps. A grey map (N = 1) takes each caster's absorption
// and extinction as one value (grey_of: a coloured one's channel mean,
// ShadowSettings::rgb_maps). A ray ends early only when every channel is
// saturated. Sink: where the wedge's nodes go — a NodeBufferN (the bounded
// buffer of a texel), or a FixedSlotSink (hd/dsm_fixed.h) that counts them
// or writes them straight into a layout (shadows/exec/light_pass.h).
template <class Sink>
struct DsmVisitorOf {
  static constexpr int N = Sink::Node::kChannels;
  using Alpha = Channels<N>;
  const SceneView& s;
  Vec3 org, dir;
  float eps;
  Wedge<Sink> c;
  Sink& buf;
  Alpha alpha{};

  CDSM_HD DsmVisitorOf(const SceneView& sv, Vec3 o, Vec3 d, float e, Sink& b)
      : s(sv), org(o), dir(d), eps(e), c(e), buf(b) {}

  CDSM_HD bool saturated() const { return min_channel(alpha) >= kSaturatedAlpha; }

  CDSM_HD bool surface(float t, uint32_t tri, bool front) {
    const uint32_t obj = s.tri_object[tri];
    const ObjectData& o = s.objects[obj];
    const Alpha op = from_rgb<N>(o.absorb);
    if (max_channel(op) <= 0.0f) return true;  // passes all light (hd/scene_data.h passes_all)
    c.push(buf, t, alpha);
    alpha = alpha + op * one_minus(alpha);  // alpha_k + a_k (1 - alpha_k): one more layer
    c.step(buf, t, alpha, surface_tag(obj, surface_rank((o.flags & kObjClosed) != 0u, front)));
    return !saturated();
  }

  CDSM_HD bool segment(float t0, float t1, const SegmentMedia& m) {
    c.push(buf, t0, alpha);
    if (m.volume_count == 0) {
      sample_constant_medium(t0, t1, one_minus(alpha), from_rgb<N>(m.sigma), kConstantChordError,
                             [&](float z, Alpha a) {
                               alpha = a;
                               c.push(buf, z, alpha);
                             });
      return !saturated();
    }
    return march_segment(
        s, m, org, dir, t0, t1,
        [&](const MarchSample& ms) {
          alpha = alpha + sample_alpha(ms, from_rgb<N>(ms.extinction)) * one_minus(alpha);
          c.push(buf, ms.t1, alpha);
          return !saturated();
        },
        [&](float ta, float tb) {
          c.push(buf, ta, alpha);
          c.push(buf, tb, alpha);
        },
        [&] { return MarchTolerance{max_channel(one_minus(alpha))}; });  // the least saturated channel
  }
};

using DsmVisitor = DsmVisitorOf<NodeBuffer>;
using DsmVisitorRgb = DsmVisitorOf<RgbNodeBuffer>;

// Walks texel (tx, ty)'s light ray with visitor kind V (scalar or RGB),
// compressing into `sink`; fragments sorted in place.
template <class Visitor, class Sink>
CDSM_HD inline void walk_texel_into(const SceneView& s, const LightPassParams& p, Span<Fragment> frags, int tx, int ty,
                                    Sink& sink, WalkStats& st) {
  const Vec3 dir = pixel_ray(p.view, tx, ty);
  Visitor vis(s, pixel_origin(p.view, tx, ty), dir, p.epsilon, sink);
  const float t_end = p.view.far / fmaxf(dot(dir, p.view.forward), 1e-6f);
  walk_ray(s, frags, p.inside, 0.0f, t_end, vis, st);
  vis.c.finish(sink);
}

// Out of line on a GPU: the first and the second walk of a texel share one
// compiled copy.
template <class Visitor, class Buffer>
CDSM_HD CDSM_NOINLINE inline void walk_texel(const SceneView& s, const LightPassParams& p, Span<Fragment> frags, int tx,
                                             int ty, Buffer& buf, WalkStats& st) {
  buf.eps = p.epsilon;
  walk_texel_into<Visitor>(s, p, frags, tx, ty, buf, st);
}

// Builds texel (tx, ty): its fragments (from the light view's lists) are
// sorted in place; nodes go to `buf` (grey or RGB; the baselines are grey).
template <int N>
CDSM_HD inline void build_texel(const SceneView& s, const LightPassParams& p, Span<Fragment> frags, int tx, int ty,
                                NodeBufferN<N>& buf, WalkStats& st) {
  if constexpr (N == 1) {
    if (p.method != ShadowMethod::Dsm) {  // the benchmark's baselines, same rays and walker
      Vec3 d = pixel_ray(p.view, tx, ty);
      float t = p.view.far / fmaxf(dot(d, p.view.forward), 1e-6f);
      build_baseline_texel(s, p.method, p.method_param, p.layer_thickness, p.inside, frags,
                           pixel_origin(p.view, tx, ty), d, t, buf, st);
      return;
    }
  }
  walk_texel<DsmVisitorOf<NodeBufferN<N>>>(s, p, frags, tx, ty, buf, st);
}

// Texel (tx, ty) of a deep shadow map (p.method == ShadowMethod::Dsm) into a
// FixedSlotSink: with no slots it only counts the nodes (the wedge reads
// back just the last two), with `count` slots it writes them in place.
// Until a NodeBuffer of K slots would overflow (node_limit(K) nodes), the
// nodes are exactly the ones build_texel() puts there (the two-pass build,
// shadows/exec/light_pass.h). Scalar or RGB nodes.
template <class Node>
CDSM_HD inline void build_texel_into(const SceneView& s, const LightPassParams& p, Span<Fragment> frags, int tx, int ty,
                                     FixedSlotSink<Node>& sink, WalkStats& st) {
  walk_texel_into<DsmVisitorOf<FixedSlotSink<Node>>>(s, p, frags, tx, ty, sink, st);
}

}  // namespace cdsm
