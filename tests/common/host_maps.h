// Maps for tests that look at one map's nodes: built by the cpu backend
// (the exec backend over CPU threads, shadows/backend/exec_backend.h) into
// its store, with host copies of the store's arrays after each build so a
// test reads `maps[k]`, `texels`, `nodes`, `chunks` and `tags` directly.
#pragma once

#include <memory>
#include <vector>

#include "backend/exec_backend.h"
#include "exec/host_exec.h"

namespace cdsm_test {

using namespace cdsm;

struct HostMaps {
  std::unique_ptr<exec::ExecBackend<exec::HostExec>> backend;
  std::vector<DsmMap> maps;
  // The grey store's arrays as of the last build (RGB maps: rgb_*).
  std::vector<TexelRange> texels, rgb_texels;
  std::vector<DsmNode> nodes;
  std::vector<DsmNodeRgb> rgb_nodes;
  std::vector<ChunkNode> chunks;
  std::vector<ChunkNodeRgb> rgb_chunks;
  std::vector<SurfaceTag> tags, rgb_tags;

  DsmStorage storage() const { return backend->storage(); }
};

// Builds one map of `sb`'s scene from `frags` (copied: the build sorts its
// own) into `out` (all maps of one HostMaps share a layout). `max_nodes`:
// the light pass's large buffer (re-compression beyond node_limit of it);
// `walk_nodes`: its first buffer.
inline DsmBuildStats build_host_map(const SceneBuffers& sb, const LightPassParams& params, FragmentBuffers frags,
                                    HostMaps& out, const DsmLayoutParams& layout = {},
                                    int max_nodes = kTexelNodeCapacity, int walk_nodes = kWalkNodes) {
  if (!out.backend) out.backend = std::make_unique<exec::ExecBackend<exec::HostExec>>("cpu");
  out.backend->update_scene(sb, SceneChange::all());
  out.backend->light_pass().max_nodes = max_nodes;
  out.backend->light_pass().walk_nodes = walk_nodes < max_nodes ? walk_nodes : max_nodes;
  DsmBuildStats stats;
  const MapId id = build_map_from_host(*out.backend, params, frags, layout, stats);
  out.maps.push_back(out.backend->map_header(id));
  const DsmStorage s = out.backend->storage();
  out.texels.assign(s.texels.begin(), s.texels.end());
  out.nodes.assign(s.nodes.begin(), s.nodes.end());
  out.chunks.assign(s.chunks.begin(), s.chunks.end());
  out.tags.assign(s.tags.begin(), s.tags.end());
  out.rgb_texels.assign(s.rgb_texels.begin(), s.rgb_texels.end());
  out.rgb_nodes.assign(s.rgb_nodes.begin(), s.rgb_nodes.end());
  out.rgb_chunks.assign(s.rgb_chunks.begin(), s.rgb_chunks.end());
  out.rgb_tags.assign(s.rgb_tags.begin(), s.rgb_tags.end());
  return stats;
}

}  // namespace cdsm_test
