// Which ShadowBackend a shadow system runs its kernels on (DESIGN.md §5):
// the cpu backend always; the cuda backend (cuda/cuda_backend.h) when the
// build has one (CDSM_HAVE_CUDA) and a device is there. Auto takes cuda only
// when, besides the device, the GL context the frame uses runs on that
// device (maps and fragments are shared with GL there) — or when the frame
// uses no GL at all. resolve_backend() (cdsm/renderer.h) says which and why;
// the choice and its reason are reported in FrameStats.
#pragma once

#include <memory>
#include <string>

#include "backend/backend.h"
#include "cdsm/renderer.h"
#include "cdsm/shadow_system.h"

namespace cdsm {

// Which GL context the frame uses, for Auto's choice.
enum class GlUse {
  None,      // no GL in the process's frame (fragments ray cast, no GL map buffers)
  Current,   // the context current on this thread (the application's: GlContextUse::Application)
  Headless,  // a headless context the frame makes (fragments rasterized; gl::create_headless_context)
};

// What the device probe found (cuda/device.h's DeviceInfo, plain here).
struct DeviceProbe {
  bool available = false;
  int device = -1;
  std::string description;  // "NVIDIA H200 (sm_90, 140 GiB)", or "no CUDA device: ..."
};
// Where the frame's GL context runs, relative to that device.
enum class GlPlacement { None, OnDevice, Elsewhere };
struct GlProbe {
  GlPlacement placement = GlPlacement::None;
  std::string context;  // the context ("Mesa llvmpipe (LLVM 15.0.6, 256 bits)"); Elsewhere: also why
};

// Auto's choice from the two probes, a pure function (tested on every
// machine): cuda when the device exists and the GL context is on it or there
// is none; else cpu, the reason naming what is missing.
BackendResolution decide_auto_backend(const DeviceProbe& device, const GlProbe& gl);

// resolve_backend (cdsm/renderer.h) for a frame whose GL use is `gl`; the
// public one assumes Headless in builds with GL (the frame's default
// fragments are rasterized on a context it makes), None without.
BackendResolution resolve_backend(Backend want, GlUse gl);

struct BackendChoice {
  std::unique_ptr<ShadowBackend> backend;
  std::string name;    // "cpu", "cuda"
  std::string reason;  // why this one
};

// The backend for `want` (Auto: cuda when it can run, else cpu). Throws
// cdsm::Error when a backend that cannot run here is requested explicitly
// (Cuda without a device; Reference draws no maps).
// `gl`: which GL context the frame uses (Auto only; default_gl_use() when
// not said).
GlUse default_gl_use();                     // Headless in builds with GL, else None
GlUse gl_use_of(FragmentSource fragments);  // Cpu, Cuda: None; Gl, Auto: default_gl_use()
BackendChoice make_backend(Backend want, GlUse gl = default_gl_use());

// A shadow system's backend (SystemOptions::backend): Auto takes cuda only
// where the GL context the system uses (if any) is on the CUDA device — the
// application's (GlContextUse::Application, current now), or the headless
// one its fragment rasterizer makes.
BackendChoice make_system_backend(const SystemOptions& options);

}  // namespace cdsm
