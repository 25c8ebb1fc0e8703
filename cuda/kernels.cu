#include "kernels.cuh"

namespace cdsm::cuda {

__global__ void count_fragments_kernel(SceneView scene, PinholeView view, ObjectMask mask,
                                       uint32_t* counts) {
  int px = blockIdx.x * blockDim.x + threadIdx.x, py = blockIdx.y * blockDim.y + threadIdx.y;
  if (px >= view.width || py >= view.height) return;
  Vec3 dir = pixel_ray(view, px, py);
  float c = dot(dir, view.forward);
  uint32_t n = 0;
  for_each_hit(scene, mask, view.eye, dir, view.near / c * 0.999f, view.far / c * 1.001f,
               [&](uint32_t, const TriHit& h) {
                 float ax = h.t * c;
                 if (ax >= view.near && ax <= view.far) ++n;
               });
  counts[size_t(py) * view.width + px] = n;
}

__global__ void fill_fragments_kernel(SceneView scene, PinholeView view, ObjectMask mask,
                                      const uint32_t* offsets, Fragment* out) {
  int px = blockIdx.x * blockDim.x + threadIdx.x, py = blockIdx.y * blockDim.y + threadIdx.y;
  if (px >= view.width || py >= view.height) return;
  Vec3 dir = pixel_ray(view, px, py);
  float c = dot(dir, view.forward);
  uint32_t at = offsets[size_t(py) * view.width + px];
  for_each_hit(scene, mask, view.eye, dir, view.near / c * 0.999f, view.far / c * 1.001f,
               [&](uint32_t tri, const TriHit& h) {
                 float ax = h.t * c;
                 if (ax >= view.near && ax <= view.far) out[at++] = make_fragment(h.t, tri, h.front);
               });
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
    a = fmaxf(a, shadow_alpha(shadows, shadows.lights[l], points[i], 0.0f, 0.0f));
  alpha[i] = a;
}

}  // namespace cdsm::cuda
