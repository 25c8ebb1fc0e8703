// Moves of stored maps inside an executor's memory (shadows/exec/exec.h):
// the exec backend's compaction moves each live map's headers, nodes,
// chunks, tags and pyramid cells down over the holes before it, inside the
// same arrays, and re-bases its offsets and links, without leaving the
// device.
#pragma once

#include <algorithm>

#include "exec/light_pass.h"

namespace cdsm::exec {

// Where one map lies in its kind's arrays (as the cpu backend's StoredMap).
struct ExecStoredMap {
  bool live = false;
  DsmMap map{};
  uint64_t texel_begin = 0, texel_end = 0;
  uint64_t node_begin = 0, node_end = 0;
  uint64_t chunk_begin = 0, chunk_end = 0;
  uint64_t bytes() const {
    const bool rgb = map.rgb != 0u;
    return (texel_end - texel_begin) * sizeof(TexelRange) +
           (node_end - node_begin) * ((rgb ? sizeof(DsmNodeRgb) : sizeof(DsmNode)) + sizeof(SurfaceTag)) +
           (chunk_end - chunk_begin) * ((rgb ? sizeof(ChunkNodeRgb) : sizeof(ChunkNode)) + sizeof(SurfaceTag));
  }
};

// Where the next map goes when a kind's maps are moved down over the holes
// (compaction in place, move_map_down_exec). Tags follow the node slots
// (packed, fixed) or the chunk slots (chunked).
struct StoreCursor {
  uint64_t texels = 0, nodes = 0, chunks = 0, texel_count = 0;
};

// The bytes of map m's largest range in one of its kind's arrays: what
// moving it through a bounce buffer needs.
template <class Node>
uint64_t move_bounce_bytes(const ExecStoredMap& m, bool pyramid) {
  using Chunk = typename NodeKind<Node>::Chunk;
  const uint64_t chunks = m.chunk_end - m.chunk_begin, nodes = m.node_end - m.node_begin;
  uint64_t b = (m.texel_end - m.texel_begin) * sizeof(TexelRange);
  b = std::max<uint64_t>(b, nodes * sizeof(Node));
  b = std::max<uint64_t>(b, chunks * sizeof(Chunk));
  b = std::max<uint64_t>(b, std::max(nodes, chunks) * sizeof(SurfaceTag));
  if (pyramid) b = std::max<uint64_t>(b, uint64_t(m.map.res) * uint64_t(m.map.view.height) / 2u * sizeof(float));
  return b;
}

// Moves map m of `k` down to `at` inside the same arrays (at is at or below
// it: the holes before it closed), each range through `bounce` (at least
// move_bounce_bytes long), offsets and links re-based; advances `at`;
// returns its new place. A map already at `at` stays where it is.
template <class Node, class Ex>
ExecStoredMap move_map_down_exec(Ex& ex, const ExecStoredMap& m, DsmLayout layout, KindStore<Node, Ex>& k,
                                 StoreCursor& at, ExecArray<unsigned char, Ex>& bounce) {
  using Chunk = typename NodeKind<Node>::Chunk;
  const bool chunked = layout == DsmLayout::Chunked;
  const uint64_t texels = m.texel_end - m.texel_begin, nodes = m.node_end - m.node_begin;
  const uint64_t chunks = m.chunk_end - m.chunk_begin;
  ExecStoredMap n = m;
  n.texel_begin = at.texels;
  n.node_begin = at.nodes;
  n.chunk_begin = at.chunks;
  n.texel_end = n.texel_begin + texels;
  n.node_end = n.node_begin + nodes;
  n.chunk_end = n.chunk_begin + chunks;
  n.map.texel_offset = at.texel_count;
  at.texels = n.texel_end;
  at.nodes = n.node_end;
  at.chunks = n.chunk_end;
  at.texel_count += uint64_t(m.map.res) * uint64_t(m.map.view.height);
  if (n.texel_begin == m.texel_begin && n.node_begin == m.node_begin && n.chunk_begin == m.chunk_begin &&
      n.map.texel_offset == m.map.texel_offset)
    return n;
  const long long node_shift = (long long)n.node_begin - (long long)m.node_begin;
  const long long chunk_shift = (long long)n.chunk_begin - (long long)m.chunk_begin;
  unsigned char* b = bounce.data();
  // A plain range: to the bounce, then to its new place.
  const auto move = [&](void* dst, const void* src, uint64_t bytes) {
    if (bytes == 0) return;
    ex.copy(b, src, bytes);
    ex.copy(dst, b, bytes);
  };
  if (texels) {
    ex.copy(b, k.texels.data() + m.texel_begin, texels * sizeof(TexelRange));
    const TexelRange* src = reinterpret_cast<const TexelRange*>(b);
    TexelRange* dst = k.texels.data() + n.texel_begin;
    ex.parallel_for(
        "store: move headers", texels, CDSM_LAMBDA(uint64_t i) {
          TexelRange r = src[i];
          if (chunked) {
            if (r.offset != kChunkEnd) r.offset = uint32_t((long long)r.offset + chunk_shift);
          } else {
            r.offset = uint32_t((long long)r.offset + node_shift);
          }
          dst[i] = r;
        });
  }
  move(k.nodes.data() + n.node_begin, k.nodes.data() + m.node_begin, nodes * sizeof(Node));
  if (chunked)
    move(k.tags.data() + n.chunk_begin, k.tags.data() + m.chunk_begin, chunks * sizeof(SurfaceTag));
  else
    move(k.tags.data() + n.node_begin, k.tags.data() + m.node_begin, nodes * sizeof(SurfaceTag));
  if (chunks) {
    ex.copy(b, k.chunks.data() + m.chunk_begin, chunks * sizeof(Chunk));
    const Chunk* src = reinterpret_cast<const Chunk*>(b);
    Chunk* dst = k.chunks.data() + n.chunk_begin;
    ex.parallel_for(
        "store: move chunks", chunks, CDSM_LAMBDA(uint64_t i) {
          Chunk c = src[i];
          if (c.next != kChunkEnd) c.next = uint32_t((long long)c.next + chunk_shift);
          dst[i] = c;
        });
  }
  if (k.pyramid.size() > 0) {
    const uint64_t cells = uint64_t(m.map.res) * uint64_t(m.map.view.height) / 2u;
    move(k.pyramid.data() + n.map.texel_offset / 2u, k.pyramid.data() + m.map.texel_offset / 2u, cells * sizeof(float));
  }
  return n;
}

// Node lists of every texel of map `m` back to the host, pads excluded
// (tests and parity checks): counts[t] and nodes (cap per texel). `storage`
// in executor memory.
template <class Ex>
void read_map_exec(Ex& ex, const DsmStorage& storage, const DsmMap& m, uint32_t cap, std::vector<uint32_t>& counts,
                   std::vector<DsmNode>& nodes) {
  const uint64_t n = uint64_t(m.res) * uint64_t(m.view.height);
  ExecArray<uint32_t, Ex> c(ex);
  ExecArray<DsmNode, Ex> out(ex);
  c.resize_discard(n);
  out.resize_discard(n * cap);
  uint32_t* cp = c.data();
  DsmNode* op = out.data();
  const DsmStorage st = storage;
  const DsmMap map = m;
  ex.parallel_for(
      "read texels", n, CDSM_LAMBDA(uint64_t i) {
        const int tx = int(i % uint64_t(map.res)), ty = int(i / uint64_t(map.res));
        cp[i] = read_texel(st, map, tx, ty, op + i * cap, cap);
      });
  c.read(counts);
  out.read(nodes);
}

}  // namespace cdsm::exec
