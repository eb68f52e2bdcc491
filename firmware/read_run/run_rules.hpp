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
// 0 -> force_g over ramp_ms (in decigrams: the force API's resolution), then force_g for
// hold_ms, then done (stop).
enum class LiftoffPhase : uint8_t { kRamp, kHold, kDone };
struct LiftoffStep {
  LiftoffPhase phase;
  uint16_t force_dg;  // every motor's command in this phase (0 when done)
};
inline LiftoffStep liftoffStep(uint32_t elapsed_ms, uint16_t force_g, uint16_t ramp_ms,
                               uint16_t hold_ms) {
  const uint32_t force_dg = 10u * force_g;  // force_g <= tc::kRecordMaxForceG: fits 16 bits
  if (elapsed_ms < ramp_ms) {
    return {LiftoffPhase::kRamp, static_cast<uint16_t>(force_dg * elapsed_ms / ramp_ms)};
  }
  if (elapsed_ms < static_cast<uint32_t>(ramp_ms) + hold_ms)
    return {LiftoffPhase::kHold, static_cast<uint16_t>(force_dg)};
  return {LiftoffPhase::kDone, 0};
}

// The ESC frame's phase (hal::Esc::setPhaseHook): the frame's work (battery, each motor's model,
// the four compare registers) starts this long after each rising edge, so its pulses go out on
// the next edge: one frame per ESC frame, on the ESC's own clock at every rate (50..400 Hz),
// the same way fly's frames are (docs/read_run.md). Four thesis records take ~0.5 ms, far
// inside the shortest frame (2.5 ms).
constexpr uint16_t kFramePhaseUs = 100;

}  // namespace rr
