// Write side of the `chunked` layout (thesis §4.2.2, Alg. 4.1; DESIGN.md §3).
//
// A chunk is C consecutive slots of the pool (ChunkNode, hd/dsm.h; C = 64 in
// the thesis). The nodes of one 8x8 tile fill the tile's chunks in the order
// in which the tile's 64 threads, emitting in lockstep, would take slots from
// the tile's layer counter b_l[b]: layer 0 of every texel that has one, then
// layer 1, ... Each slot links to its texel's next node, so texels share
// chunks and a texel's list may cross several chunks.
//
// Allocation (Alg. 4.1): the thesis takes a chunk from the global counter g_c
// with atomicAdd each time b_l[b] enters a new chunk b_c = b_l / C
// (eq. 4.11) and records it in b_g[b][b_c] with atomicCAS. Here each texel's
// nodes are complete in its bounded node buffer before anything is written
// (DESIGN.md §2.4), so a tile knows its node count T and reserves all
// ceil(T / C) chunks with one atomic add: b_g[b][b_c] = base + b_c, and the
// slot of b_l is base * C + b_l (eq. 4.11-4.13). Same chunks and the same
// slack — the free slots of each tile's last chunk — without the per-tile
// limit C_B; where the thesis aborts at C_max, a short pool grows and the
// pass is redone (cpu/light_pass.cpp).
#pragma once

#include "hd/dsm.h"

namespace cdsm {

inline constexpr int kChunkTileTexels = 64;  // an 8x8 tile (thesis §4.2.2)

// Chunks a tile with `nodes` nodes reserves.
CDSM_HD CDSM_INLINE uint32_t tile_chunks(uint32_t nodes, uint32_t chunk_nodes) {
  return (nodes + chunk_nodes - 1) / chunk_nodes;
}

// An unused slot (a tile's last chunk past its nodes).
CDSM_HD CDSM_INLINE ChunkNode empty_chunk_node() { return ChunkNode{0.0f, 0.0f, kChunkEnd}; }
// An unused slot of either pool (zero node, no link).
template <class Chunk>
CDSM_HD CDSM_INLINE Chunk empty_chunk() {
  Chunk c{};
  c.next = kChunkEnd;
  return c;
}

// Writes one tile's nodes into its chunks, which start at pool slot
// `first_slot` (= first chunk * C) and were reserved for the tile's total;
// the free slots of the last chunk are cleared. counts[k]: nodes of tile
// texel k (k < texels <= 64; 0 for texels outside the map); nodes_of(k): a
// pointer to them, tags_of(k) to their SurfaceTags (or null). heads[k]
// receives texel k's header; pool_tags (per slot, or null) the tags.
// Returns the slots used (the tile's node total).
// Scalar (ChunkNode) or RGB (ChunkNodeRgb) pools alike.
template <class NodesOf, class TagsOf, class Chunk>
CDSM_HD uint32_t write_chunked_tile(const uint32_t* counts, int texels, NodesOf nodes_of, TagsOf tags_of,
                                    uint32_t first_slot, uint32_t chunk_nodes, Chunk* pool, SurfaceTag* pool_tags,
                                    TexelRange* heads) {
  CDSM_HD_ASSERT(texels <= kChunkTileTexels);
  uint32_t prev[kChunkTileTexels];  // slot of each texel's last written node
  uint32_t layers = 0;
  for (int k = 0; k < texels; ++k) {
    heads[k] = TexelRange{kChunkEnd, counts[k]};
    layers = counts[k] > layers ? counts[k] : layers;
  }
  uint32_t bl = 0;  // b_l[b]: nodes of the tile written so far
  for (uint32_t layer = 0; layer < layers; ++layer) {
    for (int k = 0; k < texels; ++k) {
      if (counts[k] <= layer) continue;
      uint32_t slot = first_slot + bl++;
      pool[slot] = chunk_of(nodes_of(k)[layer], kChunkEnd);
      if (pool_tags) {
        const SurfaceTag* t = tags_of(k);
        pool_tags[slot] = t ? t[layer] : kNoSurface;
      }
      if (layer == 0)
        heads[k].offset = slot;
      else
        pool[prev[k]].next = slot;
      prev[k] = slot;
    }
  }
  uint32_t end = first_slot + tile_chunks(bl, chunk_nodes) * chunk_nodes;
  for (uint32_t slot = first_slot + bl; slot < end; ++slot) {
    pool[slot] = empty_chunk<Chunk>();
    if (pool_tags) pool_tags[slot] = kNoSurface;
  }
  return bl;
}

// The slot write_chunked_tile gives layer `layer` of tile texel k (counts
// as there): the nodes of every texel in the layers before, then those of
// the texels before k that reach this layer.
CDSM_HD CDSM_INLINE uint32_t chunked_tile_slot(const uint32_t* counts, int texels, int k, uint32_t layer) {
  uint32_t before = 0;
  for (int j = 0; j < texels; ++j) {
    before += counts[j] < layer ? counts[j] : layer;  // its nodes in layers 0 .. layer-1
    if (j < k && counts[j] > layer) ++before;
  }
  return before;
}

// write_chunked_tile's result, one texel at a time (a thread per texel on
// a GPU): tile texel k writes its own nodes and links and its header;
// texel 0 also clears the free slots of the tile's last chunk. The same
// slots, links and headers as write_chunked_tile, bit for bit.
template <class Node, class Chunk>
CDSM_HD void write_chunked_texel(const uint32_t* counts, int texels, int k, const Node* nodes, const SurfaceTag* tags,
                                 uint32_t first_slot, uint32_t chunk_nodes, Chunk* pool, SurfaceTag* pool_tags,
                                 TexelRange& head) {
  const uint32_t n = counts[k];
  head = TexelRange{kChunkEnd, n};
  uint32_t slot = n > 0 ? first_slot + chunked_tile_slot(counts, texels, k, 0) : kChunkEnd;
  if (n > 0) head.offset = slot;
  for (uint32_t layer = 0; layer < n; ++layer) {
    const uint32_t next = layer + 1 < n ? first_slot + chunked_tile_slot(counts, texels, k, layer + 1) : kChunkEnd;
    pool[slot] = chunk_of(nodes[layer], next);
    if (pool_tags) pool_tags[slot] = tags ? tags[layer] : kNoSurface;
    slot = next;
  }
  if (k == 0) {
    uint32_t total = 0;
    for (int j = 0; j < texels; ++j) total += counts[j];
    const uint32_t end = first_slot + tile_chunks(total, chunk_nodes) * chunk_nodes;
    for (uint32_t s = first_slot + total; s < end; ++s) {
      pool[s] = empty_chunk<Chunk>();
      if (pool_tags) pool_tags[s] = kNoSurface;
    }
  }
}

}  // namespace cdsm
