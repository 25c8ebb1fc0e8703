// Closed proxy meshes bounding a volume: the grid's (active) box, or the
// union of a sparse grid's active leaf blocks.
#include <nanovdb/NanoVDB.h>

#include <algorithm>
#include <array>
#include <unordered_map>
#include <unordered_set>

#include "cdsm/error.h"
#include "cdsm/loaders.h"

namespace cdsm {
namespace {

// Appends quad (a, b, c, d), counter-clockwise seen from outside, as two triangles.
void add_quad(TriangleMesh& m, uint32_t a, uint32_t b, uint32_t c, uint32_t d, bool flip) {
  uint32_t q[6] = {a, b, c, a, c, d};
  if (flip) {
    std::swap(q[1], q[2]);
    std::swap(q[4], q[5]);
  }
  m.indices.insert(m.indices.end(), q, q + 6);
}

// Box [lo, hi] in index space, mapped to object space. The index-to-object
// map is baked into the positions, so a mirroring one flips the winding here
// (counter-clockwise outward in object space); compile_object flips again
// only for the object's own transform.
TriangleMesh index_box(Vec3 lo, Vec3 hi, const Mat4& index_to_object) {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i)
    m.positions.push_back(index_to_object.point({(i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z}));
  const bool flip = mirrors(index_to_object);
  add_quad(m, 0, 2, 3, 1, flip);  // -z
  add_quad(m, 4, 5, 7, 6, flip);  // +z
  add_quad(m, 0, 1, 5, 4, flip);  // -y
  add_quad(m, 2, 6, 7, 3, flip);  // +y
  add_quad(m, 0, 4, 6, 2, flip);  // -x
  add_quad(m, 1, 3, 7, 5, flip);  // +x
  return m;
}

using Key = uint64_t;  // a block coordinate packed into 3 x 21 bits
constexpr int64_t kBias = int64_t(1) << 20;

Key pack(int64_t x, int64_t y, int64_t z) {
  return (uint64_t(x + kBias) << 42) | (uint64_t(y + kBias) << 21) | uint64_t(z + kBias);
}

// Union of the active 8^3 leaf blocks, clipped to the active box.
TriangleMesh leaf_hull(const SparseGrid& g, const Mat4& index_to_object) {
  if (g.nanovdb_bytes < sizeof(nanovdb::GridData) || g.nanovdb_bytes > g.nanovdb.size() * sizeof(SparseGrid::Block))
    throw Error(g.name, "sparse grid holds no NanoVDB grid");
  const auto* grid = reinterpret_cast<const nanovdb::FloatGrid*>(g.data());
  if (!grid->isValid() || grid->gridType() != nanovdb::GridType::Float)
    throw Error(g.name, "sparse grid is not a NanoVDB float grid");
  using Leaf = nanovdb::FloatTree::LeafNodeType;
  const nanovdb::FloatTree& tree = grid->tree();
  const Leaf* first = tree.getFirstLeaf();
  std::unordered_set<Key> occupied;
  std::vector<std::array<int64_t, 3>> blocks;
  for (uint32_t i = 0; i < tree.nodeCount<Leaf>(); ++i) {
    const Leaf& leaf = first[i];
    if (leaf.valueMask().isOff()) continue;  // no active voxel
    nanovdb::Coord o = leaf.origin();
    std::array<int64_t, 3> b{o[0] >> 3, o[1] >> 3, o[2] >> 3};
    if (std::abs(b[0]) >= kBias || std::abs(b[1]) >= kBias || std::abs(b[2]) >= kBias)
      throw Error(g.name, "sparse grid extends beyond +-2^23 voxels");
    if (occupied.insert(pack(b[0], b[1], b[2])).second) blocks.push_back(b);
  }
  if (blocks.empty()) throw Error(g.name, "sparse grid has no active voxels");
  auto has = [&](int64_t x, int64_t y, int64_t z) { return occupied.count(pack(x, y, z)) != 0; };
  // Two blocks touching only along an edge would make that edge shared by
  // four faces: fill one of the two empty blocks of each such 2x2 square.
  for (size_t i = 0; i < blocks.size(); ++i) {  // blocks grows while we go
    for (int a = 0; a < 3; ++a)
      for (int b = a + 1; b < 3; ++b)
        for (int sa = -1; sa <= 1; sa += 2)
          for (int sb = -1; sb <= 1; sb += 2) {
            std::array<int64_t, 3> p = blocks[i], qa = blocks[i], qb = blocks[i];
            p[size_t(a)] += sa;
            p[size_t(b)] += sb;
            qa[size_t(a)] += sa;
            qb[size_t(b)] += sb;
            if (has(p[0], p[1], p[2]) && !has(qa[0], qa[1], qa[2]) && !has(qb[0], qb[1], qb[2])) {
              occupied.insert(pack(qa[0], qa[1], qa[2]));
              blocks.push_back(qa);
            }
          }
  }
  // Block corner c on an axis sits at 8c - 0.5, clipped to the active box.
  const int32_t* lo = g.active_min;
  const int32_t* hi = g.active_max;
  auto corner = [&](int axis, int64_t c) {
    float x = float(c * 8) - 0.5f;
    return std::min(std::max(x, float(lo[axis]) - 0.5f), float(hi[axis]) + 0.5f);
  };
  TriangleMesh m;
  std::unordered_map<Key, uint32_t> vertex;
  auto vid = [&](int64_t x, int64_t y, int64_t z) {
    auto it = vertex.emplace(pack(x, y, z), uint32_t(m.positions.size()));
    if (it.second) m.positions.push_back(index_to_object.point({corner(0, x), corner(1, y), corner(2, z)}));
    return it.first->second;
  };
  const bool flip = mirrors(index_to_object);
  for (const auto& b : blocks) {
    const int64_t x = b[0], y = b[1], z = b[2];
    if (!has(x, y, z - 1)) add_quad(m, vid(x, y, z), vid(x, y + 1, z), vid(x + 1, y + 1, z), vid(x + 1, y, z), flip);
    if (!has(x, y, z + 1))
      add_quad(m, vid(x, y, z + 1), vid(x + 1, y, z + 1), vid(x + 1, y + 1, z + 1), vid(x, y + 1, z + 1), flip);
    if (!has(x, y - 1, z)) add_quad(m, vid(x, y, z), vid(x + 1, y, z), vid(x + 1, y, z + 1), vid(x, y, z + 1), flip);
    if (!has(x, y + 1, z))
      add_quad(m, vid(x, y + 1, z), vid(x, y + 1, z + 1), vid(x + 1, y + 1, z + 1), vid(x + 1, y + 1, z), flip);
    if (!has(x - 1, y, z)) add_quad(m, vid(x, y, z), vid(x, y, z + 1), vid(x, y + 1, z + 1), vid(x, y + 1, z), flip);
    if (!has(x + 1, y, z))
      add_quad(m, vid(x + 1, y, z), vid(x + 1, y + 1, z), vid(x + 1, y + 1, z + 1), vid(x + 1, y, z + 1), flip);
  }
  return m;
}

}  // namespace

TriangleMesh make_volume_proxy(const Volume& v, VolumeProxy kind) {
  if (v.sparse) {
    const SparseGrid& g = *v.sparse;
    if (g.active_voxels == 0 || g.active_min[0] > g.active_max[0])
      throw Error(v.name, "sparse grid '" + g.name + "' has no active voxels to bound");
    if (kind == VolumeProxy::Leaves) return leaf_hull(g, v.index_to_object);
    return index_box({g.active_min[0] - 0.5f, g.active_min[1] - 0.5f, g.active_min[2] - 0.5f},
                     {g.active_max[0] + 0.5f, g.active_max[1] + 0.5f, g.active_max[2] + 0.5f}, v.index_to_object);
  }
  if (!v.grid || v.grid->nx < 1 || v.grid->ny < 1 || v.grid->nz < 1) throw Error(v.name, "volume has no grid to bound");
  const DenseGrid& g = *v.grid;
  return index_box({-0.5f, -0.5f, -0.5f}, {g.nx - 0.5f, g.ny - 0.5f, g.nz - 0.5f}, v.index_to_object);
}

}  // namespace cdsm
