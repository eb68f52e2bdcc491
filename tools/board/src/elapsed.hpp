// Wall time since a point, in seconds: what the board commands report and time out on.
#pragma once
#include <chrono>

namespace board {
inline double secondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}
}  // namespace board
