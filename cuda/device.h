// Runtime discovery of a CUDA device. Without one (or without a driver),
// callers get a clear reason and use the cpu backend — never a crash.
#pragma once

#include <string>

namespace cdsm::cuda {

struct DeviceInfo {
  bool available = false;
  std::string description;  // device name and compute capability, or why none
};

DeviceInfo probe_device();

}  // namespace cdsm::cuda
