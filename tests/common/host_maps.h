// Maps for tests that look at one map's nodes: built by the cpu backend
// (the exec backend over CPU threads, shadows/backend/exec_backend.h,
// reached through its interface so the kernels are compiled once) into
// its store, with host copies of the store's arrays after each build so a
// test reads `maps[k]`, `texels`, `nodes`, `chunks` and `tags` directly.
#pragma once

#include <memory>
#include <vector>

#include "backend/exec_shadow_backend.h"
#include "backend/host_storage.h"

namespace cdsm_test {

using namespace cdsm;

// The store's arrays as of the last build (HostStorage), its maps' headers.
struct HostMaps : HostStorage {
  std::unique_ptr<exec::ExecShadowBackend> backend;
  std::vector<DsmMap> maps;

  DsmStorage storage() const { return backend->storage(); }
};

// Builds one map of `sb`'s scene from `frags` (copied: the build sorts its
// own) into `out` (all maps of one HostMaps share a layout). `max_nodes`:
// the light pass's large buffer (re-compression beyond node_limit of it);
// `walk_nodes`: its first buffer.
inline DsmBuildStats build_host_map(const SceneBuffers& sb, const LightPassParams& params, FragmentBuffers frags,
                                    HostMaps& out, const DsmLayoutParams& layout = {},
                                    int max_nodes = kTexelNodeCapacity, int walk_nodes = kWalkNodes) {
  if (!out.backend) out.backend = exec::make_cpu_exec_backend();
  out.backend->update_scene(sb, SceneChange::all());
  out.backend->light_pass().max_nodes = max_nodes;
  out.backend->light_pass().walk_nodes = walk_nodes < max_nodes ? walk_nodes : max_nodes;
  DsmBuildStats stats;
  const MapId id = build_map_from_host(*out.backend, params, frags, layout, stats);
  out.maps.push_back(out.backend->map_header(id));
  out.assign(out.backend->storage());
  return stats;
}

}  // namespace cdsm_test
