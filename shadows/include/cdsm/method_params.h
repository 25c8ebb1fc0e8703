// The parameter of each shadow method (ShadowSettings::method_param).
#pragma once

#include <cstdint>

#include "cdsm/tags.h"

namespace cdsm {

// ShadowSettings::method_param of each method, written once: what it is,
// its range and its default (a value of 0 means the default). The scene
// validator, the benchmark's method list (osmN, avsmN, sm:T) and the
// baselines (hd/baselines.h) read it. Dsm has none (what = nullptr).
struct MethodParam {
  const char* what;  // "the slice count"
  float lo, hi;      // accepted values besides 0 (inclusive; sm's threshold excludes 0 itself)
  float fallback;    // used for 0
  bool integer;
};
inline constexpr MethodParam kMethodParams[] = {
    {nullptr, 0.0f, 0.0f, 0.0f, false},                  // Dsm
    {"the opacity threshold", 0.0f, 1.0f, 0.5f, false},  // ShadowMap: (0, 1]
    {"the slice count", 1.0f, 512.0f, 32.0f, true},      // OpacitySlices
    {"the node count", 2.0f, 512.0f, 8.0f, true},        // FixedNodes
    {"the layer count", 1.0f, 64.0f, 8.0f, true},        // DeepOpacity
    {"the coefficient count", 3.0f, 32.0f, 8.0f, true},  // FourierOpacity
    {"the power moment count", 4.0f, 8.0f, 4.0f, true},  // Moments: 4 or 8 (the scene validator)
};
constexpr const MethodParam& method_param(ShadowMethod m) { return kMethodParams[uint32_t(m)]; }

// A rule the range cannot say: moments come in the counts whose bias is
// published (hd/series.h moment_bias). The scene validator and the bench's
// method list both ask here.
constexpr bool moment_count_allowed(float param) { return param == 0.0f || param == 4.0f || param == 8.0f; }

// The parameter in use: `param`, or the method's default for 0.
constexpr float method_param_or_default(ShadowMethod m, float param) {
  return param != 0.0f ? param : method_param(m).fallback;
}

// Numbers per texel an engine stores for the methods whose texels hold a
// fixed set of them, each a 32-bit float (the moments' bias assumes that
// precision): deep opacity maps N layers and the first caster depth,
// Fourier opacity maps N coefficients and moments b_0 and N moments, both
// with the texel's depth range (2). 0 for the node lists (dsm, shadow_map,
// opacity_slices, fixed_nodes): their memory is the nodes they keep.
constexpr int stored_components(ShadowMethod m, float param) {
  const int n = int(method_param_or_default(m, param));
  switch (m) {
    case ShadowMethod::DeepOpacity: return n + 1;
    case ShadowMethod::FourierOpacity: return n + 2;
    case ShadowMethod::Moments: return n + 3;
    default: return 0;
  }
}
inline constexpr int kBytesPerComponent = 4;

}  // namespace cdsm
