// Portability macros shared by every CDSM_HD header.
// Under nvcc, CDSM_HD marks functions callable on host and device; under a
// plain C++ compiler every macro here is empty, so these headers build
// anywhere.
#pragma once

#include <cassert>
#include <cstdint>

#if defined(__CUDACC__)
#define CDSM_HD __host__ __device__
#define CDSM_INLINE __forceinline__
#define CDSM_DEVICE_CODE 1
#else
#define CDSM_HD
#define CDSM_INLINE inline
#define CDSM_DEVICE_CODE 0
#endif

// A rarely taken path kept out of line (a buffer's overflow handling): one
// copy per program instead of one per call site. Under nvcc every caller
// would otherwise inline it, and ptxas's time grows faster than the size
// of the kernels it compiles.
#if defined(__CUDACC__)
#define CDSM_NOINLINE __noinline__
#elif defined(__GNUC__)
#define CDSM_NOINLINE __attribute__((noinline))
#else
#define CDSM_NOINLINE
#endif

// Invariant check usable inside CDSM_HD code: assert() on both sides.
#define CDSM_HD_ASSERT(cond) assert(cond)

// The body of a parallel_for (the executors): a lambda that captures by
// value and runs on CPU threads or in a CUDA launch (nvcc: --extended-lambda).
#define CDSM_LAMBDA(...) [=] CDSM_HD(__VA_ARGS__)

namespace cdsm {

// Hard limits of the bounded per-ray / per-texel state.
// Changing them changes stack usage of every kernel.
inline constexpr int kMaxEnclosing = 16;                // objects a ray tracks the interiors of at once (deeper
                                                        // constant media are summed: hd/segments.h EnclosingOverflow;
                                                        // a volume inside 16 volumes is left out, counted and warned)
inline constexpr int kMaxRayObjects = 32;               // objects bracket-matched per pass (more: further passes)
inline constexpr int kBvhStackSize = 64;                // BVH traversal stack depth
inline constexpr int kMaxTransferPoints = 16;           // transfer-function control points
inline constexpr int kMaxLights = 8;                    // lights per frame in one camera pass
inline constexpr int kMaxMapsPerLight = 8;              // DSMs (faces or clusters) per light
inline constexpr float kSaturatedAlpha = 1.0f - 1e-4f;  // a ray this opaque ends early
inline constexpr float kCompositeStop = 0.995f;         // camera rays stop at this opacity

}  // namespace cdsm
