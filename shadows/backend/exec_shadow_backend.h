// The exec backend's interface (backend/exec_backend.h) without its
// templates: what a test or the benchmark reaches beyond ShadowBackend, and
// the cpu backend made as one. A translation unit that includes this
// instead of exec_backend.h does not instantiate the kernels again (each
// such test compiled 10-35 s of them under the sanitizers).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "backend/backend.h"
#include "exec/light_pass_options.h"

namespace cdsm::exec {

// The exec backend's own controls beyond ShadowBackend (tests, benchmark).
class ExecShadowBackend : public ShadowBackend {
 public:
  // How the light pass walks texels (its buffers).
  virtual LightPassOptions& light_pass() = 0;
  // Texel t's nodes of map `id` (pads excluded), read on the executor:
  // counts[t], nodes[t * cap ...]. Grey maps only.
  virtual void read_map(MapId id, uint32_t cap, std::vector<uint32_t>& counts, std::vector<DsmNode>& nodes) = 0;
};

// The cpu backend (make_cpu_backend) as the exec backend it is.
std::unique_ptr<ExecShadowBackend> make_cpu_exec_backend();

}  // namespace cdsm::exec
