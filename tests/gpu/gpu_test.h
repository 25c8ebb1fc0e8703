// GPU tests (label gpu): skipped with the reason where no CUDA device is
// usable; CDSM_REQUIRE_GPU=1 (scripts/gpu/run_kit.sh) turns a missing
// device into a failure.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "device.h"

namespace cdsm::test {

inline bool gpu_required() {
  const char* v = std::getenv("CDSM_REQUIRE_GPU");
  return v && std::string(v) == "1";
}

}  // namespace cdsm::test

// First statement of a GPU test.
#define CDSM_REQUIRE_DEVICE()                                                                            \
  do {                                                                                                   \
    const ::cdsm::cuda::DeviceInfo cdsm_device_ = ::cdsm::cuda::probe_device();                          \
    if (!cdsm_device_.available) {                                                                       \
      if (::cdsm::test::gpu_required()) FAIL() << "CDSM_REQUIRE_GPU=1 but " << cdsm_device_.description; \
      GTEST_SKIP() << cdsm_device_.description;                                                          \
    }                                                                                                    \
  } while (0)

// First statement of a GPU test that also needs the GL context on the CUDA
// device (CUDA-GL interop; include gl_interop.h).
#define CDSM_REQUIRE_GL_ON_DEVICE()                                                             \
  do {                                                                                          \
    CDSM_REQUIRE_DEVICE();                                                                      \
    std::string cdsm_why_;                                                                      \
    if (!::cdsm::cuda::gl_context_on_device(::cdsm::cuda::probe_device().device, &cdsm_why_)) { \
      if (::cdsm::test::gpu_required()) FAIL() << cdsm_why_;                                    \
      GTEST_SKIP() << cdsm_why_;                                                                \
    }                                                                                           \
  } while (0)
