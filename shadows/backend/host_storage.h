// The arrays of a DsmStorage held in host memory: a copy of a map store
// (the host mirror of a store in device memory, a test's snapshot) and the
// view of them the lookups read. One type for every such copy.
#pragma once

#include <vector>

#include "hd/dsm.h"

namespace cdsm {

// One node kind's arrays (NodeArrays<N>) held in host memory.
template <int N>
struct HostArrays {
  std::vector<TexelRange> texels;
  std::vector<DsmNodeN<N>> nodes;
  std::vector<ChunkNodeN<N>> chunks;
  std::vector<SurfaceTag> tags;
  std::vector<float> pyramid;

  void assign(const NodeArrays<N>& a) {
    texels.assign(a.texels.begin(), a.texels.end());
    nodes.assign(a.nodes.begin(), a.nodes.end());
    chunks.assign(a.chunks.begin(), a.chunks.end());
    tags.assign(a.tags.begin(), a.tags.end());
    pyramid.assign(a.pyramid.begin(), a.pyramid.end());
  }
  NodeArrays<N> view() const {
    return {{texels.data(), texels.size()},
            {nodes.data(), nodes.size()},
            {chunks.data(), chunks.size()},
            {tags.data(), tags.size()},
            {pyramid.data(), pyramid.size()}};
  }
};

struct HostStorage {
  HostArrays<1> grey;
  HostArrays<3> rgb;

  // Copies the arrays of `s` (spans the host can read).
  void assign(const DsmStorage& s) {
    grey.assign(s.grey);
    rgb.assign(s.rgb);
  }

  // These arrays seen as a store with `shape`'s layout and layers.
  DsmStorage view(const DsmStorage& shape) const {
    DsmStorage st = shape;
    st.grey = grey.view();
    st.rgb = rgb.view();
    return st;
  }
};

}  // namespace cdsm
