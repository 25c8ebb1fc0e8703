// How the light pass (exec/light_pass.h) walks texels: its buffers. A
// header of its own so the exec backend's interface
// (backend/exec_shadow_backend.h) names it without the kernels.
#pragma once

#include <cstdint>

#include "hd/map_build.h"

namespace cdsm::exec {

struct LightPassOptions {
  int walk_nodes = kWalkNodes;         // K of the first walk (>= 4)
  int max_nodes = kTexelNodeCapacity;  // the second walk's buffer: re-compression beyond node_limit() of it
  // The first walk's buffers of one batch of tile rows, and the second's of
  // one chunk; 0: the executor's (Ex::kLightPassBatchBytes: 8 MiB on CPU
  // threads, where a batch's buffers stay in cache — measured against 2, 32
  // and 1024 MiB —, 1 GiB on a device, where a batch must fill it).
  uint64_t batch_bytes = 0;
};

}  // namespace cdsm::exec
