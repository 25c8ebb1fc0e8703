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
  if (device_here()) {
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
