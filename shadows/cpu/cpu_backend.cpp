#include "cpu/cpu_backend.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace cdsm {
namespace {

// Where one map lies in its kind's arrays of the store (grey or RGB).
struct StoredMap {
  bool live = false;
  DsmMap map{};                  // texel_offset into the store
  uint64_t texel_begin = 0;      // packed, chunked: its TexelRanges [begin, end)
  uint64_t texel_end = 0;
  uint64_t node_begin = 0;       // packed, fixed: its nodes [begin, end)
  uint64_t node_end = 0;
  uint64_t chunk_begin = 0;      // chunked: its chunk slots [begin, end)
  uint64_t chunk_end = 0;
  uint64_t bytes() const {
    const bool rgb = map.rgb != 0u;
    return (texel_end - texel_begin) * sizeof(TexelRange) +
           (node_end - node_begin) * ((rgb ? sizeof(DsmNodeRgb) : sizeof(DsmNode)) + sizeof(SurfaceTag)) +
           (chunk_end - chunk_begin) * ((rgb ? sizeof(ChunkNodeRgb) : sizeof(ChunkNode)) + sizeof(SurfaceTag));
  }
};

// Copies map m from `from` to the end of `to`, re-basing its headers' node /
// chunk offsets and the chunks' links; returns its new place.
template <class Node, class Chunk>
StoredMap move_map(const StoredMap& m, uint32_t layout, DsmArraysRef<Node, Chunk> from, DsmArraysRef<Node, Chunk> to) {
  const uint64_t texel_count = uint64_t(m.map.res) * m.map.view.height;
  StoredMap n = m;
  n.texel_begin = to.texels.size();
  n.node_begin = to.nodes.size();
  n.chunk_begin = to.chunks.size();
  n.map.texel_offset = to.texel_count;
  to.texel_count += texel_count;
  const int64_t node_shift = int64_t(n.node_begin) - int64_t(m.node_begin);
  const int64_t chunk_shift = int64_t(n.chunk_begin) - int64_t(m.chunk_begin);
  for (uint64_t t = m.texel_begin; t < m.texel_end; ++t) {
    TexelRange r = from.texels[t];
    if (layout == kDsmChunked) {
      if (r.offset != kChunkEnd) r.offset = uint32_t(int64_t(r.offset) + chunk_shift);
    } else {
      r.offset = uint32_t(int64_t(r.offset) + node_shift);
    }
    to.texels.push_back(r);
  }
  to.nodes.insert(to.nodes.end(), from.nodes.begin() + ptrdiff_t(m.node_begin), from.nodes.begin() + ptrdiff_t(m.node_end));
  // Tags go with the node slots (packed, fixed) or the chunk slots (chunked).
  const uint64_t tag_begin = layout == kDsmChunked ? m.chunk_begin : m.node_begin;
  const uint64_t tag_end = layout == kDsmChunked ? m.chunk_end : m.node_end;
  to.tags.insert(to.tags.end(), from.tags.begin() + ptrdiff_t(tag_begin), from.tags.begin() + ptrdiff_t(tag_end));
  for (uint64_t c = m.chunk_begin; c < m.chunk_end; ++c) {
    Chunk cn = from.chunks[c];
    if (cn.next != kChunkEnd) cn.next = uint32_t(int64_t(cn.next) + chunk_shift);
    to.chunks.push_back(cn);
  }
  n.texel_end = to.texels.size();
  n.node_end = to.nodes.size();
  n.chunk_end = to.chunks.size();
  return n;
}

class CpuBackend final : public ShadowBackend {
 public:
  const char* name() const override { return "cpu"; }

  void update_scene(const SceneBuffers& sb, const SceneChange&) override { scene_ = sb.view(); }

  MapId build_map(const LightPassParams& params, FragmentLists frags, const DsmLayoutParams& layout,
                  DsmBuildStats& stats) override {
    if (slots_.live() == 0) reset_store();
    StoredMap m;
    const auto place = [&](auto kind, bool end) {
      (end ? m.texel_end : m.texel_begin) = kind.texels.size();
      (end ? m.node_end : m.node_begin) = kind.nodes.size();
      (end ? m.chunk_end : m.chunk_begin) = kind.chunks.size();
    };
    if (params.rgb) place(rgb_arrays(store_), false);
    else place(grey_arrays(store_), false);
    stats = build_dsm(scene_, params, frags, store_, layout);
    m.live = true;
    m.map = store_.maps.back();
    // The store's own map list is unused (slots_ holds the maps); one entry
    // stays so the store keeps its layout (build_dsm adopts a layout only
    // when the list is empty).
    store_.maps.assign(1, DsmMap{});
    if (params.rgb) place(rgb_arrays(store_), true);
    else place(grey_arrays(store_), true);
    return slots_.add(m);
  }

  void free_map(MapId id) override {
    slots_.free(id);
    if (slots_.live() == 0) reset_store();
    else if (slots_.needs_compaction()) compact();
  }

  DsmMap map_header(MapId id) const override {
    return slots_.at(id, "map_header").map;
  }

  DsmStorage storage() const override { return store_.storage(); }
  uint64_t storage_epoch() const override { return epoch_; }

  void camera_pass(const ShadowView& shadows, const CameraPassParams& params, FragmentLists frags,
                   std::vector<float>& rgb, WalkStats& walk) override {
    render_camera(scene_, shadows, params, frags, rgb, walk);
  }

  MapStoreStats map_store() const override {
    MapStoreStats s;
    s.live_bytes = slots_.live_bytes;
    s.allocated_bytes = allocated_bytes();
    s.compactions = compactions_;
    s.compacted_bytes = compacted_bytes_;
    s.maps = slots_.live();
    return s;
  }

 private:
  uint64_t allocated_bytes() const {
    return store_.texels.capacity() * sizeof(TexelRange) + store_.nodes.capacity() * sizeof(DsmNode) +
           store_.chunks.capacity() * sizeof(ChunkNode) + store_.rgb.texels.capacity() * sizeof(TexelRange) +
           store_.rgb.nodes.capacity() * sizeof(DsmNodeRgb) + store_.rgb.chunks.capacity() * sizeof(ChunkNodeRgb) +
           (store_.tags.capacity() + store_.rgb.tags.capacity()) * sizeof(SurfaceTag);
  }

  void reset_store() {
    store_ = DsmBuffers{};  // frees the arrays (clear() would keep their capacity)
    ++epoch_;
    slots_.clear();
  }

  // Copies the live maps into fresh arrays, exactly sized, re-basing their
  // headers' node / chunk offsets and the chunks' links.
  void compact() {
    DsmBuffers next;
    next.layout = store_.layout;
    next.maps.push_back(DsmMap{});
    size_t texels[2] = {0, 0}, nodes[2] = {0, 0}, chunks[2] = {0, 0};
    for (const StoredMap& m : slots_.maps)
      if (m.live) {
        const int k = m.map.rgb ? 1 : 0;
        texels[k] += m.texel_end - m.texel_begin;
        nodes[k] += m.node_end - m.node_begin;
        chunks[k] += m.chunk_end - m.chunk_begin;
      }
    next.texels.reserve(texels[0]);
    next.nodes.reserve(nodes[0]);
    next.chunks.reserve(chunks[0]);
    next.rgb.texels.reserve(texels[1]);
    next.rgb.nodes.reserve(nodes[1]);
    next.rgb.chunks.reserve(chunks[1]);
    const bool chunked = store_.layout.layout == kDsmChunked;
    next.tags.reserve(chunked ? chunks[0] : nodes[0]);
    next.rgb.tags.reserve(chunked ? chunks[1] : nodes[1]);
    for (StoredMap& m : slots_.maps) {
      if (!m.live) continue;
      m = m.map.rgb ? move_map(m, store_.layout.layout, rgb_arrays(store_), rgb_arrays(next))
                    : move_map(m, store_.layout.layout, grey_arrays(store_), grey_arrays(next));
      compacted_bytes_ += m.bytes();
    }
    store_ = std::move(next);
    slots_.compacted();
    ++compactions_;
    ++epoch_;
  }

  SceneView scene_{};
  DsmBuffers store_;                // every stored map's texels and nodes, in one layout
  MapSlots<StoredMap> slots_;
  uint64_t compactions_ = 0, compacted_bytes_ = 0;
  uint64_t epoch_ = 1;  // storage_epoch()
};

}  // namespace

std::unique_ptr<ShadowBackend> make_cpu_backend() { return std::make_unique<CpuBackend>(); }

}  // namespace cdsm
