// The console link as a failsafe watches it (read_run while a motor runs, fly while armed): a
// complete, intact line is a keep-alive; tc::kFailsafeMs without one is a lost link. Pure: the
// images feed it the time of each keep-alive and ask it at their frames.
#pragma once
#include <stdint.h>

#include "thrustcal/limits.hpp"

namespace fw {

// kFailsafeMs without a keep-alive, also across the 32-bit millisecond wrap.
inline bool linkLost(uint32_t now_ms, uint32_t last_keepalive_ms) {
  return now_ms - last_keepalive_ms >= tc::kFailsafeMs;
}

// When the last keep-alive came, and how often the failsafe stopped the motors.
struct LinkWatch {
  uint32_t last_ms = 0;
  uint32_t trips = 0;

  void heard(uint32_t now_ms) { last_ms = now_ms; }
  bool lost(uint32_t now_ms) const { return linkLost(now_ms, last_ms); }
};

}  // namespace fw
