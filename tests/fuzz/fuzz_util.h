// Helpers of the libFuzzer targets: a bounded reader of the input bytes
// and the setup every target shares.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "cdsm/loaders.h"

namespace cdsm_fuzz {

// Reads values from the fuzzer's bytes; past the end every read is 0, so
// any input (also an empty one) describes something.
class ByteReader {
 public:
  ByteReader(const uint8_t* data, size_t size) : data_(data), size_(size) {}

  uint8_t byte() { return at_ < size_ ? data_[at_++] : 0; }
  uint32_t u32() {
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v = (v << 8) | byte();
    return v;
  }
  bool flag() { return (byte() & 1) != 0; }
  // An integer in [lo, hi].
  int range(int lo, int hi) { return lo + int(byte() % uint32_t(hi - lo + 1)); }
  // A float in [lo, hi] in 256 steps.
  float unit(float lo, float hi) { return lo + (hi - lo) * float(byte()) / 255.0f; }
  size_t remaining() const { return at_ < size_ ? size_ - at_ : 0; }
  std::vector<unsigned char> rest() {
    std::vector<unsigned char> r(data_ + (at_ < size_ ? at_ : size_), data_ + size_);
    at_ = size_;
    return r;
  }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t at_ = 0;
};

// Loader warnings are dropped (printing them would dominate the run time),
// and file references of scenes resolve nowhere outside the project: the
// shared data directory points to nothing.
inline void quiet_and_hermetic() {
  cdsm::set_warning_sink([](const std::string&) {});
  setenv("CDSM_DATA_DIR", "/nonexistent/cdsm-fuzz-shared-data", 1);
}

}  // namespace cdsm_fuzz

// libFuzzer's one-time setup of every target: quiet_and_hermetic(). A
// target with more to do defines CDSM_FUZZ_OWN_INITIALIZE and its own.
#ifndef CDSM_FUZZ_OWN_INITIALIZE
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  cdsm_fuzz::quiet_and_hermetic();
  return 0;
}
#endif
