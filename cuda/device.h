// Runtime discovery of a CUDA device. Without one (no driver, a driver too
// old for this runtime, no GPU, or a GPU this build has no code for),
// callers get a one-line reason and use the cpu backend — never a crash.
// Plain C++: the engine includes it without nvcc.
#pragma once

#include <string>

namespace cdsm::cuda {

struct DeviceInfo {
  bool available = false;
  int device = -1;          // the device the cuda backend uses (the first usable one)
  std::string description;  // "NVIDIA H200 (sm_90, 139 GiB)", or why none: "no CUDA device: ..."
};

// Probed once per process (later calls return the first answer).
// $CDSM_CUDA_DISABLE=1 reports no device (tests, and users who want the cpu backend by default).
DeviceInfo probe_device();

}  // namespace cdsm::cuda
