// read_run's decisions as pure functions of numbers: no console, no HAL, no state of their own.
// The controller (read_run_app.cpp, frame.cpp) calls them; tests/firmware/read_run/
// test_run_rules.cpp checks them without booting the app.
#pragma once
#include <stdint.h>

#include "link_watch.hpp"
#include "thrustcal/limits.hpp"

namespace rr {

// Failsafe and lift-off link: kFailsafeMs without a keep-alive (or, in a lift-off, a line end);
// shared with fly (firmware/common/link_watch.hpp).
using fw::linkLost;
using fw::LinkWatch;

// `stream on`: one CSV row every `every_frames` frames (kStreamLinesPerSecond at any rate).
constexpr uint8_t kStreamLinesPerSecond = 10;
struct StreamPace {
  bool on = false;
  uint8_t every_frames = 5;
  uint8_t countdown = 0;

  void setFrameRate(uint16_t frame_hz) {
    every_frames = static_cast<uint8_t>(frame_hz / kStreamLinesPerSecond);
  }
  // Called once per frame: true when this frame's row is due.
  bool frameDue() {
    const bool due = countdown == 0;
    if (due) countdown = every_frames;
    --countdown;
    return due;
  }
};

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
