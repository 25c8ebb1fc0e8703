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
};
constexpr const MethodParam& method_param(ShadowMethod m) { return kMethodParams[uint32_t(m)]; }

}  // namespace cdsm
