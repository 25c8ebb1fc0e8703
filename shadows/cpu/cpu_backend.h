// The cpu backend: the ShadowBackend interface over the TBB drivers of
// cpu/backend.h. Maps are built straight into one store per layout (no copy
// when built, none when reused); freed maps leave holes that are compacted
// once they exceed a quarter of the store.
#pragma once

#include <memory>

#include "backend/backend.h"

namespace cdsm {

std::unique_ptr<ShadowBackend> make_cpu_backend();

}  // namespace cdsm
