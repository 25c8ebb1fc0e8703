// Backend choice and fallback (issue 16 item 6), in the library: Auto runs
// on cuda only when a CUDA device is there, else on cpu with the reason;
// cuda asked for by name without a device is an error naming the reason,
// never a crash. Holds on machines with and without a GPU.
#include <gtest/gtest.h>

#include "backend_select.h"
#include "cdsm/error.h"
#include "cdsm/procedural.h"
#include "cdsm/shadow_system.h"

using namespace cdsm;

namespace {
bool device_here() { return resolve_backend(Backend::Cuda).available; }
}  // namespace

TEST(BackendChoice, CpuAndReferenceAlwaysResolve) {
  const BackendResolution c = resolve_backend(Backend::Cpu);
  EXPECT_TRUE(c.available);
  EXPECT_EQ(c.backend, Backend::Cpu);
  EXPECT_EQ(c.name, "cpu");
  EXPECT_EQ(c.reason, "requested");
  const BackendResolution r = resolve_backend(Backend::Reference);
  EXPECT_EQ(r.backend, Backend::Reference);
  EXPECT_EQ(r.name, "reference");
  EXPECT_STREQ(make_backend(Backend::Cpu).backend->name(), "cpu");
  EXPECT_THROW(make_backend(Backend::Reference), Error);
}

TEST(BackendChoice, AutoPicksCudaOnlyWithADevice) {
  const BackendResolution a = resolve_backend(Backend::Auto);
  EXPECT_TRUE(a.available) << "Auto always resolves to something that runs";
  BackendChoice made = make_backend(Backend::Auto);
  ASSERT_TRUE(made.backend);
  if (device_here() && a.reason.rfind("GL context is", 0) == 0) {
    // A device, but the frame's GL context runs elsewhere (llvmpipe): cpu.
    EXPECT_EQ(a.backend, Backend::Cpu);
    EXPECT_STREQ(made.backend->name(), "cpu");
  } else if (device_here()) {
    EXPECT_EQ(a.backend, Backend::Cuda);
    EXPECT_EQ(a.name, "cuda");
    EXPECT_STREQ(made.backend->name(), "cuda");
  } else {
    EXPECT_EQ(a.backend, Backend::Cpu);
    EXPECT_EQ(a.name, "cpu");
    EXPECT_EQ(a.reason.rfind("no CUDA device", 0), 0u) << a.reason;
    EXPECT_EQ(a.reason.find('\n'), std::string::npos) << "one line: " << a.reason;
    EXPECT_STREQ(made.backend->name(), "cpu");
    EXPECT_EQ(made.reason, a.reason);
  }
}

// Auto's decision as a pure function of the two probes (issue 16 item 6):
// every combination, on any machine.
TEST(BackendChoice, AutoNeedsTheGlContextOnTheDevice) {
  DeviceProbe none;
  none.description = "no CUDA device: cudaErrorNoDevice (no CUDA-capable device is detected)";
  DeviceProbe h200;
  h200.available = true;
  h200.device = 0;
  h200.description = "NVIDIA H200 (sm_90, 140 GiB)";
  GlProbe no_gl;
  GlProbe on;
  on.placement = GlPlacement::OnDevice;
  on.context = "NVIDIA Corporation NVIDIA H200/PCIe/SSE2";
  GlProbe llvmpipe;
  llvmpipe.placement = GlPlacement::Elsewhere;
  llvmpipe.context =
      "Mesa llvmpipe (LLVM 15.0.6, 256 bits) (the GL context is not on a CUDA device (cudaErrorNoDevice))";

  // No device: cpu with the device's reason, whatever GL does.
  for (const GlProbe& g : {no_gl, on, llvmpipe}) {
    const BackendResolution r = decide_auto_backend(none, g);
    EXPECT_EQ(r.backend, Backend::Cpu);
    EXPECT_EQ(r.name, "cpu");
    EXPECT_TRUE(r.available);
    EXPECT_EQ(r.reason, none.description);
  }
  // A device and no GL in the frame: the device suffices, and the line says so.
  const BackendResolution a = decide_auto_backend(h200, no_gl);
  EXPECT_EQ(a.backend, Backend::Cuda);
  EXPECT_EQ(a.name, "cuda");
  EXPECT_EQ(a.reason, "default with a CUDA device (no GL context in this frame): NVIDIA H200 (sm_90, 140 GiB)");
  // A device and the GL context on it.
  const BackendResolution b = decide_auto_backend(h200, on);
  EXPECT_EQ(b.backend, Backend::Cuda);
  EXPECT_EQ(b.reason, "default with a CUDA device and the GL context on it: NVIDIA H200 (sm_90, 140 GiB)");
  // A device, but the GL context is Mesa's software rasterizer: cpu, naming why.
  const BackendResolution c = decide_auto_backend(h200, llvmpipe);
  EXPECT_EQ(c.backend, Backend::Cpu);
  EXPECT_EQ(c.name, "cpu");
  EXPECT_TRUE(c.available);
  EXPECT_EQ(c.reason.rfind("GL context is Mesa llvmpipe", 0), 0u) << c.reason;
  EXPECT_NE(c.reason.find("not on CUDA device 0 (NVIDIA H200"), std::string::npos) << c.reason;
  EXPECT_EQ(c.reason.find('\n'), std::string::npos) << "one line: " << c.reason;
}

// Without a device (CI) no GL probe runs and every GL use resolves to cpu
// with the device's reason; cuda by name stays an error.
// cdsm render --fragments cpu|cuda makes no GL context: Auto then asks only
// for the device (decide_auto_backend with no GL); gl and auto rasterize.
TEST(BackendChoice, TheFragmentSourceSaysWhetherTheFrameUsesGl) {
  EXPECT_EQ(gl_use_of(FragmentSource::Cpu), GlUse::None);
  EXPECT_EQ(gl_use_of(FragmentSource::Cuda), GlUse::None);
  EXPECT_EQ(gl_use_of(FragmentSource::Gl), default_gl_use());
  EXPECT_EQ(gl_use_of(FragmentSource::Auto), default_gl_use());
  const BackendResolution by_source = resolve_backend(Backend::Auto, FragmentSource::Cpu);
  const BackendResolution by_use = resolve_backend(Backend::Auto, GlUse::None);
  EXPECT_EQ(by_source.name, by_use.name);
  EXPECT_EQ(by_source.reason, by_use.reason);
}

TEST(BackendChoice, EveryGlUseFallsBackWithoutADevice) {
  if (device_here()) GTEST_SKIP() << "a CUDA device is present: " << resolve_backend(Backend::Cuda).reason;
  for (GlUse g : {GlUse::None, GlUse::Current, GlUse::Headless}) {
    const BackendResolution r = resolve_backend(Backend::Auto, g);
    EXPECT_EQ(r.backend, Backend::Cpu);
    EXPECT_EQ(r.reason.rfind("no CUDA device", 0), 0u) << r.reason;
    EXPECT_STREQ(make_backend(Backend::Auto, g).backend->name(), "cpu");
    EXPECT_FALSE(resolve_backend(Backend::Cuda, g).available);
  }
}

TEST(BackendChoice, CudaByNameWithoutADeviceIsAnErrorWithTheReason) {
  if (device_here()) GTEST_SKIP() << "a CUDA device is present: " << resolve_backend(Backend::Cuda).reason;
  const BackendResolution r = resolve_backend(Backend::Cuda);
  EXPECT_FALSE(r.available);
  EXPECT_EQ(r.name, "cuda");
  EXPECT_EQ(r.reason.rfind("no CUDA device", 0), 0u) << r.reason;
  try {
    make_backend(Backend::Cuda);
    FAIL() << "expected cdsm::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(r.reason), std::string::npos) << e.what();
  }
  // A shadow system asked for cuda refuses the same way (no half-made system).
  SystemOptions o;
  o.backend = Backend::Cuda;
  EXPECT_THROW(ShadowSystem sys(o), Error);
  o.backend = Backend::Auto;
  EXPECT_NO_THROW(ShadowSystem sys(o));
}

// The CUDA fragment producer needs the cuda backend: on the cpu backend a
// system refuses it by name at its first update, before any map is built.
TEST(BackendChoice, CudaFragmentsOnTheCpuBackendAreRefused) {
  cdsm::SystemOptions o;
  o.fragments = cdsm::FragmentSource::Cuda;
  cdsm::ShadowSystem sys(o);
  cdsm::Object box;
  box.mesh = std::make_shared<cdsm::TriangleMesh>(cdsm::make_box({1, 1, 1}));
  sys.add_object(box);
  sys.add_light(cdsm::Light{});
  try {
    sys.update();
    ADD_FAILURE() << "CUDA fragments on the cpu backend must be refused";
  } catch (const cdsm::Error& e) {
    EXPECT_NE(std::string(e.what()).find("--fragments cuda"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("cuda backend"), std::string::npos) << e.what();
  }
}
