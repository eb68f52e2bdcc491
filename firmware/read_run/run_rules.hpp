// read_run's decisions as pure functions of numbers: no console, no HAL, no state of their own.
// The controller (read_run_app.cpp, frame.cpp) calls them; tests/firmware/read_run/
// test_run_rules.cpp checks them without booting the app.
#pragma once
#include <stdint.h>

#include "thrustcal/limits.hpp"

namespace rr {

// Failsafe and lift-off link: kFailsafeMs without a keep-alive (or, in a lift-off, a line end).
inline bool linkLost(uint32_t now_ms, uint32_t last_keepalive_ms) {
  return now_ms - last_keepalive_ms >= tc::kFailsafeMs;
}

// The lift-off sequence (thesis sec. 7.4) at `elapsed_ms` after its command: a linear ramp
// 0 -> force_g over ramp_ms, then force_g for hold_ms, then done (stop).
enum class LiftoffPhase : uint8_t { kRamp, kHold, kDone };
struct LiftoffStep {
  LiftoffPhase phase;
  uint16_t force_g;  // every motor's command in this phase (0 when done)
};
inline LiftoffStep liftoffStep(uint32_t elapsed_ms, uint16_t force_g, uint16_t ramp_ms,
                               uint16_t hold_ms) {
  if (elapsed_ms < ramp_ms) {
    return {LiftoffPhase::kRamp,
            static_cast<uint16_t>(static_cast<uint32_t>(force_g) * elapsed_ms / ramp_ms)};
  }
  if (elapsed_ms < static_cast<uint32_t>(ramp_ms) + hold_ms) return {LiftoffPhase::kHold, force_g};
  return {LiftoffPhase::kDone, 0};
}

// The v2 bus-voltage filter's constant per frame rate, 1/2^shift per frame: 1/8 at 50-99 Hz,
// 1/16 at 100-199, 1/32 at 200-399, 1/64 at 400 Hz, so its time constant stays about 150 ms.
inline uint8_t filterShiftFor(uint16_t frame_hz) {
  uint8_t shift = 3;
  for (uint16_t hz = 100; hz <= frame_hz && shift < 6; hz = static_cast<uint16_t>(hz * 2)) ++shift;
  return shift;
}

// Sum of the middle two of four ADC readings, each clamped to adc_max (one spike either way
// is ignored): the v2 frame's battery reading in half counts, at most 2 * adc_max.
inline uint16_t middleTwoCounts(const uint16_t (&counts)[4], uint16_t adc_max) {
  uint16_t sum = 0;
  uint16_t lo = 0xFFFF;
  uint16_t hi = 0;
  for (uint8_t k = 0; k < 4; ++k) {
    const uint16_t c = counts[k] < adc_max ? counts[k] : adc_max;
    sum = static_cast<uint16_t>(sum + c);
    if (c < lo) lo = c;
    if (c > hi) hi = c;
  }
  return static_cast<uint16_t>(sum - lo - hi);
}

// The ESC frame schedule on a 1 ms clock: period 1000/hz ms as whole ms plus a remainder, so
// 400 Hz averages exactly 2.5 ms. A schedule that fell behind (a long print) restarts from now.
struct FrameClock {
  uint32_t next_ms = 0;
  uint16_t rem = 0;

  void restart(uint32_t now_ms) {
    next_ms = now_ms;
    rem = 0;
  }
  bool due(uint32_t now_ms) const { return static_cast<int32_t>(now_ms - next_ms) >= 0; }
  // Called when a frame is served at now_ms: schedules the next one.
  void advance(uint32_t now_ms, uint16_t frame_hz) {
    next_ms += 1000u / frame_hz;
    rem = static_cast<uint16_t>(rem + 1000u % frame_hz);
    if (rem >= frame_hz) {
      rem = static_cast<uint16_t>(rem - frame_hz);
      ++next_ms;
    }
    if (due(now_ms)) {
      next_ms = now_ms + 1000u / frame_hz;
      rem = 0;
    }
  }
};

}  // namespace rr
