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

// Probed once per process (later calls return the first answer, except
// that once CUDA is unusable, below, it reports no device and says why).
// $CDSM_CUDA_DISABLE=1 reports no device (tests, and users who want the cpu backend by default).
DeviceInfo probe_device();

// A sticky CUDA error (an illegal address, a failed launch, a device-side
// assert, ...) leaves the process's CUDA context unusable: every later call
// returns it. cuda/check.cuh records the first one here, which says so once
// on stderr; from then on the cuda backend's calls fail fast with that
// message (CudaExec) and probe_device() reports no device.
// Returns the message recorded (the first one).
std::string mark_unusable(int cuda_error, const std::string& what);
bool unusable();                // whether a sticky error was recorded
std::string unusable_reason();  // its message ("" while usable)
int unusable_error();           // its cudaError_t (0 while usable)

// $CDSM_CUDA_SYNC=1: CudaExec synchronizes after every launch, so a fault is
// reported by the launch that made it, named (read once per process).
bool sync_every_launch();
// The name of the last kernel launched (CudaExec::parallel_for), for the
// message of an asynchronous fault found later; "" before any.
void note_launch(const char* name);
const char* last_launch();

}  // namespace cdsm::cuda
