// cdsm::Scene -> flat, GPU-ready arrays (SceneBuffers) + BVH: volume by
// volume and object by object, so a frame recompiles only what changed.
#include "scene_compile.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include <tbb/parallel_for.h>

#include <atomic>

#include "cdsm/error.h"
#include "hd/fragment.h"
#include "hd/segments.h"
#include "hd/volume.h"
#if CDSM_HAVE_NANOVDB
#include "scene/nano_blocks.h"
#endif

namespace cdsm {
namespace {

std::string mib(uint64_t bytes) {
  return format_number(double(bytes) / 1048576.0 < 10 ? std::round(double(bytes) / 104857.6) / 10
                                                      : std::round(double(bytes) / 1048576.0)) +
         " MiB";
}

// Runs an allocation; a failure becomes an Error saying what and how large.
template <class F>
void allocating(const std::string& where, const std::string& what, uint64_t bytes, F&& f) {
  try {
    f();
  } catch (const std::bad_alloc&) {
    throw Error(where, "out of memory while " + what + " (" + mib(bytes) + ")");
  } catch (const std::length_error&) {
    throw Error(where, "out of memory while " + what + " (" + mib(bytes) + ")");
  }
}

// A triangle's unit normal. The squared length of its edges' cross product
// overflows float for triangles of ~1e9 units and more (a ground scaled by
// 1e20 shaded NaN); those take it in double.
Vec3 geometric_normal(Vec3 a, Vec3 b, Vec3 c) {
  const Vec3 u = b - a, v = c - a;
  const float reach = std::fmax(max_channel(vmax(u, -u)), max_channel(vmax(v, -v)));
  if (reach < 1e9f) return normalize(cross(u, v));  // |u x v|^2 below 1e37: float holds it
  const double ux = double(b.x) - a.x, uy = double(b.y) - a.y, uz = double(b.z) - a.z;
  const double vx = double(c.x) - a.x, vy = double(c.y) - a.y, vz = double(c.z) - a.z;
  const double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
  const double len = std::sqrt(nx * nx + ny * ny + nz * nz);
  return Vec3{float(nx / len), float(ny / len), float(nz / len)};
}

// Beyond this distance from the origin float positions are a unit apart.
constexpr float kFloatReach = 1.0e7f;

bool finite_matrix(const Mat4& m) {
  for (auto& row : m.m)
    for (float v : row)
      if (!is_finite(v)) return false;
  return true;
}

TransferData compile_transfer(const Volume& v, const std::string& where) {
  TransferData tf{};
  if (v.transfer.empty()) throw Error(where, "transfer function has no control points");
  if (v.transfer.size() > size_t(kMaxTransferPoints))
    throw Error(where, "transfer function has " + std::to_string(v.transfer.size()) + " control points, at most " +
                           std::to_string(kMaxTransferPoints));
  tf.count = int32_t(v.transfer.size());
  tf.max_extinction = 0.0f;
  for (size_t i = 0; i < v.transfer.size(); ++i) {
    const TransferPoint& p = v.transfer[i];
    if (!is_finite(p.density) || !is_finite(p.extinction) || !is_finite(p.color) || min_channel(p.extinction) < 0)
      throw Error(where, "transfer point " + std::to_string(i) + " is not finite or has negative extinction");
    if (i > 0 && p.density < v.transfer[i - 1].density) throw Error(where, "transfer points must be sorted by density");
    tf.density[i] = p.density;
    for (int k = 0; k < 3; ++k) tf.extinction[k][i] = p.extinction[k];
    if (!is_grey(p.extinction)) tf.coloured = 1u;
    tf.r[i] = p.color.x;
    tf.g[i] = p.color.y;
    tf.b[i] = p.color.z;
    tf.max_extinction = std::max(tf.max_extinction, max_channel(p.extinction));
  }
  return tf;
}

// The transfer function is piecewise linear: its maximum (over channels)
// over the density range [lo, hi] is at an end or at a control point inside.
float max_extinction(const TransferData& tf, float lo, float hi) {
  float m = std::max(max_channel(apply_transfer(tf, lo).extinction), max_channel(apply_transfer(tf, hi).extinction));
  for (int p = 0; p < tf.count; ++p)
    if (tf.density[p] > lo && tf.density[p] < hi) m = std::max(m, max_channel(transfer_extinction(tf, p)));
  return m;
}

// Maximum extinction over the voxels each macro-cell's samples can touch,
// for the cells -1 .. ceil(n / K) on each axis (stored from 0): samples up
// to a voxel outside the grid still read its border voxels (hd/volume.h).
void build_macro_cells(CompiledVolume& sb, VolumeData& vd, const DenseGrid& g, const std::string& where) {
  vd.mx = (g.nx + kMacroCell - 1) / kMacroCell + 2;
  vd.my = (g.ny + kMacroCell - 1) / kMacroCell + 2;
  vd.mz = (g.nz + kMacroCell - 1) / kMacroCell + 2;
  vd.macro_offset = sb.macro_max.size();
  // Stored cells -1 .. ceil(n/K): cell c covers [c K - 0.5, (c + 1) K - 0.5).
  vd.cells_lo = vec3(-float(kMacroCell) - 0.5f);
  vd.cells_hi = Vec3{float((vd.mx - 1) * kMacroCell) - 0.5f, float((vd.my - 1) * kMacroCell) - 0.5f,
                     float((vd.mz - 1) * kMacroCell) - 0.5f};
  const size_t cells = size_t(vd.mx) * vd.my * vd.mz;
  allocating(where, "building its " + std::to_string(cells) + " macro-cells", cells * sizeof(float),
             [&] { sb.macro_max.resize(sb.macro_max.size() + cells, 0.0f); });
  float* out = sb.macro_max.data() + vd.macro_offset;
  for (int sk = 0; sk < vd.mz; ++sk)
    for (int sj = 0; sj < vd.my; ++sj)
      for (int si = 0; si < vd.mx; ++si) {
        const int ci = si - 1, cj = sj - 1, ck = sk - 1;  // the cell's coordinates
        float lo = 3e38f, hi = -3e38f;
        for (int k = ck * kMacroCell - 1; k <= (ck + 1) * kMacroCell; ++k)
          for (int j = cj * kMacroCell - 1; j <= (cj + 1) * kMacroCell; ++j)
            for (int i = ci * kMacroCell - 1; i <= (ci + 1) * kMacroCell; ++i) {
              bool in = i >= 0 && j >= 0 && k >= 0 && i < g.nx && j < g.ny && k < g.nz;
              float d = in ? g.at(i, j, k) : g.background;
              lo = std::min(lo, d);
              hi = std::max(hi, d);
            }
        out[(size_t(sk) * vd.my + sj) * vd.mx + si] = max_extinction(vd.tf, lo, hi);
      }
}

void compile_dense(CompiledVolume& sb, VolumeData& vd, const DenseGrid& g, const std::string& where) {
  if (g.nx <= 0 || g.ny <= 0 || g.nz <= 0) throw Error(where, "has an empty grid");
  if (g.values.size() != size_t(g.nx) * g.ny * g.nz)
    throw Error(where, "grid holds " + std::to_string(g.values.size()) + " values, dimensions need " +
                           std::to_string(size_t(g.nx) * g.ny * g.nz));
  for (size_t i = 0; i < g.values.size(); ++i)
    if (!is_finite(g.values[i])) throw Error(where, "voxel " + std::to_string(i) + " is NaN or infinite");
  if (!is_finite(g.background)) throw Error(where, "background is NaN or infinite");
  vd.grid_kind = GridKind::Dense;
  vd.nx = g.nx;
  vd.ny = g.ny;
  vd.nz = g.nz;
  vd.background = g.background;
  vd.voxel_offset = sb.voxels.size();
  allocating(where, "copying its " + std::to_string(g.values.size()) + " voxels", g.values.size() * sizeof(float),
             [&] { sb.voxels.insert(sb.voxels.end(), g.values.begin(), g.values.end()); });
  build_macro_cells(sb, vd, g, where);
}

#if CDSM_HAVE_NANOVDB
// Copies a NanoVDB grid into the pool and stores one maximum extinction
// per leaf (= macro-cell, apron included). Checks a float grid whose bytes
// are complete and finite values. A cell without a leaf is a constant (a
// tile's value or the background): when every leaf with a non-background
// value has its 26 neighbour leaves and no tile holds a non-background
// value (load_vdb makes grids so), such a cell is background within its
// apron; otherwise (tiles above leaf level, grids made in code) skipping
// reads the cell's 27-cell neighbourhood (NanoSkip::Neighbours).
void compile_nano(CompiledVolume& sb, VolumeData& vd, const SparseGrid& g, const std::string& where) {
  using Leaf = nanovdb::FloatTree::LeafNodeType;
  const uint64_t bytes = g.nanovdb_bytes;
  if (bytes < sizeof(nanovdb::GridData) || bytes > g.nanovdb.size() * sizeof(GridBlock))
    throw Error(where, "sparse grid has " + std::to_string(bytes) + " bytes, not a NanoVDB grid");
  const auto* grid = reinterpret_cast<const nanovdb::FloatGrid*>(g.data());
  if (!grid->isValid() || grid->gridType() != nanovdb::GridType::Float || grid->gridSize() > bytes)
    throw Error(where, "sparse grid is not a complete NanoVDB float grid");
  const nanovdb::FloatTree& tree = grid->tree();
  const float bg = tree.background();
  if (!is_finite(bg)) throw Error(where, "background is NaN or infinite");
  const uint32_t leaves = tree.nodeCount<Leaf>();
  if (leaves == 0) throw Error(where, "sparse grid has no leaf nodes (no voxels)");

  // Pool: whole 32-byte blocks, so every grid starts aligned.
  vd.grid_kind = GridKind::Nano;
  vd.voxel_offset = sb.nano_pool.size() * sizeof(GridBlock);
  allocating(where, "copying its NanoVDB grid", bytes, [&] {
    const size_t blocks = (bytes + sizeof(GridBlock) - 1) / sizeof(GridBlock);
    const size_t first = sb.nano_pool.size();
    sb.nano_pool.resize(first + blocks);
    std::memcpy(sb.nano_pool.data() + first, g.nanovdb.data(), blocks * sizeof(GridBlock));
  });
  vd.background = bg;
  const nanovdb::CoordBBox box = tree.bbox();
  vd.nx = box.max()[0] - box.min()[0] + 1;
  vd.ny = box.max()[1] - box.min()[1] + 1;
  vd.nz = box.max()[2] - box.min()[2] + 1;
  vd.mx = int32_t(leaves);
  vd.my = vd.mz = 1;
  vd.macro_offset = sb.macro_max.size();
  allocating(where, "building its " + std::to_string(leaves) + " leaf maxima", uint64_t(leaves) * sizeof(float),
             [&] { sb.macro_max.resize(sb.macro_max.size() + leaves, 0.0f); });
  float* out = sb.macro_max.data() + vd.macro_offset;
  const Leaf* first = tree.getFirstLeaf();
  std::atomic<int64_t> bad_value{-1}, bad_apron{-1};
  tbb::parallel_for(uint32_t(0), leaves, [&](uint32_t li) {
    const Leaf& leaf = first[li];
    const nanovdb::Coord o = leaf.origin();
    bool non_background = false;
    for (uint32_t n = 0; n < Leaf::SIZE; ++n) {
      float x = leaf.getValue(n);
      if (!is_finite(x)) bad_value = li;
      non_background |= x != bg;
    }
    auto acc = grid->getAccessor();
    if (non_background)
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx)
            if (!acc.probeLeaf(o + nanovdb::Coord(dx * Leaf::DIM, dy * Leaf::DIM, dz * Leaf::DIM))) bad_apron = li;
    float lo = 3e38f, hi = -3e38f;
    for (int k = o[2] - 1; k <= o[2] + int(Leaf::DIM); ++k)
      for (int j = o[1] - 1; j <= o[1] + int(Leaf::DIM); ++j)
        for (int i = o[0] - 1; i <= o[0] + int(Leaf::DIM); ++i) {
          float x = acc.getValue(nanovdb::Coord(i, j, k));
          lo = std::min(lo, x);
          hi = std::max(hi, x);
        }
    out[li] = max_extinction(vd.tf, lo, hi);
  });
  if (bad_value >= 0)
    throw Error(where, "sparse grid has a NaN or infinite value in the leaf at " +
                           std::to_string(first[bad_value].origin()[0]) + "," +
                           std::to_string(first[bad_value].origin()[1]) + "," +
                           std::to_string(first[bad_value].origin()[2]));
  // Tiles (values above leaf level) other than the background?
  bool tiles = false;
  auto check_tile = [&](float v) {
    if (!is_finite(v)) throw Error(where, "sparse grid has a NaN or infinite tile value");
    tiles = tiles || v != bg;
  };
  const auto* lower = tree.getFirstLower();
  for (uint32_t i = 0; i < tree.nodeCount(1); ++i)
    for (auto it = lower[i].beginValue(); it; ++it) check_tile(*it);
  const auto* upper = tree.getFirstUpper();
  for (uint32_t i = 0; i < tree.nodeCount(2); ++i)
    for (auto it = upper[i].beginValue(); it; ++it) check_tile(*it);
  const auto& root = tree.root();
  for (uint32_t i = 0; i < root.tileCount(); ++i)
    if (root.data()->tile(i)->isValue()) check_tile(root.data()->tile(i)->value);
  vd.skip_mode = (tiles || bad_apron >= 0) ? NanoSkip::Neighbours : NanoSkip::Leaves;
  // The cells that can read a non-background value: every leaf and every
  // non-background tile, one cell of apron around them (a sample reads one
  // voxel beyond its cell), as index positions of the cells' extents.
  Vec3 lo = vec3(3e38f), hi = vec3(-3e38f);
  for_each_value_block(tree, [&](const nanovdb::Coord& o, int dim) {
    lo = vmin(lo, Vec3{float(o[0] - kMacroCell), float(o[1] - kMacroCell), float(o[2] - kMacroCell)} - vec3(0.5f));
    hi = vmax(hi, Vec3{float(o[0] + dim + kMacroCell), float(o[1] + dim + kMacroCell), float(o[2] + dim + kMacroCell)} -
                      vec3(0.5f));
  });
  vd.cells_lo = lo;
  vd.cells_hi = hi;
}
#endif

}  // namespace

std::string object_location(const std::string& source, size_t index, const std::string& name) {
  return source + ": object " + std::to_string(index) + (name.empty() ? "" : " '" + name + "'");
}

cluster::LightShape light_shape(const Light& light) {
  cluster::LightShape s;
  s.spot = light.type == LightType::Spot;
  s.directional = light.type == LightType::Directional;
  s.position = light.position;
  s.direction = light.direction;
  s.outer_cone_deg = light.outer_cone_deg;
  return s;
}

CompiledVolume compile_volume(const Volume& v, const std::string& where) {
  if (!v.grid == !v.sparse) throw Error(where, "needs exactly one grid (dense or sparse)");
  if (!(v.step_voxels > 0.0f) || !is_finite(v.step_voxels)) throw Error(where, "step must be > 0");
  CompiledVolume cv;
  VolumeData& vd = cv.data;
  vd.tf = compile_transfer(v, where);
  vd.shading = v.shading;
  vd.gradient_scale = v.gradient_scale;
  if (v.grid) {
    compile_dense(cv, vd, *v.grid, where);
  } else {
#if CDSM_HAVE_NANOVDB
    compile_nano(cv, vd, *v.sparse, where);
#else
    throw Error(where, "sparse (NanoVDB) grids need the NanoVDB headers, absent from this build");
#endif
  }
  return cv;
}

void place_volume(VolumeData& vd, const Volume& v, const Mat4& transform, const std::string& where) {
  const Mat4 index_to_world = transform * v.index_to_object;
  vd.index_to_world = index_to_world;
  if (!invert(index_to_world, vd.world_to_index)) throw Error(where, "volume placement is singular");
  Vec3 ex = index_to_world.vector({1, 0, 0}), ey = index_to_world.vector({0, 1, 0}),
       ez = index_to_world.vector({0, 0, 1});
  vd.voxel_world = std::min({length(ex), length(ey), length(ez)});
  vd.step = v.step_voxels * vd.voxel_world;
  // The march must advance in float wherever the volume holds data (its
  // cells box): its step at least min_march_step of those coordinates
  // (marching from a distant eye or light is lengthened and counted).
  float reach = 0.0f;
  for (int c = 0; c < 8; ++c) {
    Vec3 q{(c & 1) ? vd.cells_hi.x : vd.cells_lo.x, (c & 2) ? vd.cells_hi.y : vd.cells_lo.y,
           (c & 4) ? vd.cells_hi.z : vd.cells_lo.z};
    Vec3 w = vd.index_to_world.point(q);
    reach = std::max({reach, std::fabs(w.x), std::fabs(w.y), std::fabs(w.z)});
  }
  if (!(vd.step >= min_march_step(0.0f, reach)))
    throw Error(where, "its march step of " + std::to_string(vd.step) +
                           " world units (step_voxels x voxel size after the transform) is below the float "
                           "resolution where the volume lies (coordinates up to " +
                           std::to_string(reach) +
                           "): it cannot be marched; use larger voxels or move it nearer the origin");
}

void apply_surface(const Object& o, const std::string& where, ObjectData& od) {
  const SurfaceMaterial& m = o.surface;
  if (!(m.opacity >= 0.0f && m.opacity <= 1.0f)) throw Error(where, "surface opacity must be in [0, 1]");
  const Vec3 f = m.transmission_color;
  if (!is_finite(f) || !(min_channel(f) >= 0.0f && max_channel(f) <= 1.0f))
    throw Error(where,
                "surface transmission_color must be in [0, 1] in every channel (a filter passes at most "
                "all light)");
  od.color = m.color;
  od.opacity = m.opacity;
  // A white filter keeps the coverage itself (bit for bit the grey result).
  const bool white = f.x == 1.0f && f.y == 1.0f && f.z == 1.0f;
  od.absorb = white ? vec3(m.opacity) : one_minus(f * (1.0f - m.opacity));
  od.ka = m.ambient;
  od.kd = m.diffuse;
  od.ks = m.specular;
  od.shininess = m.shininess;
  od.flags = (od.flags & ~(kObjCastsShadows | kObjColoured)) | (o.casts_shadows ? kObjCastsShadows : 0u) |
             (is_grey(od.absorb) ? 0u : kObjColoured);
}

void compile_object(const Object& o, bool closed, const std::string& where, CompiledObject& out) {
  out = CompiledObject{};
  if (!o.mesh) throw Error(where, "has no mesh");
  if (!finite_matrix(o.transform)) throw Error(where, "transform has NaN or infinite entries");
  const TriangleMesh& mesh = *o.mesh;
  if (mesh.indices.size() % 3 != 0) throw Error(where, "mesh index count is not a multiple of 3");
  for (size_t i = 0; i < mesh.positions.size(); ++i)
    if (!is_finite(mesh.positions[i])) throw Error(where, "vertex " + std::to_string(i) + " is NaN or infinite");
  ObjectData& od = out.data;
  od.interior = o.interior;
  od.volume = -1;
  od.flags = closed ? kObjClosed : 0u;
  apply_surface(o, where, od);
  if (o.interior == InteriorKind::Constant && !(min_channel(o.sigma) >= 0.0f && is_finite(o.sigma)))
    throw Error(where, "sigma must be finite and >= 0 in every channel");
  od.sigma = o.interior == InteriorKind::Constant ? o.sigma : Vec3{0, 0, 0};
  if (o.interior != InteriorKind::None && !closed) {  // no interior without a closed boundary
    od.interior = InteriorKind::None;
    out.warnings.push_back(where + ": mesh is not closed, its interior (medium or volume) is ignored");
  }
  Mat4 inv;
  if (!invert(o.transform, inv))
    throw Error(where,
                "transform is singular: it flattens the mesh (or holds values float cannot invert) and "
                "has no inverse for its normals");
  const Mat4 normal_m = transpose(inv);  // inverse transpose of the linear part
  if (mesh.triangle_count() >= kMaxPrimitives)
    throw Error(where, "more than " + std::to_string(kMaxPrimitives) + " triangles");
  allocating(where, "copying its " + std::to_string(mesh.triangle_count()) + " triangles",
             mesh.triangle_count() * (6 * sizeof(Vec3)), [&] {
               out.vertices.reserve(3 * mesh.triangle_count());
               out.normals.reserve(3 * mesh.triangle_count());
             });
  // Meshes are counter-clockwise outward in object space; a mirroring
  // transform (negative determinant) reverses that in world space, so the
  // winding is flipped here — the one place it is (loaders never pre-flip
  // for an object's transform) — and entries stay entries.
  const bool mirrored = mirrors(o.transform);
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    uint32_t idx[3] = {mesh.indices[t], mesh.indices[t + (mirrored ? 2 : 1)], mesh.indices[t + (mirrored ? 1 : 2)]};
    for (uint32_t k : idx)
      if (k >= mesh.positions.size())
        throw Error(where, "triangle " + std::to_string(t / 3) + " refers to vertex " + std::to_string(k) + " of " +
                               std::to_string(mesh.positions.size()));
    Vec3 p[3];
    for (int k = 0; k < 3; ++k) {
      p[k] = o.transform.point(mesh.positions[idx[k]]);
      if (!is_finite(p[k]))
        throw Error(where, "transform turns vertex " + std::to_string(idx[k]) +
                               " (finite in object space) into an infinite or NaN position in world space");
    }
    Vec3 ng = geometric_normal(p[0], p[1], p[2]);
    for (int k = 0; k < 3; ++k) {
      out.vertices.push_back(p[k]);
      out.bounds.grow(p[k]);
      Vec3 n = mesh.normals.size() == mesh.positions.size() ? normalize(normal_m.vector(mesh.normals[idx[k]])) : ng;
      out.normals.push_back(is_finite(n) ? n : ng);
    }
  }
  // Float positions are 1 unit apart at 1.7e7 units from the origin: rays
  // then miss surfaces near the camera (a ground scaled by 1e9 was not hit
  // where the camera looked at it) and lookups lose their depth precision.
  const Box3& b = out.bounds;
  const float reach = out.vertices.empty() ? 0.0f : max_channel(vmax(vmax(b.lo, -b.lo), vmax(b.hi, -b.hi)));
  if (reach > kFloatReach)
    out.warnings.push_back(where + ": reaches " + format_number(reach) +
                           " units from the origin, where float positions are " + format_number(reach * 5.96e-8f) +
                           " units apart or more: rays may miss its surfaces and shadows lose precision; scale the "
                           "scene down (or move it nearer the origin)");
}

uint32_t append_volume(SceneBuffers& sb, const CompiledVolume& cv) {
  VolumeData vd = cv.data;
  if (vd.grid_kind == GridKind::Dense) {
    vd.voxel_offset = sb.voxels.size();
    sb.voxels.insert(sb.voxels.end(), cv.voxels.begin(), cv.voxels.end());
  } else {
    vd.voxel_offset = sb.nano_pool.size() * sizeof(GridBlock);
    sb.nano_pool.insert(sb.nano_pool.end(), cv.nano_pool.begin(), cv.nano_pool.end());
  }
  vd.macro_offset = sb.macro_max.size();
  sb.macro_max.insert(sb.macro_max.end(), cv.macro_max.begin(), cv.macro_max.end());
  sb.volumes.push_back(vd);
  return uint32_t(sb.volumes.size() - 1);
}

void append_object(SceneBuffers& sb, CompiledObject& co, const std::string& source) {
  const uint32_t index = uint32_t(sb.objects.size());
  co.data.first_tri = uint32_t(sb.tri_object.size());
  co.data.tri_count = uint32_t(co.vertices.size() / 3);
  if (uint64_t(sb.tri_object.size()) + co.data.tri_count >= kMaxPrimitives)
    throw Error(source, "more than " + std::to_string(kMaxPrimitives) + " triangles");
  sb.tri_vertices.insert(sb.tri_vertices.end(), co.vertices.begin(), co.vertices.end());
  sb.tri_normals.insert(sb.tri_normals.end(), co.normals.begin(), co.normals.end());
  sb.tri_object.insert(sb.tri_object.end(), co.data.tri_count, index);
  sb.warnings.insert(sb.warnings.end(), co.warnings.begin(), co.warnings.end());
  sb.objects.push_back(co.data);
  sb.object_bounds.push_back(co.bounds);
  sb.bounds.grow(co.bounds);
}

void build_scene_bvh(SceneBuffers& sb, const std::string& source) {
  allocating(source, "building the BVH over " + std::to_string(sb.tri_object.size()) + " triangles",
             sb.tri_object.size() * (sizeof(BvhNode) + sizeof(uint32_t)), [&] { build_bvh(sb); });
}

}  // namespace cdsm
