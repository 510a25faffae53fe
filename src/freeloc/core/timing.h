// Wall-clock milliseconds since a steady_clock time point: the stage timings of results and logs.
#pragma once

#include <chrono>

namespace freeloc {

inline double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace freeloc
