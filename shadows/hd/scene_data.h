// The compiled scene as the kernels see it: flat arrays of plain structs,
// the same bytes on the CPU and on a GPU (STYLE.md 4). Built on the host by
// scene/scene_buffers.h from a cdsm::Scene.
#pragma once

#include <cstddef>

#include "cdsm/math.h"
#include "cdsm/tags.h"
#include "hd/span.h"

namespace cdsm {

inline constexpr uint32_t kObjClosed = 1u;        // mesh is closed: its interior is defined
inline constexpr uint32_t kObjCastsShadows = 2u;  // enters DSMs
inline constexpr uint32_t kObjColoured = 4u;      // its surface's crossing differs between colour
                                                  // channels (media: is_coloured)

// Per object: surface, interior and its triangle range. 80 bytes (std430:
// five vec4-sized rows).
struct ObjectData {
  Vec3 color;     // surface colour (linear RGB)
  float opacity;  // coverage a: the reflecting part, composited with this weight, [0, 1]
  Vec3 absorb;    // per channel, the opacity of one crossing: 1 - (1 - a) f_k
                  // (cdsm::SurfaceMaterial); exactly (a, a, a) for a white filter
  float ka;       // Phong constants (thesis eq. 3.8)
  Vec3 sigma;     // constant medium: extinction per channel, per world unit
  float kd;
  float ks, shininess;  // Phong k_s, exponent n_s
  InteriorKind interior;
  int32_t volume;      // volume index, or -1
  uint32_t flags;      // kObjClosed | kObjCastsShadows | kObjColoured
  uint32_t first_tri;  // triangle range in the scene's triangle arrays
  uint32_t tri_count;
  uint32_t pad0;
};
static_assert(sizeof(ObjectData) == 80, "ObjectData is 80 bytes");

// Whether a surface passes all light (opacity 0 behind a white filter: a
// volume's proxy): the camera pass, the maps and the reference skip it.
CDSM_HD CDSM_INLINE bool passes_all(const ObjectData& o) { return max_channel(o.absorb) <= 0.0f; }

// Whether the object bounds a medium (a closed mesh with a constant or
// volume interior). Producers keep such an object's fragments outside a
// view's [near, far] as clipped fragments (hd/fragment.h), so media the
// near or far plane cuts stay open: media absorb from the eye up to the
// view's far distance, surfaces are seen only within [near, far].
CDSM_HD CDSM_INLINE bool bounds_medium(const ObjectData& o) {
  return (o.flags & kObjClosed) != 0u && o.interior != InteriorKind::None;
}

// Piecewise-linear transfer function density -> (extinction, colour).
struct TransferData {
  int32_t count;                            // control points used (1..kMaxTransferPoints)
  float density[kMaxTransferPoints];        // ascending
  float extinction[3][kMaxTransferPoints];  // per colour channel, per world unit
  float r[kMaxTransferPoints];
  float g[kMaxTransferPoints];
  float b[kMaxTransferPoints];
  float max_extinction;  // over all control points and channels
  uint32_t coloured;     // 1: some point's extinction differs between channels
  float pad;
};
static_assert(sizeof(TransferData) == 4 + 16 * 4 * 7 + 12,
              "TransferData: count, 7 arrays of kMaxTransferPoints, 3 words");
static_assert(offsetof(TransferData, extinction) == 68 && offsetof(TransferData, max_extinction) == 452,
              "TransferData's arrays follow each other without padding");

// A grid volume placed in the world. Macro-cells of kMacroCell^3 voxels
// hold the maximum extinction (after the transfer function) over the
// voxels a trilinear sample inside the cell can touch (one-voxel apron),
// for empty-space skipping. Cell c covers index positions
// [c*K - 0.5, (c+1)*K - 0.5) on each axis.
//  - GridKind::Dense: a dense array in SceneView::voxels, x fastest, and a dense
//    array of macro-cells -1 .. ceil(n/K) per axis (stored from 0): samples
//    up to a voxel outside the grid read its border voxels.
//  - GridKind::Nano: a NanoVDB float grid in SceneView::nano_pool. Its leaf
//    nodes (8^3 voxels) are exactly the macro-cells: one maximum per leaf,
//    in the tree's leaf order. A cell without a leaf holds one value (a
//    tile's or the background); skip_mode says how its apron is bounded.
inline constexpr int kMacroCell = 8;

struct VolumeData {
  Mat4 world_to_index;    // world -> voxel index coordinates
  Mat4 index_to_world;    // inverse
  uint64_t voxel_offset;  // dense: first voxel in SceneView::voxels;
                          // nano: byte offset of the grid in SceneView::nano_pool (32-aligned)
  uint64_t macro_offset;  // first macro-cell (dense) or per-leaf maximum (nano) in SceneView::macro_max
  int32_t nx, ny, nz;     // dense: voxels; nano: extent of the active bounding box (information)
  int32_t mx, my, mz;     // dense: macro-cells (with the outer ring); nano: mx = leaf count, my = mz = 1
  float background;       // value where the grid stores none
  float step;             // march step, world units
  VolumeShading shading;  // scatter or phong (cdsm/tags.h)
  float gradient_scale;   // phong: gradient -> normal scale
  float voxel_world;      // smallest world size of a voxel edge
  GridKind grid_kind;     // dense or NanoVDB (cdsm/tags.h)
  NanoSkip skip_mode;     // nano: how cells without a leaf are skipped
  Vec3 cells_lo;          // index-space box of the macro-cells that can hold a non-background
  Vec3 cells_hi;          // value (apron included); outside it every sample reads the background
  TransferData tf;
};
// The bytes the CPU and CUDA read alike: two matrices, two 64-bit offsets,
// then 4-byte fields only (the tags are uint32_t enums).
static_assert(sizeof(VolumeData) == 688 && alignof(VolumeData) == 8, "VolumeData is 688 bytes, 8-aligned");
static_assert(offsetof(VolumeData, voxel_offset) == 128 && offsetof(VolumeData, shading) == 176 &&
                  offsetof(VolumeData, grid_kind) == 188 && offsetof(VolumeData, tf) == 220,
              "VolumeData's fields where the kernels expect them");

// A BVH node: inner nodes have count == 0, children at index+1 and `first`;
// leaves hold prims[first .. first+count).
struct BvhNode {
  Vec3 lo;
  uint32_t first;
  Vec3 hi;
  uint32_t count;
};
static_assert(sizeof(BvhNode) == 32, "BvhNode is 32 bytes");

struct SceneView;
CDSM_HD CDSM_INLINE bool is_coloured(const SceneView& s, const ObjectData& o);

struct SceneView {
  Span<const Vec3> tri_vertices;    // 3 world-space positions per triangle
  Span<const Vec3> tri_normals;     // 3 world-space shading normals per triangle
  Span<const uint32_t> tri_object;  // object index per triangle
  Span<const ObjectData> objects;
  Span<const VolumeData> volumes;
  Span<const float> voxels;        // all dense grids
  Span<const float> macro_max;     // all macro-cell maxima
  Span<const uint8_t> nano_pool;   // all NanoVDB grids (GridKind::Nano), each 32-byte aligned
  Span<const BvhNode> bvh;         // node 0 is the root (absent if empty)
  Span<const uint32_t> bvh_prims;  // triangle indices referenced by leaves
};

// Whether object o passes light differently per colour channel: a tinted
// surface, a constant medium or a volume whose extinction differs between
// channels. Maps with such a caster store RGB nodes.
CDSM_HD CDSM_INLINE bool is_coloured(const SceneView& s, const ObjectData& o) {
  if ((o.flags & kObjColoured) != 0u) return true;
  if (o.interior == InteriorKind::Constant) return !is_grey(o.sigma);
  if (o.interior == InteriorKind::Volume && o.volume >= 0) return s.volumes[uint32_t(o.volume)].tf.coloured != 0u;
  return false;
}

// Which objects a view rasterizes (a light's casters, a cluster's members).
// Bit i of words[i / 32] set = object i included. Empty span = all objects.
struct ObjectMask {
  Span<const uint32_t> words;
  CDSM_HD bool contains(uint32_t object) const {
    if (words.empty()) return true;
    uint32_t w = object >> 5;
    return w < words.size() && ((words[w] >> (object & 31u)) & 1u) != 0u;
  }
};

}  // namespace cdsm
