// Light pass (DESIGN.md §2.4): one texel's visibility function — walk the
// light ray's segments, accumulate alpha, compress on the fly.
#pragma once

#include "hd/baselines.h"
#include "hd/compress.h"
#include "hd/compress_rgb.h"
#include "hd/dsm_fixed.h"
#include "hd/segments.h"
#include "hd/view.h"

namespace cdsm {

struct LightPassParams {
  PinholeView view;              // the map's view from the light
  float epsilon;                 // compression bound
  Span<const uint32_t> inside;   // caster objects containing the light
  ShadowMethod method = ShadowMethod::Dsm;  // DSM, or a baseline (hd/baselines.h)
  float method_param = 0.0f;     // the baseline's parameter (0: its default)
  bool rgb = false;              // RGB nodes (a coloured caster among the map's members; DSM only)
};

// Sink: where the wedge's nodes go — a NodeBuffer (the cpu backend), or a
// FixedSlotSink (hd/dsm_fixed.h) that counts them or writes them straight
// into a layout (the two-pass build of shadows/exec/).
template <class Sink>
struct DsmVisitorOf {
  const SceneView& s;
  Vec3 org, dir;
  float eps;
  Wedge<Sink> c;
  Sink& buf;
  float alpha = 0.0f;

  CDSM_HD DsmVisitorOf(const SceneView& sv, Vec3 o, Vec3 d, float e, Sink& b)
      : s(sv), org(o), dir(d), eps(e), c(e), buf(b) {}

  CDSM_HD bool saturated() const { return alpha >= kSaturatedAlpha; }

  CDSM_HD bool surface(float t, uint32_t tri, bool front) {
    // Grey casters: every channel equal, the value itself (a coloured one in
    // a scalar map: its channel mean, ShadowSettings::rgb_maps).
    const uint32_t o = s.tri_object[tri];
    float op = grey_of(s.objects[o].absorb);
    if (op <= 0.0f) return true;
    c.push(buf, t, alpha);
    alpha = alpha + op * (1.0f - alpha);
    c.step(buf, t, alpha, surface_tag(o, surface_rank((s.objects[o].flags & kObjClosed) != 0u, front)));
    return !saturated();
  }

  CDSM_HD bool segment(float t0, float t1, const SegmentMedia& m) {
    c.push(buf, t0, alpha);
    if (m.volume_count == 0) {
      sample_constant_medium(t0, t1, 1.0f - alpha, grey_of(m.sigma), kConstantChordError, [&](float z, float a) {
        alpha = a;
        c.push(buf, z, alpha);
      });
      return !saturated();
    }
    return march_segment(
        s, m, org, dir, t0, t1,
        [&](const MarchSample& ms) {
          float a = 1.0f - expf_hd(-grey_of(ms.extinction) * (ms.t1 - ms.t0));
          alpha = alpha + a * (1.0f - alpha);
          c.push(buf, ms.t1, alpha);
          return !saturated();
        },
        [&](float ta, float tb) {
          c.push(buf, ta, alpha);
          c.push(buf, tb, alpha);
        },
        [&] { return MarchTolerance{1.0f - alpha}; });
  }
};

// The same walk with alpha per colour channel: one RGB wedge (shared node
// depths, hd/compress_rgb.h), each channel within eps. A ray ends early
// only when every channel is saturated.
template <class Sink>
struct DsmVisitorRgbOf {
  const SceneView& s;
  Vec3 org, dir;
  float eps;
  WedgeRgb<Sink> c;
  Sink& buf;
  Vec3 alpha{0, 0, 0};

  CDSM_HD DsmVisitorRgbOf(const SceneView& sv, Vec3 o, Vec3 d, float e, Sink& b)
      : s(sv), org(o), dir(d), eps(e), c(e), buf(b) {}

  CDSM_HD bool saturated() const { return min_channel(alpha) >= kSaturatedAlpha; }
  // alpha_k + a_k (1 - alpha_k): one more layer, per channel.
  CDSM_HD void add_layer(Vec3 a) { alpha = alpha + a * one_minus(alpha); }

  CDSM_HD bool surface(float t, uint32_t tri, bool front) {
    const uint32_t obj = s.tri_object[tri];
    const ObjectData& o = s.objects[obj];
    if (passes_all(o)) return true;
    c.push(buf, t, alpha);
    add_layer(o.absorb);
    c.step(buf, t, alpha, surface_tag(obj, surface_rank((o.flags & kObjClosed) != 0u, front)));
    return !saturated();
  }

  CDSM_HD bool segment(float t0, float t1, const SegmentMedia& m) {
    c.push(buf, t0, alpha);
    if (m.volume_count == 0) {
      sample_constant_medium_rgb(t0, t1, one_minus(alpha), m.sigma, kConstantChordError, [&](float z, Vec3 a) {
        alpha = a;
        c.push(buf, z, alpha);
      });
      return !saturated();
    }
    return march_segment(
        s, m, org, dir, t0, t1,
        [&](const MarchSample& ms) {
          add_layer(sample_alpha(ms));
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
using DsmVisitorRgb = DsmVisitorRgbOf<RgbNodeBuffer>;

// Walks texel (tx, ty)'s light ray with visitor kind V (scalar or RGB),
// compressing into `sink`; fragments sorted in place.
template <class Visitor, class Sink>
CDSM_HD inline void walk_texel_into(const SceneView& s, const LightPassParams& p, Span<Fragment> frags, int tx,
                                    int ty, Sink& sink, WalkStats& st) {
  const Vec3 dir = pixel_ray(p.view, tx, ty);
  Visitor vis(s, p.view.eye, dir, p.epsilon, sink);
  const float t_end = p.view.far / fmaxf(dot(dir, p.view.forward), 1e-6f);
  walk_ray(s, frags, p.inside, 0.0f, t_end, vis, st);
  vis.c.finish(sink);
}

// Out of line on a GPU: the first and the second walk of a texel share one
// compiled copy.
template <class Visitor, class Buffer>
CDSM_HD CDSM_NOINLINE inline void walk_texel(const SceneView& s, const LightPassParams& p, Span<Fragment> frags, int tx, int ty,
                               Buffer& buf, WalkStats& st) {
  buf.eps = p.epsilon;
  walk_texel_into<Visitor>(s, p, frags, tx, ty, buf, st);
}

// Builds texel (tx, ty): its fragments (from the light view's lists) are
// sorted in place; nodes go to `buf`.
CDSM_HD inline void build_texel(const SceneView& s, const LightPassParams& p, Span<Fragment> frags,
                                int tx, int ty, NodeBuffer& buf, WalkStats& st) {
  if (p.method != ShadowMethod::Dsm) {  // the benchmark's baselines, same rays and walker
    Vec3 d = pixel_ray(p.view, tx, ty);
    float t = p.view.far / fmaxf(dot(d, p.view.forward), 1e-6f);
    build_baseline_texel(s, p.method, p.method_param, p.inside, frags, p.view.eye, d, t, buf, st);
    return;
  }
  walk_texel<DsmVisitor>(s, p, frags, tx, ty, buf, st);
}

// An RGB texel (p.rgb; deep shadow maps only).
CDSM_HD inline void build_texel(const SceneView& s, const LightPassParams& p, Span<Fragment> frags,
                                int tx, int ty, RgbNodeBuffer& buf, WalkStats& st) {
  walk_texel<DsmVisitorRgb>(s, p, frags, tx, ty, buf, st);
}

// Texel (tx, ty) of a deep shadow map (p.method == ShadowMethod::Dsm) into a
// FixedSlotSink: with no slots it only counts the nodes (the wedge reads
// back just the last two), with `count` slots it writes them in place.
// Until a NodeBuffer of K slots would overflow (node_limit(K) nodes), the
// nodes are exactly the ones build_texel() puts there (the two-pass build,
// shadows/exec/light_pass.h). Scalar or RGB nodes.
CDSM_HD inline void build_texel_into(const SceneView& s, const LightPassParams& p, Span<Fragment> frags, int tx,
                                     int ty, FixedSlotSink<DsmNode>& sink, WalkStats& st) {
  walk_texel_into<DsmVisitorOf<FixedSlotSink<DsmNode>>>(s, p, frags, tx, ty, sink, st);
}
CDSM_HD inline void build_texel_into(const SceneView& s, const LightPassParams& p, Span<Fragment> frags, int tx,
                                     int ty, FixedSlotSink<DsmNodeRgb>& sink, WalkStats& st) {
  walk_texel_into<DsmVisitorRgbOf<FixedSlotSink<DsmNodeRgb>>>(s, p, frags, tx, ty, sink, st);
}

}  // namespace cdsm
