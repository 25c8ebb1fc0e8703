// Marching the volumes of a segment (DESIGN.md §2.3): each volume with its
// own step where it can hold data, empty space skipped by the transfer
// function's output (macro-cells), and the light pass's tolerances that
// bound a step where the extinction is dense or has edges.
#pragma once

#include "hd/channels.h"
#include "hd/enclosing.h"
#include "hd/explog.h"
#include "hd/volume.h"

namespace cdsm {

// The shortest march step a segment ending at depth t1 can take and still
// advance in float: 4 ulps of |t1| (an ulp is at most |t| 2^-23). Marching a
// volume far from the eye (or light) with a finer step would never advance.
CDSM_HD CDSM_INLINE float min_march_step(float t0, float t1) {
  return fmaxf(fmaxf(fabsf(t0), fabsf(t1)) * 4.77e-7f, 1e-30f);
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

}  // namespace cdsm
