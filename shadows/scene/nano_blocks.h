// The blocks of a NanoVDB float tree that can hold a value other than its
// background (host code; the grids' compile and the reference renderer).
#pragma once

#include <nanovdb/NanoVDB.h>

#include <cstdint>

namespace cdsm {

// Calls f(origin, dim) for each block of `tree` (index coordinates, dim^3
// voxels) whose values are not all the background: every leaf (8^3), and
// every tile of an internal node (8^3 in a lower node, 128^3 in an upper
// one) and of the root (4096^3) whose value differs from the background.
// An internal node's table slot n holds child block (x, y, z) =
// (n >> 2L, (n >> L) & (2^L - 1), n & (2^L - 1)), L = log2 of its size
// (NanoVDB's CoordToOffset; its iterators' getOrigin does not compile).
template <class F>
void for_each_value_block(const nanovdb::FloatTree& tree, F&& f) {
  const float bg = tree.background();
  const auto* leaf = tree.getFirstLeaf();
  for (uint32_t i = 0; i < tree.nodeCount(0); ++i) f(leaf[i].origin(), 8);
  auto tiles_of = [&](const auto& node, int log2dim, int child_dim) {
    const nanovdb::Coord o = node.origin();
    const uint32_t mask = (1u << log2dim) - 1u;
    for (auto it = node.beginValue(); it; ++it) {
      if (*it == bg) continue;
      const uint32_t n = it.pos();
      f(o + nanovdb::Coord(int(n >> (2 * log2dim)) * child_dim, int((n >> log2dim) & mask) * child_dim,
                           int(n & mask) * child_dim),
        child_dim);
    }
  };
  const auto* lower = tree.getFirstLower();
  for (uint32_t i = 0; i < tree.nodeCount(1); ++i) tiles_of(lower[i], 4, 8);
  const auto* upper = tree.getFirstUpper();
  for (uint32_t i = 0; i < tree.nodeCount(2); ++i) tiles_of(upper[i], 5, 128);
  const auto& root = tree.root();
  for (uint32_t i = 0; i < root.tileCount(); ++i) {
    const auto* t = root.data()->tile(i);
    if (t->isValue() && t->value != bg) f(t->origin(), 4096);
  }
}

}  // namespace cdsm
