#include "backend_select.h"

#include "cdsm/error.h"
#include "cpu/cpu_backend.h"

namespace cdsm {

BackendChoice make_backend(Backend want) {
  BackendChoice c;
  switch (want) {
    case Backend::Cpu:
      c.backend = make_cpu_backend();
      c.name = "cpu";
      c.reason = "requested";
      return c;
    case Backend::Reference:
      throw Error("backend", "the reference renderer builds no shadow maps: a shadow system needs the cpu backend");
  }
  throw Error("backend", "unknown backend");
}

}  // namespace cdsm
