// The arrays of a DsmStorage held in host memory: a copy of a map store
// (the host mirror of a store in device memory, a test's snapshot) and the
// view of them the lookups read. One type for every such copy.
#pragma once

#include <vector>

#include "hd/dsm.h"

namespace cdsm {

struct HostStorage {
  std::vector<TexelRange> texels, rgb_texels;
  std::vector<DsmNode> nodes;
  std::vector<DsmNodeRgb> rgb_nodes;
  std::vector<ChunkNode> chunks;
  std::vector<ChunkNodeRgb> rgb_chunks;
  std::vector<SurfaceTag> tags, rgb_tags;

  // Copies the arrays of `s` (spans the host can read).
  void assign(const DsmStorage& s) {
    texels.assign(s.texels.begin(), s.texels.end());
    nodes.assign(s.nodes.begin(), s.nodes.end());
    chunks.assign(s.chunks.begin(), s.chunks.end());
    tags.assign(s.tags.begin(), s.tags.end());
    rgb_texels.assign(s.rgb_texels.begin(), s.rgb_texels.end());
    rgb_nodes.assign(s.rgb_nodes.begin(), s.rgb_nodes.end());
    rgb_chunks.assign(s.rgb_chunks.begin(), s.rgb_chunks.end());
    rgb_tags.assign(s.rgb_tags.begin(), s.rgb_tags.end());
  }

  // These arrays seen as a store with `shape`'s layout and layers.
  DsmStorage view(const DsmStorage& shape) const {
    DsmStorage st = shape;
    st.texels = {texels.data(), texels.size()};
    st.nodes = {nodes.data(), nodes.size()};
    st.chunks = {chunks.data(), chunks.size()};
    st.tags = {tags.data(), tags.size()};
    st.rgb_texels = {rgb_texels.data(), rgb_texels.size()};
    st.rgb_nodes = {rgb_nodes.data(), rgb_nodes.size()};
    st.rgb_chunks = {rgb_chunks.data(), rgb_chunks.size()};
    st.rgb_tags = {rgb_tags.data(), rgb_tags.size()};
    return st;
  }
};

}  // namespace cdsm
