// Small integer hashes the engine shares (deterministic on every platform).
#pragma once

#include <cstdint>

namespace cdsm {

// A 32-bit avalanche mix: every input bit flips about half the output bits.
inline uint32_t mix32(uint32_t h) {
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return h;
}

}  // namespace cdsm
