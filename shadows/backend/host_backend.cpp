// The cpu backend: the exec backend over CPU threads (one instantiation).
#include "backend/exec_backend.h"
#include "exec/host_exec.h"

namespace cdsm {

std::unique_ptr<exec::ExecShadowBackend> exec::make_cpu_exec_backend() {
  return std::make_unique<ExecBackend<HostExec>>("cpu");
}

std::unique_ptr<ShadowBackend> make_cpu_backend() { return exec::make_cpu_exec_backend(); }

}  // namespace cdsm
