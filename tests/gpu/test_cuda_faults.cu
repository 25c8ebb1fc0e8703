// CUDA faults named where they happen (issue 27 item 6; cuda/check.cuh,
// cuda/device.h, cuda/launch.cuh). A sticky error is process-wide, so each
// part runs in its own process (tests/gpu/CMakeLists.txt):
//   - cuda_faults_without_device (label unit, every CUDA build): the error
//     path itself, on error codes, with no GPU: a non-sticky error stays
//     an error of its call; the first sticky one is said once on stderr,
//     names the last kernel launched, and from then on CudaExec-style calls
//     fail fast with it and probe_device() reports no device;
//   - test_cuda_faults (label gpu): a kernel that writes to an invalid
//     address, with CDSM_CUDA_SYNC=1, is named by its launch; then the
//     executor refuses work with that message and the probe says why.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <string>

#include "check.cuh"
#include "device.h"
#include "gpu_test.h"
#include "launch.cuh"

using namespace cdsm;

namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// A kernel that writes to an address nothing was allocated at (an extended
// lambda may not live in a test body, a private member function).
void launch_fault(cuda::CudaExec& ex) {
  int* bad = reinterpret_cast<int*>(uintptr_t(0x10));
  ex.parallel_for(
      "faults: write to an invalid address", 1, CDSM_LAMBDA(uint64_t) { *bad = 1; });
}

}  // namespace

TEST(CudaFaults, StickyErrorsMarkCudaUnusableOnceAndLaterCallsFailFast) {
  ASSERT_FALSE(cuda::unusable());
  // A non-sticky error is the failure of its call only.
  try {
    CDSM_CUDA_CHECK(cudaErrorInvalidValue);
    FAIL() << "no throw";
  } catch (const cuda::CudaError& e) {
    EXPECT_EQ(e.code(), cudaErrorInvalidValue);
    EXPECT_TRUE(contains(e.what(), "cudaErrorInvalidValue")) << e.what();
    EXPECT_TRUE(contains(e.what(), "test_cuda_faults.cu")) << "names the file: " << e.what();
  }
  EXPECT_FALSE(cuda::unusable());
  EXPECT_NO_THROW(cuda::check_usable("download"));

  // The first sticky error: recorded, said once, naming the last kernel.
  cuda::note_launch("light pass: walk");
  testing::internal::CaptureStderr();
  std::string first;
  try {
    cuda::check(cudaErrorIllegalAddress, "cudaStreamSynchronize(stream())", "launch.cuh", 7);
    FAIL() << "no throw";
  } catch (const cuda::CudaError& e) {
    first = e.what();
  }
  // Later failures (cleanup included) say nothing more.
  cuda::check_nothrow(cudaErrorIllegalAddress, "cudaFree(p)", "launch.cuh", 9);
  std::string again;
  try {
    cuda::check(cudaErrorLaunchFailure, "cudaMemcpyAsync(...)", "launch.cuh", 8);
  } catch (const cuda::CudaError& e) {
    again = e.what();
  }
  const std::string said = testing::internal::GetCapturedStderr();
  EXPECT_TRUE(contains(first, "launch.cuh:7: cudaStreamSynchronize(stream()): cudaErrorIllegalAddress")) << first;
  EXPECT_TRUE(contains(first, "last kernel launched: 'light pass: walk'")) << first;
  EXPECT_TRUE(contains(first, "unusable")) << first;
  EXPECT_TRUE(cuda::unusable());
  EXPECT_EQ(cuda::unusable_error(), int(cudaErrorIllegalAddress));
  EXPECT_TRUE(contains(again, "cudaErrorLaunchFailure")) << again;
  EXPECT_TRUE(contains(again, "since: launch.cuh:7")) << "a later error names the first: " << again;
  size_t lines = 0;
  for (size_t p = said.find("CUDA is unusable"); p != std::string::npos; p = said.find("CUDA is unusable", p + 1))
    ++lines;
  EXPECT_EQ(lines, 1u) << "said once:\n" << said;
  EXPECT_TRUE(contains(said, "cudaErrorIllegalAddress")) << said;

  // From now on: fail fast with the first message; no device.
  try {
    cuda::check_usable("upload");
    FAIL() << "no throw";
  } catch (const cuda::CudaError& e) {
    EXPECT_EQ(e.code(), cudaErrorIllegalAddress);
    EXPECT_TRUE(contains(e.what(), "cuda backend: upload: CUDA is unusable")) << e.what();
    EXPECT_TRUE(contains(e.what(), "launch.cuh:7")) << e.what();
  }
  const cuda::DeviceInfo d = cuda::probe_device();
  EXPECT_FALSE(d.available);
  EXPECT_TRUE(contains(d.description, "no CUDA device: CUDA is unusable in this process")) << d.description;
}

TEST(CudaFaultsOnDevice, AnIllegalAddressIsNamedByItsKernelAndSticky) {
  CDSM_REQUIRE_DEVICE();
  setenv("CDSM_CUDA_SYNC", "1", 1);  // before the first launch reads it
  ASSERT_TRUE(cuda::sync_every_launch()) << "CDSM_CUDA_SYNC was read before this test set it";
  cuda::CudaExec ex(cuda::probe_device().device);
  std::string what;
  try {
    launch_fault(ex);
    FAIL() << "the launch of a faulting kernel did not throw under CDSM_CUDA_SYNC=1";
  } catch (const cuda::CudaError& e) {
    what = e.what();
  }
  EXPECT_TRUE(contains(what, "kernel 'faults: write to an invalid address'")) << what;
  EXPECT_TRUE(contains(what, "cudaErrorIllegalAddress")) << what;
  EXPECT_TRUE(cuda::unusable());
  EXPECT_THROW(ex.allocate(64), cuda::CudaError);
  try {
    ex.synchronize();
    FAIL() << "no throw";
  } catch (const cuda::CudaError& e) {
    EXPECT_TRUE(contains(e.what(), "faults: write to an invalid address")) << "the first fault, named: " << e.what();
  }
  EXPECT_FALSE(cuda::probe_device().available);
}
