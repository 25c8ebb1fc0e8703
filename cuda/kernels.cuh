// __global__ wrappers over every shadows/ entry point (DESIGN.md §5).
#pragma once

#include "hd/camera_pass.h"
#include "hd/dsm_chunked.h"
#include "hd/dsm_fixed.h"
#include "hd/light_pass.h"
#include "hd/cast.h"

namespace cdsm::cuda {

// Fragment count pass of the ray caster (hd/cast.h): fragments per pixel.
// any_media: mask_has_media(scene, mask).
__global__ void count_fragments_kernel(SceneView scene, PinholeView view, ObjectMask mask, bool any_media,
                                       uint32_t* counts);
// Fill pass: writes each pixel's fragments at offsets[pixel].
__global__ void fill_fragments_kernel(SceneView scene, PinholeView view, ObjectMask mask, bool any_media,
                                      const uint32_t* offsets, Fragment* out);
// Light pass: one texel per thread into a per-thread node buffer of K nodes,
// node counts written to counts[texel].
__global__ void build_texels_kernel(SceneView scene, LightPassParams params, FragmentLists frags,
                                    DsmNode* scratch, int node_capacity, uint32_t* counts);
// Fixed layout (hd/dsm_fixed.h): one texel per thread writes its nodes from
// the node buffers (K per texel, counts[texel] of them) into its L slots,
// re-compressed when there are more; stored[texel] and extra_error[texel]
// receive the node count and the error bound added.
__global__ void write_fixed_kernel(int width, int height, const DsmNode* scratch, int node_capacity,
                                   const uint32_t* counts, float eps, DsmNode* slots, int layers,
                                   uint32_t* stored, float* extra_error);
// Chunked layout (hd/dsm_chunked.h): one 8x8 tile per thread writes its
// texels' nodes into the tile's chunks, reserved from pool slot
// tile_first_slot[tile]; headers[texel] receive the list heads.
__global__ void write_chunked_kernel(int width, int height, const DsmNode* scratch, int node_capacity,
                                     const uint32_t* counts, const uint32_t* tile_first_slot,
                                     uint32_t chunk_nodes, ChunkNode* pool, TexelRange* headers);
// Node lists read back from any layout, `cap` per texel (tests: parity).
__global__ void read_texels_kernel(DsmStorage storage, DsmMap map, DsmNode* out, uint32_t cap,
                                   uint32_t* counts);
// Camera pass: one pixel per thread.
__global__ void shade_pixels_kernel(SceneView scene, ShadowView shadows, CameraPassParams params,
                                    FragmentLists frags, float* rgb);
// Lookups alone (tests: CPU/GPU parity of the lookup arithmetic).
__global__ void lookup_kernel(ShadowView shadows, const Vec3* points, int n, float* alpha);

}  // namespace cdsm::cuda
