// Sampling a constant medium (a pure absorber) for a compressor.
#pragma once

#include "hd/channels.h"
#include "hd/explog.h"

namespace cdsm {

// Sampling of a constant medium (extinction sigma) for a compressor (the
// light pass, the baselines): the
// chord of alpha(z) = 1 - T0 exp(-sigma (z - z0)) over a spacing h deviates
// from it by at most T h^2 sigma^2 / 8, T the transmittance at the chord's
// start. Spacing h = sqrt(8 e / T) / sigma keeps every chord within e, and
// grows as the medium saturates, so about 2 / sqrt(8 e) samples reach
// transmittance kConstantTail whatever sigma * length is (224 for e = 1e-5);
// sampling ends there. Chord and compression errors add: within eps + e.
inline constexpr float kConstantChordError = 1e-5f;
inline constexpr float kConstantTail = 1e-5f;     // transmittance where sampling ends (< 1 - kSaturatedAlpha)
inline constexpr int kMaxConstantSamples = 1024;  // bound against float luck; the spacing needs about 224

// The samples of a constant medium from t0 (transmittance T0 there) to t1,
// chord error `e`, in N channels (hd/channels.h: a float, or a Vec3 when the
// extinction differs between channels): calls emit(z, alpha) for each. The
// spacing is the smallest any channel still above the tail needs
// (sqrt(8 e / T_k) / sigma_k), so every channel's chord stays within e;
// sampling ends when every channel reaches kConstantTail.
template <class Alpha, class Emit>
CDSM_HD void sample_constant_medium(float t0, float t1, Alpha T0, Alpha sigma, float e, Emit&& emit) {
  constexpr int N = sizeof(Alpha) / sizeof(float);
  float z = t0;
  Alpha T = T0;
  for (int i = 0; i < kMaxConstantSamples && z < t1 && max_channel(T) > kConstantTail; ++i) {
    float h = 3.0e38f;
    for (int k = 0; k < N; ++k)
      if (channel(sigma, k) > 0.0f && channel(T, k) > kConstantTail)
        h = fminf(h, sqrtf(8.0f * e / channel(T, k)) / channel(sigma, k));
    float zn = fminf(z + h, t1);
    if (!(zn > z)) zn = fminf(nextafterf(z, 3.0e38f), t1);  // sigma beyond float resolution: a jump
    if (i + 1 == kMaxConstantSamples) zn = t1;
    const float d = zn - t0;
    for (int k = 0; k < N; ++k) set_channel(T, k, channel(T0, k) * expf_hd(-channel(sigma, k) * d));
    emit(zn, one_minus(T));
    z = zn;
  }
}

}  // namespace cdsm
