#include "kernels.cuh"

namespace cdsm::cuda {

__global__ void count_fragments_kernel(SceneView scene, PinholeView view, ObjectMask mask, bool any_media,
                                       uint32_t* counts) {
  int px = blockIdx.x * blockDim.x + threadIdx.x, py = blockIdx.y * blockDim.y + threadIdx.y;
  if (px >= view.width || py >= view.height) return;
  uint32_t n = 0;
  cast_pixel(scene, view, mask, any_media, px, py, [&](Fragment) { ++n; });
  counts[size_t(py) * view.width + px] = n;
}

__global__ void fill_fragments_kernel(SceneView scene, PinholeView view, ObjectMask mask, bool any_media,
                                      const uint32_t* offsets, Fragment* out) {
  int px = blockIdx.x * blockDim.x + threadIdx.x, py = blockIdx.y * blockDim.y + threadIdx.y;
  if (px >= view.width || py >= view.height) return;
  uint32_t at = offsets[size_t(py) * view.width + px];
  cast_pixel(scene, view, mask, any_media, px, py, [&](Fragment f) { out[at++] = f; });
}

__global__ void build_texels_kernel(SceneView scene, LightPassParams params, FragmentLists frags,
                                    DsmNode* scratch, int node_capacity, uint32_t* counts) {
  int tx = blockIdx.x * blockDim.x + threadIdx.x, ty = blockIdx.y * blockDim.y + threadIdx.y;
  if (tx >= params.view.width || ty >= params.view.height) return;
  size_t texel = size_t(ty) * params.view.width + tx;
  NodeBuffer buf{scratch + texel * size_t(node_capacity), node_capacity};
  WalkStats st;
  build_texel(scene, params, frags.pixel(tx, ty), tx, ty, buf, st);
  counts[texel] = uint32_t(buf.count);
}

__global__ void write_fixed_kernel(int width, int height, const DsmNode* scratch, int node_capacity,
                                   const uint32_t* counts, float eps, DsmNode* slots, int layers,
                                   uint32_t* stored, float* extra_error) {
  int tx = blockIdx.x * blockDim.x + threadIdx.x, ty = blockIdx.y * blockDim.y + threadIdx.y;
  if (tx >= width || ty >= height) return;
  size_t texel = size_t(ty) * width + tx;
  Span<const DsmNode> nodes{scratch + texel * size_t(node_capacity), counts[texel]};
  FixedFit fit = write_fixed_texel(nodes, eps, slots + texel * size_t(layers), layers);
  stored[texel] = uint32_t(fit.count);
  extra_error[texel] = fit.extra_error;
}

__global__ void write_chunked_kernel(int width, int height, const DsmNode* scratch, int node_capacity,
                                     const uint32_t* counts, const uint32_t* tile_first_slot,
                                     uint32_t chunk_nodes, ChunkNode* pool, TexelRange* headers) {
  constexpr int kTile = 8;
  int tiles_x = (width + kTile - 1) / kTile, tiles_y = (height + kTile - 1) / kTile;
  int tile = blockIdx.x * blockDim.x + threadIdx.x;
  if (tile >= tiles_x * tiles_y) return;
  int x0 = (tile % tiles_x) * kTile, y0 = (tile / tiles_x) * kTile;
  uint32_t tile_counts[kChunkTileTexels];
  size_t texel[kChunkTileTexels];
  TexelRange heads[kChunkTileTexels];
  for (int k = 0; k < kChunkTileTexels; ++k) {
    int tx = x0 + k % kTile, ty = y0 + k / kTile;
    bool in = tx < width && ty < height;
    texel[k] = in ? size_t(ty) * width + tx : 0;
    tile_counts[k] = in ? counts[texel[k]] : 0u;
  }
  write_chunked_tile(
      tile_counts, kChunkTileTexels, [&](int k) { return scratch + texel[k] * size_t(node_capacity); },
      tile_first_slot[tile], chunk_nodes, pool, heads);
  for (int k = 0; k < kChunkTileTexels; ++k) {
    int tx = x0 + k % kTile, ty = y0 + k / kTile;
    if (tx < width && ty < height) headers[texel[k]] = heads[k];
  }
}

__global__ void read_texels_kernel(DsmStorage storage, DsmMap map, DsmNode* out, uint32_t cap,
                                   uint32_t* counts) {
  int tx = blockIdx.x * blockDim.x + threadIdx.x, ty = blockIdx.y * blockDim.y + threadIdx.y;
  if (tx >= int(map.res) || ty >= int(map.res)) return;
  size_t texel = size_t(ty) * map.res + tx;
  counts[texel] = read_texel(storage, map, tx, ty, out + texel * cap, cap);
}

__global__ void shade_pixels_kernel(SceneView scene, ShadowView shadows, CameraPassParams params,
                                    FragmentLists frags, float* rgb) {
  int px = blockIdx.x * blockDim.x + threadIdx.x, py = blockIdx.y * blockDim.y + threadIdx.y;
  if (px >= params.view.width || py >= params.view.height) return;
  DsmVisibility vis{shadows};
  NoRecorder rec;
  WalkStats st;
  PixelResult r = shade_pixel(scene, shadows.lights, vis, params, frags.pixel(px, py), px, py, rec, st);
  float* o = rgb + (size_t(py) * params.view.width + px) * 3;
  o[0] = r.color.x;
  o[1] = r.color.y;
  o[2] = r.color.z;
}

__global__ void lookup_kernel(ShadowView shadows, const Vec3* points, int n, float* alpha) {
  int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  float a = 0.0f;
  for (uint32_t l = 0; l < shadows.lights.size(); ++l)
    a = fmaxf(a, shadow_alpha(shadows, shadows.lights[l], points[i]));
  alpha[i] = a;
}

}  // namespace cdsm::cuda
