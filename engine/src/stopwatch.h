// Wall-clock stage times of the engine's frames (FrameStats::times).
#pragma once

#include <chrono>

namespace cdsm {

using Clock = std::chrono::steady_clock;

// Milliseconds since t0.
inline double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

}  // namespace cdsm
