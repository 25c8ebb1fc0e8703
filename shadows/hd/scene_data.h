// The compiled scene as the kernels see it: flat arrays of plain structs,
// the same bytes on the CPU and on a GPU (STYLE.md 4). Built on the host by
// cpu/scene_buffers.h from a cdsm::Scene.
#pragma once

#include "cdsm/math.h"
#include "hd/span.h"

namespace cdsm {

inline constexpr uint32_t kObjClosed = 1u;        // mesh is closed: its interior is defined
inline constexpr uint32_t kObjCastsShadows = 2u;  // enters DSMs

// Per object: surface, interior and its triangle range. 64 bytes.
struct ObjectData {
  Vec3 color;           // surface colour (linear RGB)
  float opacity;        // surface opacity per crossing, [0, 1]
  float ka, kd, ks;     // Phong constants (thesis eq. 3.8)
  float shininess;      // Phong exponent n_s
  uint32_t interior;    // InteriorKind: 0 none, 1 constant, 2 volume
  float sigma;          // constant medium: extinction per world unit
  int32_t volume;       // volume index, or -1
  uint32_t flags;       // kObjClosed | kObjCastsShadows
  uint32_t first_tri;   // triangle range in the scene's triangle arrays
  uint32_t tri_count;
  uint32_t pad0, pad1;
};
static_assert(sizeof(ObjectData) == 64, "ObjectData is 64 bytes");

// Whether the object bounds a medium (a closed mesh with a constant or
// volume interior). Producers keep such an object's fragments outside a
// view's [near, far] as clipped fragments (hd/fragment.h), so media the
// near or far plane cuts stay open: media absorb from the eye up to the
// view's far distance, surfaces are seen only within [near, far].
CDSM_HD CDSM_INLINE bool bounds_medium(const ObjectData& o) {
  return (o.flags & kObjClosed) != 0u && o.interior != 0u;
}

// Piecewise-linear transfer function density -> (extinction, colour).
struct TransferData {
  int32_t count;                        // control points used (1..kMaxTransferPoints)
  float density[kMaxTransferPoints];    // ascending
  float extinction[kMaxTransferPoints]; // per world unit
  float r[kMaxTransferPoints];
  float g[kMaxTransferPoints];
  float b[kMaxTransferPoints];
  float max_extinction;                 // over all control points
  float pad[2];
};

// A grid volume placed in the world. Macro-cells of kMacroCell^3 voxels
// hold the maximum extinction (after the transfer function) over the
// voxels a trilinear sample inside the cell can touch (one-voxel apron),
// for empty-space skipping. Cell c covers index positions
// [c*K - 0.5, (c+1)*K - 0.5) on each axis.
//  - kGridDense: a dense array in SceneView::voxels, x fastest, and a dense
//    array of macro-cells -1 .. ceil(n/K) per axis (stored from 0): samples
//    up to a voxel outside the grid read its border voxels.
//  - kGridNano: a NanoVDB float grid in SceneView::nano_pool. Its leaf
//    nodes (8^3 voxels) are exactly the macro-cells: one maximum per leaf,
//    in the tree's leaf order. A cell without a leaf holds one value (a
//    tile's or the background); skip_mode says how its apron is bounded.
inline constexpr int kMacroCell = 8;
inline constexpr uint32_t kGridDense = 0u;
inline constexpr uint32_t kGridNano = 1u;
// How a sparse grid's cells without a leaf are skipped: kNanoSkipLeaves
// (the cell is background within its apron: load_vdb's grids),
// kNanoSkipNeighbours (the cell and its 26 neighbours decide: tiles, grids
// made in code).
inline constexpr uint32_t kNanoSkipLeaves = 0u;
inline constexpr uint32_t kNanoSkipNeighbours = 1u;

struct VolumeData {
  Mat4 world_to_index;   // world -> voxel index coordinates
  Mat4 index_to_world;   // inverse
  uint64_t voxel_offset; // dense: first voxel in SceneView::voxels;
                         // nano: byte offset of the grid in SceneView::nano_pool (32-aligned)
  uint64_t macro_offset; // first macro-cell (dense) or per-leaf maximum (nano) in SceneView::macro_max
  int32_t nx, ny, nz;    // dense: voxels; nano: extent of the active bounding box (information)
  int32_t mx, my, mz;    // dense: macro-cells (with the outer ring); nano: mx = leaf count, my = mz = 1
  float background;      // value where the grid stores none
  float step;            // march step, world units
  uint32_t shading;      // VolumeShading: 0 scatter, 1 phong
  float gradient_scale;  // phong: gradient -> normal scale
  float voxel_world;     // smallest world size of a voxel edge
  uint32_t grid_kind;    // kGridDense / kGridNano
  uint32_t skip_mode;    // nano: kNanoSkipLeaves / kNanoSkipNeighbours
  Vec3 cells_lo;         // index-space box of the macro-cells that can hold a non-background
  Vec3 cells_hi;         // value (apron included); outside it every sample reads the background
  TransferData tf;
};

// A BVH node: inner nodes have count == 0, children at index+1 and `first`;
// leaves hold prims[first .. first+count).
struct BvhNode {
  Vec3 lo;
  uint32_t first;
  Vec3 hi;
  uint32_t count;
};
static_assert(sizeof(BvhNode) == 32, "BvhNode is 32 bytes");

struct SceneView {
  Span<const Vec3> tri_vertices;   // 3 world-space positions per triangle
  Span<const Vec3> tri_normals;    // 3 world-space shading normals per triangle
  Span<const uint32_t> tri_object; // object index per triangle
  Span<const ObjectData> objects;
  Span<const VolumeData> volumes;
  Span<const float> voxels;        // all dense grids
  Span<const float> macro_max;     // all macro-cell maxima
  Span<const uint8_t> nano_pool;   // all NanoVDB grids (kGridNano), each 32-byte aligned
  Span<const BvhNode> bvh;         // node 0 is the root (absent if empty)
  Span<const uint32_t> bvh_prims;  // triangle indices referenced by leaves
};

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
