// The baselines the benchmark compares deep shadow maps with (issue 6):
// built from the same light rays and the same segment walker, stored as
// node lists in the same layout, so the same lookup (hd/dsm.h) reads them.
//
//   ShadowMap      a conventional shadow map: a step 0 -> 1 at the first
//                  depth where the ray turns opaque — a surface whose own
//                  opacity reaches the threshold (alpha test), or the point
//                  where the media's accumulated opacity crosses it.
//   OpacitySlices  opacity shadow maps (Kim & Neumann 2001): alpha exactly
//                  at N + 1 uniform slice boundaries over the ray's extent
//                  through the casters, linear in between.
//   FixedNodes     an AVSM-style map (Salvi et al. 2010): at most N nodes,
//                  built by streaming the exact samples and, when over N,
//                  dropping the interior node whose removal changes the area
//                  under alpha(z) least.
//   DeepOpacity    deep opacity maps (Yuksel & Keyser 2008): N layers of a
//                  fixed thickness from the texel's first caster depth,
//                  alpha exactly at each layer's far end, linear in
//                  between, 0 at the first depth; what lies beyond the last
//                  layer is lost.
//   FourierOpacity Fourier opacity maps (Jansen & Bavoil 2010): N real
//                  coefficients of the absorption density over the texel's
//                  depth range (hd/series.h).
//   Moments        moment-based transmittance (Peters & Klein 2015,
//                  Münstermann et al. 2018): b_0 and 4 or 8 power moments
//                  of the absorbance over the texel's depth range, the
//                  biased bound of hd/series.h.
// The last two keep a few numbers per texel, not a function: the lookup
// path is the same for every method, so their reconstruction is tabulated
// into nodes at build time (series_samples(N) even depths over the range, made
// nondecreasing and compressed within kTabulationError) — the map reads
// what the method's own lookup would compute there, within that error and
// the interpolation between samples. Their memory is what an engine would
// store (cdsm/method_params.h stored_components), not these nodes.
//
// The baselines are grey: they store one alpha per node, a coloured
// caster entering by its channel mean (grey casters: their value exactly).
// The benchmark reports them as grey-only (docs/bench/).
#pragma once

#include "cdsm/method_params.h"
#include "hd/compress.h"
#include "hd/segments.h"
#include "hd/series.h"
#include "hd/view.h"

namespace cdsm {

// Defaults when ShadowSettings::method_param is 0 (cdsm/tags.h kMethodParams).
inline constexpr float kDefaultOpacityThreshold = kMethodParams[uint32_t(ShadowMethod::ShadowMap)].fallback;
inline constexpr int kDefaultOpacitySlices = int(kMethodParams[uint32_t(ShadowMethod::OpacitySlices)].fallback);
inline constexpr int kDefaultFixedNodes = int(kMethodParams[uint32_t(ShadowMethod::FixedNodes)].fallback);
inline constexpr int kDefaultLayers = int(kMethodParams[uint32_t(ShadowMethod::DeepOpacity)].fallback);
inline constexpr int kDefaultCoefficients = int(kMethodParams[uint32_t(ShadowMethod::FourierOpacity)].fallback);
inline constexpr int kDefaultMoments = int(kMethodParams[uint32_t(ShadowMethod::Moments)].fallback);

// The count a counted baseline uses: `param`, or its default for 0. (The
// defaults as compile-time constants: device code reads no host table.)
CDSM_HD inline int baseline_count(ShadowMethod method, float param) {
  if (param >= 1.0f) return int(param);
  switch (method) {
    case ShadowMethod::OpacitySlices: return kDefaultOpacitySlices;
    case ShadowMethod::FixedNodes: return kDefaultFixedNodes;
    case ShadowMethod::DeepOpacity: return kDefaultLayers;
    case ShadowMethod::FourierOpacity: return kDefaultCoefficients;
    case ShadowMethod::Moments: return kDefaultMoments;
    default: return 0;
  }
}

// The tabulation of the series methods: samples over the texel's range for
// N numbers, and the compression of the samples into nodes.
CDSM_HD constexpr int series_samples(int n) { return 8 * n + 16; }
inline constexpr float kTabulationError = 1e-3f;

// Fourier opacity maps: the range is widened by this share of its length at
// each end (the series is periodic: absorbance at one end rings at the other).
inline constexpr float kFourierMargin = 0.05f;

// Chord error of the pieces a constant medium is cut into for the baselines
// (hd/light_pass.h sample_constant_medium: spacing grows with saturation).
inline constexpr float kBaselineChordError = 1e-4f;

// Walks the exact opacity along a light ray and reports it to a builder as
// surfaces and exponential pieces:
//   bool surface(float z, float opacity, float before, float after, SurfaceTag tag)
//   bool piece(float z0, float z1, float a0, float a1, float sigma)
//        alpha(z) = 1 - (1 - a0) exp(-sigma (z - z0)) on [z0, z1], a1 at z1
//        (sigma = 0: an empty stretch, alpha constant)
// Both return false once the builder needs no more of the ray; the walk
// also ends when the ray saturates.
template <class Builder>
struct ExactAlphaVisitor {
  const SceneView& s;
  Vec3 org, dir;
  Builder& b;
  float alpha = 0.0f;

  CDSM_HD ExactAlphaVisitor(const SceneView& sv, Vec3 o, Vec3 d, Builder& builder)
      : s(sv), org(o), dir(d), b(builder) {}

  CDSM_HD bool saturated() const { return alpha >= kSaturatedAlpha; }

  CDSM_HD bool surface(float t, uint32_t tri, bool front) {
    const uint32_t o = s.tri_object[tri];
    float op = grey_of(s.objects[o].absorb);  // baselines are grey: channel mean
    if (op <= 0.0f) return true;
    float before = alpha;
    alpha = alpha + op * (1.0f - alpha);
    const SurfaceTag tag = surface_tag(o, surface_rank((s.objects[o].flags & kObjClosed) != 0u, front));
    return b.surface(t, op, before, alpha, tag) && !saturated();
  }

  CDSM_HD bool piece(float z0, float z1, float sigma) {
    float a0 = alpha;
    alpha = 1.0f - (1.0f - a0) * expf_hd(-sigma * (z1 - z0));
    return b.piece(z0, z1, a0, alpha, sigma) && !saturated();
  }

  CDSM_HD bool segment(float t0, float t1, const SegmentMedia& m) {
    if (m.volume_count == 0) {
      bool go_on = true;
      float za = t0;
      const float sigma = grey_of(m.sigma);
      sample_constant_medium(t0, t1, 1.0f - alpha, sigma, kBaselineChordError, [&](float zb, float) {
        if (go_on) go_on = piece(za, zb, sigma);
        za = zb;
      });
      return go_on;
    }
    bool go_on = true;
    march_segment(
        s, m, org, dir, t0, t1,
        [&](const MarchSample& ms) { return go_on = piece(ms.t0, ms.t1, grey_of(ms.extinction)); },
        [&](float ta, float tb) {
          if (go_on) go_on = piece(ta, tb, 0.0f);
        });
    return go_on;
  }
};

// A conventional shadow map: one step to full opacity where the ray turns
// opaque, no nodes if it never does.
struct ShadowMapBuilder {
  NodeBuffer& buf;
  float threshold;       // opacity that counts as opaque, (0, 1]
  float media_T = 1.0f;  // transmittance of the media crossed so far

  // tag: the surface that turned the ray opaque (kNoSurface: media).
  CDSM_HD void opaque_at(float z, SurfaceTag tag) {
    buf.emit(z, 0.0f);
    buf.emit(z, 1.0f, tag);
  }
  CDSM_HD bool surface(float z, float opacity, float, float, SurfaceTag tag) {
    if (opacity < threshold) return true;
    opaque_at(z, tag);
    return false;
  }
  CDSM_HD bool piece(float z0, float z1, float, float, float sigma) {
    if (sigma <= 0.0f) return true;
    float T1 = media_T * expf_hd(-sigma * (z1 - z0));
    if (1.0f - T1 < threshold) {
      media_T = T1;
      return true;
    }
    // Where the media's opacity reaches the threshold: T(z) = 1 - threshold.
    float zc = z0 + logf_hd(media_T / fmaxf(1.0f - threshold, 1e-30f)) / sigma;
    opaque_at(clampf(zc, z0, z1), kNoSurface);
    return false;
  }
  CDSM_HD void finish() {}
};

// Opacity shadow maps: alpha at `slices` + 1 uniform boundaries over
// [z_lo, z_hi], right-continuous at surfaces; the lookup interpolates.
struct OpacitySliceBuilder {
  NodeBuffer& buf;
  int slices;
  float z_lo, z_hi;
  int next = 0;        // next boundary to emit
  float alpha = 0.0f;  // alpha after everything reported so far

  CDSM_HD float boundary(int k) const { return k >= slices ? z_hi : z_lo + (z_hi - z_lo) * (float(k) / float(slices)); }
  // Emits the boundaries before z (strictly), alpha constant there.
  CDSM_HD void flat_until(float z) {
    while (next <= slices && boundary(next) < z) buf.emit(boundary(next++), alpha);
  }
  // Both end the walk once every boundary is out.
  CDSM_HD bool surface(float z, float, float, float after, SurfaceTag) {
    flat_until(z);
    alpha = after;
    return next <= slices;
  }
  CDSM_HD bool piece(float z0, float z1, float a0, float a1, float sigma) {
    flat_until(z0);
    while (next <= slices && boundary(next) < z1) {
      float z = boundary(next++);
      buf.emit(z, 1.0f - (1.0f - a0) * expf_hd(-sigma * (z - z0)));
    }
    alpha = a1;
    return next <= slices;
  }
  CDSM_HD void finish() {
    while (next <= slices) buf.emit(boundary(next++), alpha);
  }
};

// AVSM-style: the exact samples stream into at most `max_nodes` nodes;
// when one too many, the interior node whose removal changes the area
// under alpha(z) least (the triangle it spans with its neighbours) goes.
// First and last nodes stay, so the function keeps its extent and its
// final opacity; removal keeps alpha monotone.
struct FixedNodeBuilder {
  NodeBuffer& buf;
  int max_nodes;  // >= 2

  CDSM_HD static float removal_area(DsmNode a, DsmNode b, DsmNode c) {
    return 0.5f * fabsf((b.z - a.z) * (c.alpha - a.alpha) - (b.alpha - a.alpha) * (c.z - a.z));
  }
  CDSM_HD void add(float z, float a, SurfaceTag tag = kNoSurface) {
    if (buf.count > 0) {
      DsmNode last = buf.nodes[buf.count - 1];
      if (last.z == z && last.alpha == a) return;
    }
    if (buf.tags) buf.tags[buf.count] = tag;
    buf.nodes[buf.count++] = DsmNode{z, a};
    if (buf.count <= max_nodes) return;
    int best = 1;
    float best_area = 3.0e38f;
    for (int i = 1; i + 1 < buf.count; ++i) {
      float area = removal_area(buf.nodes[i - 1], buf.nodes[i], buf.nodes[i + 1]);
      if (area < best_area) {
        best_area = area;
        best = i;
      }
    }
    for (int i = best; i + 1 < buf.count; ++i) buf.nodes[i] = buf.nodes[i + 1];
    if (buf.tags)
      for (int i = best; i + 1 < buf.count; ++i) buf.tags[i] = buf.tags[i + 1];
    --buf.count;
  }
  CDSM_HD bool surface(float z, float, float before, float after, SurfaceTag tag) {
    add(z, before);
    add(z, after, tag);
    return true;
  }
  CDSM_HD bool piece(float z0, float z1, float a0, float a1, float) {
    add(z0, a0);
    add(z1, a1);
    return true;
  }
  CDSM_HD void finish() {}
};

// Fourier coefficients or power moments of the ray's absorbance (hd/series.h)
// over [lo, hi] mapped to unit depth u = (z - lo) * scale + offset.
template <class Series>
struct SeriesBuilder {
  Series& series;
  float lo, hi;
  double scale, offset;

  CDSM_HD double unit(float z) const { return double(z - lo) * scale + offset; }
  CDSM_HD bool surface(float z, float opacity, float, float, SurfaceTag) {
    series.add_surface(unit(z), surface_absorbance(opacity));
    return true;
  }
  CDSM_HD bool piece(float z0, float z1, float, float, float sigma) {
    if (z0 >= hi) return false;  // past the last caster
    if (sigma > 0.0f) series.add_medium(unit(z0), unit(fminf(z1, hi)), double(sigma) / scale);
    return true;
  }
  CDSM_HD void finish() {}
};

// Nodes of alpha(z) = 1 - exp(-A(z)) from the absorbance in front of unit
// depth u, A(u) = absorbance(u), sampled at `samples` + 1 even depths over
// [lo, hi] (u from u0 to u1): clamped into [0, 1 - exp(-total)] (the
// reconstructions may overshoot the total they know exactly), made
// nondecreasing and compressed within kTabulationError; at hi, behind
// everything, the total.
template <class Absorbance>
CDSM_HD inline void tabulate_absorbance(NodeBuffer& buf, float lo, float hi, double u0, double u1, int samples,
                                        double total, const Absorbance& absorbance) {
  const float a_total = clampf(float(1.0 - exp(-total)), 0.0f, 1.0f);
  Wedge<NodeBuffer> w(kTabulationError);
  w.cap = a_total;  // no line above the total: the last node lands on it
  float run = 0.0f;
  for (int i = 0; i <= samples; ++i) {
    const double f = double(i) / double(samples);
    const float z = i == samples ? hi : lo + (hi - lo) * float(f);
    const float a = clampf(float(1.0 - exp(-absorbance(u0 + (u1 - u0) * f))), 0.0f, a_total);
    run = fmaxf(run, a);
    w.push(buf, z, run);
  }
  w.push(buf, hi, a_total);
  w.finish(buf);
}

// The ray's extent through the casters, [lo, hi] within [0, t_end]: from
// the light (when it is inside one) or the first fragment, to the last
// fragment. False when the ray meets no caster.
CDSM_HD inline bool caster_extent(Span<const uint32_t> inside, Span<Fragment> frags, float t_end, float& lo,
                                  float& hi) {
  lo = inside.empty() ? 3.0e38f : 0.0f;
  hi = -3.0e38f;
  for (uint64_t i = 0; i < frags.size(); ++i) {
    lo = fminf(lo, frags[i].depth);
    hi = fmaxf(hi, frags[i].depth);
  }
  if (!(hi >= lo)) return false;
  lo = clampf(lo, 0.0f, t_end);
  hi = clampf(hi, lo, t_end);
  return true;
}

// Nodes a baseline texel can hold at once: a first walk into this many
// never needs a second (shadows/exec/light_pass.h).
CDSM_HD inline int baseline_node_bound(ShadowMethod method, float param) {
  const int n = baseline_count(method, param);
  switch (method) {
    case ShadowMethod::OpacitySlices: return n + 1;
    case ShadowMethod::FixedNodes: return n + 1;
    case ShadowMethod::DeepOpacity: return n + 1;
    case ShadowMethod::FourierOpacity:
    case ShadowMethod::Moments: return series_samples(n) + 2;  // a step at most besides the samples
    default: return 2;
  }
}

// (Out of line on a GPU: the baseline walk and the second walk share it.)
// Builds one texel of a baseline map along unit ray `dir` from `org`,
// walking [0, t_end]. `param` is ShadowSettings::method_param (0: default);
// `layer_thickness` the deep opacity maps' layer thickness along the ray
// (0: the texel's own caster extent / N).
CDSM_HD CDSM_NOINLINE inline void build_baseline_texel(const SceneView& s, ShadowMethod method, float param,
                                                       float layer_thickness, Span<const uint32_t> inside,
                                                       Span<Fragment> frags, Vec3 org, Vec3 dir, float t_end,
                                                       NodeBuffer& buf, WalkStats& st) {
  if (method == ShadowMethod::ShadowMap) {
    float thr = param > 0.0f ? fminf(param, 1.0f) : kDefaultOpacityThreshold;
    ShadowMapBuilder b{buf, thr};
    ExactAlphaVisitor<ShadowMapBuilder> vis(s, org, dir, b);
    walk_ray(s, frags, inside, 0.0f, t_end, vis, st);
    b.finish();
  } else if (method == ShadowMethod::OpacitySlices) {
    int n = baseline_count(method, param);
    n = n > buf.capacity - 1 ? buf.capacity - 1 : n;
    // The slices span the ray's extent through the casters.
    float lo, hi;
    if (!caster_extent(inside, frags, t_end, lo, hi)) return;
    OpacitySliceBuilder b{buf, n, lo, hi};
    ExactAlphaVisitor<OpacitySliceBuilder> vis(s, org, dir, b);
    walk_ray(s, frags, inside, 0.0f, t_end, vis, st);
    b.finish();
  } else if (method == ShadowMethod::FixedNodes) {
    int n = baseline_count(method, param);
    n = n > buf.capacity - 1 ? buf.capacity - 1 : n;
    FixedNodeBuilder b{buf, n};
    ExactAlphaVisitor<FixedNodeBuilder> vis(s, org, dir, b);
    walk_ray(s, frags, inside, 0.0f, t_end, vis, st);
    b.finish();
  } else if (method == ShadowMethod::DeepOpacity) {
    int n = baseline_count(method, param);
    n = n > buf.capacity - 2 ? buf.capacity - 2 : n;
    float lo, hi;
    if (!caster_extent(inside, frags, t_end, lo, hi)) return;
    float d = layer_thickness > 0.0f ? layer_thickness : (hi - lo) / float(n);
    if (!(d > 0.0f)) d = fmaxf(1e-4f * hi, 1e-6f);  // a single surface
    // Layer boundaries from the first depth on: alpha 0 there (the first
    // layer's front), the first layer ends a thickness behind it.
    buf.emit(lo, 0.0f);
    OpacitySliceBuilder b{buf, n, lo, lo + d * float(n)};
    b.next = 1;
    ExactAlphaVisitor<OpacitySliceBuilder> vis(s, org, dir, b);
    walk_ray(s, frags, inside, 0.0f, t_end, vis, st);
    b.finish();
  } else if (method == ShadowMethod::FourierOpacity || method == ShadowMethod::Moments) {
    const int n = baseline_count(method, param);
    float lo, hi;
    if (!caster_extent(inside, frags, t_end, lo, hi)) return;
    if (method == ShadowMethod::FourierOpacity) {
      const float margin = kFourierMargin * (hi - lo) + fmaxf(1e-4f * hi, 1e-6f);
      lo = fmaxf(lo - margin, 0.0f);
      hi = hi + margin;
    } else if (!(hi > lo)) {
      hi = lo + fmaxf(1e-4f * hi, 1e-6f);  // a single surface
    }
    // The range as stored (floats), and the coefficients.
    if (method == ShadowMethod::FourierOpacity) {
      FourierSeries f(n);
      SeriesBuilder<FourierSeries> b{f, lo, hi, 1.0 / double(hi - lo), 0.0};
      ExactAlphaVisitor<SeriesBuilder<FourierSeries>> vis(s, org, dir, b);
      walk_ray(s, frags, inside, 0.0f, t_end, vis, st);
      f.store();
      if (!(f.c[0] > 0.0)) return;  // nothing absorbs
      tabulate_absorbance(buf, lo, hi, 0.0, 1.0, series_samples(n), 0.5 * f.c[0],
                          [&](double u) { return f.optical_depth(u); });
    } else {
      PowerMoments m(n);
      SeriesBuilder<PowerMoments> b{m, lo, hi, 2.0 / double(hi - lo), -1.0};
      ExactAlphaVisitor<SeriesBuilder<PowerMoments>> vis(s, org, dir, b);
      walk_ray(s, frags, inside, 0.0f, t_end, vis, st);
      m.store();
      if (!(m.b[0] > 0.0)) return;
      const MomentBias bias = moment_bias(n);
      tabulate_absorbance(buf, lo, hi, -1.0, 1.0, series_samples(n), m.b[0], [&](double u) {
        double lower, at;
        m.bound(u, bias, lower, at);
        return m.b[0] * (lower + kMomentOverestimation * at);
      });
    }
  }
}

}  // namespace cdsm
