// Per-box timing: wall-clock milliseconds since a start point.
#pragma once

#include <chrono>

namespace autocal {

inline double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace autocal
