// Copies of stored maps inside an executor's memory (shadows/exec/exec.h):
// the exec backend's compaction moves a map's headers, nodes and chunks
// to the end of fresh arrays and re-bases its offsets and links — the cpu
// backend's move_map (cpu/cpu_backend.cpp) without leaving the device.
#pragma once

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

// Appends map m of `from` to `to` (same kind and layout); returns its new place.
template <class Node, class Ex>
ExecStoredMap move_map_exec(Ex& ex, const ExecStoredMap& m, DsmLayout layout, const KindStore<Node, Ex>& from,
                            KindStore<Node, Ex>& to) {
  using Chunk = typename NodeKind<Node>::Chunk;
  ExecStoredMap n = m;
  n.texel_begin = to.texels.size();
  n.node_begin = to.nodes.size();
  n.chunk_begin = to.chunks.size();
  n.map.texel_offset = to.texel_count;
  to.texel_count += uint64_t(m.map.res) * uint64_t(m.map.view.height);
  const long long node_shift = (long long)n.node_begin - (long long)m.node_begin;
  const long long chunk_shift = (long long)n.chunk_begin - (long long)m.chunk_begin;
  const bool chunked = layout == DsmLayout::Chunked;

  const uint64_t texels = m.texel_end - m.texel_begin;
  to.texels.resize(n.texel_begin + texels);
  const TexelRange* src_t = from.texels.data() + m.texel_begin;
  TexelRange* dst_t = to.texels.data() + n.texel_begin;
  ex.parallel_for(
      "store: move headers", texels, CDSM_LAMBDA(uint64_t i) {
        TexelRange r = src_t[i];
        if (chunked) {
          if (r.offset != kChunkEnd) r.offset = uint32_t((long long)r.offset + chunk_shift);
        } else {
          r.offset = uint32_t((long long)r.offset + node_shift);
        }
        dst_t[i] = r;
      });

  const uint64_t nodes = m.node_end - m.node_begin;
  to.nodes.resize(n.node_begin + nodes);
  if (nodes) ex.copy(to.nodes.data() + n.node_begin, from.nodes.data() + m.node_begin, nodes * sizeof(Node));

  // Tags go with the node slots (packed, fixed) or the chunk slots (chunked).
  const uint64_t tag_begin = chunked ? m.chunk_begin : m.node_begin;
  const uint64_t tags = chunked ? m.chunk_end - m.chunk_begin : nodes;
  const uint64_t to_tag = to.tags.size();
  to.tags.resize(to_tag + tags);
  if (tags) ex.copy(to.tags.data() + to_tag, from.tags.data() + tag_begin, tags * sizeof(SurfaceTag));

  const uint64_t chunks = m.chunk_end - m.chunk_begin;
  to.chunks.resize(n.chunk_begin + chunks);
  const Chunk* src_c = from.chunks.data() + m.chunk_begin;
  Chunk* dst_c = to.chunks.data() + n.chunk_begin;
  ex.parallel_for(
      "store: move chunks", chunks, CDSM_LAMBDA(uint64_t i) {
        Chunk c = src_c[i];
        if (c.next != kChunkEnd) c.next = uint32_t((long long)c.next + chunk_shift);
        dst_c[i] = c;
      });
  // The blocker pyramid's slot (hd/blocker_pyramid.h), where the kind has them.
  if (from.pyramid.size() > 0) {
    const uint64_t cells = uint64_t(m.map.res) * uint64_t(m.map.view.height) / 2u;
    to.pyramid.resize(pyramid_array_size(to.texel_count));
    if (cells)
      ex.copy(to.pyramid.data() + n.map.texel_offset / 2u, from.pyramid.data() + m.map.texel_offset / 2u,
              cells * sizeof(float));
  }
  n.texel_end = to.texels.size();
  n.node_end = to.nodes.size();
  n.chunk_end = to.chunks.size();
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
