// __global__ wrappers over every shadows/ entry point (DESIGN.md §5).
#pragma once

#include "hd/camera_pass.h"
#include "hd/light_pass.h"
#include "hd/bvh.h"

namespace cdsm::cuda {

// Fragment count pass of the ray caster: hits per pixel.
__global__ void count_fragments_kernel(SceneView scene, PinholeView view, ObjectMask mask,
                                       uint32_t* counts);
// Fill pass: writes each pixel's fragments at offsets[pixel].
__global__ void fill_fragments_kernel(SceneView scene, PinholeView view, ObjectMask mask,
                                      const uint32_t* offsets, Fragment* out);
// Light pass: one texel per thread into a per-thread node buffer of K nodes,
// node counts written to counts[texel].
__global__ void build_texels_kernel(SceneView scene, LightPassParams params, FragmentLists frags,
                                    DsmNode* scratch, int node_capacity, uint32_t* counts);
// Camera pass: one pixel per thread.
__global__ void shade_pixels_kernel(SceneView scene, ShadowView shadows, CameraPassParams params,
                                    FragmentLists frags, float* rgb);
// Lookups alone (tests: CPU/GPU parity of the lookup arithmetic).
__global__ void lookup_kernel(ShadowView shadows, const Vec3* points, int n, float* alpha);

}  // namespace cdsm::cuda
