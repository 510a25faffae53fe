// Wall-clock milliseconds since a steady_clock time point: the stage timings of results and logs.
#pragma once

#include <chrono>

namespace freeloc {

inline double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// When the process began, as near as a library can tell: the moment libfreeloc_core was loaded (before main). A
// command's record counts its start-up from here (`relocalize`'s prepare_ms).
std::chrono::steady_clock::time_point ProcessStart();

}  // namespace freeloc
