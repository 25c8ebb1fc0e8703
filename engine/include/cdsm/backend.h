// Where a ShadowSystem or Renderer runs its kernels and gets its fragment
// lists, how a request resolves on this machine, and the process-wide
// memory limit. Included by cdsm/shadow_system.h and cdsm/renderer.h.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>

namespace cdsm {

// Where a frame's kernels run. Cuda: the cuda backend (a build with nvcc and
// a CUDA device); Auto: cuda when it can run here, else cpu; Reference: the
// exact renderer, no maps.
enum class Backend { Cpu, Reference, Cuda, Auto };

// What `want` runs on in this process and why (the cdsm program prints it).
// Auto resolves to Cuda or Cpu. available = false when Cuda was asked for
// and cannot run here (no CUDA build, no driver, no device): `reason` says
// which, in one line.
struct BackendResolution {
  Backend backend = Backend::Cpu;
  bool available = true;
  std::string name;    // "cpu", "cuda", "reference"
  std::string reason;  // "requested", "NVIDIA H200 (sm_90, 141 GiB)", "no CUDA device: ..."
};
BackendResolution resolve_backend(Backend want);
// Where fragment lists come from: the OpenGL rasterizer, the CPU ray
// caster, or the same ray caster launched on the CUDA device (needs the
// cuda backend: Backend::Cuda).
enum class FragmentSource { Auto, Gl, Cpu, Cuda };
// resolve_backend for a frame whose fragments come from `fragments`: with
// the ray caster (Cpu, Cuda) the frame makes no GL context, so Auto needs
// only the device; with GL (Gl, Auto) the context must run on it too.
BackendResolution resolve_backend(Backend want, FragmentSource fragments);

// Progress of a long render (the reference image of compare_reference),
// shared with another thread: `fraction` grows from 0 to 1; setting
// `cancel` makes the render stop early and throw cdsm::Error ("cancelled").
struct RenderProgress {
  std::atomic<float> fraction{0.0f};
  std::atomic<bool> cancel{false};
};

// The memory a frame may use when a scene does not say (/shadows/max_memory),
// MiB; 0 restores the default, half the physical memory. Scenes and settings
// estimated to need more are refused, naming the setting, before anything
// large is allocated (also by the scene reader, for grids and meshes it
// generates). Process-wide; cheap.
void set_memory_limit_mib(int64_t mib);

}  // namespace cdsm
