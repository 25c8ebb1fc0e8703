// The bits of a float and back, the same on CPU threads and on a GPU (an
// intrinsic on the device, memcpy on the host: no aliasing through casts).
#pragma once

#include <cstdint>
#include <cstring>  // std::memcpy (host)

#include "cdsm/config.h"

namespace cdsm {

// For x >= 0 the bits order as the values do (atomic_max of errors).
CDSM_HD CDSM_INLINE uint32_t float_bits(float x) {
#if defined(__CUDA_ARCH__)
  return __float_as_uint(x);
#else
  uint32_t u;
  std::memcpy(&u, &x, sizeof u);
  return u;
#endif
}

CDSM_HD CDSM_INLINE float bits_float(uint32_t u) {
#if defined(__CUDA_ARCH__)
  return __uint_as_float(u);
#else
  float x;
  std::memcpy(&x, &u, sizeof x);
  return x;
#endif
}

}  // namespace cdsm
