// The lift-off sequence (thesis sec. 7.4): all four motors the same force, a linear ramp 0 -> G,
// a hold, then stop. This type keeps the sequence's own state (when it started, its force and
// phases, when the next progress line is due); the app applies its steps to the motors and
// stops it on loss of link or a key (read_run_app.cpp).
#pragma once
#include <stdint.h>

#include "run_rules.hpp"

namespace rr {

class Liftoff {
 public:
  static constexpr uint16_t kDefaultRampMs = 2000;  // `help` spells both (static_assert there)
  static constexpr uint16_t kDefaultHoldMs = 5000;
  static constexpr uint16_t kMaxMs = 60000;
  static constexpr uint16_t kProgressMs = 500;  // one "# " progress line this often

  void start(uint16_t force_g, uint16_t ramp_ms, uint16_t hold_ms, uint32_t now_ms) {
    force_g_ = force_g;
    ramp_ms_ = ramp_ms;
    hold_ms_ = hold_ms;
    start_ms_ = now_ms;
    next_progress_ms_ = now_ms;
    holding_ = false;
  }
  // Every motor's force at now_ms and the phase it is in.
  LiftoffStep step(uint32_t now_ms) const {
    return liftoffStep(now_ms - start_ms_, force_g_, ramp_ms_, hold_ms_);
  }
  // True once, at the first step of the hold.
  bool entersHold(const LiftoffStep& step) {
    if (step.phase != LiftoffPhase::kHold || holding_) return false;
    holding_ = true;
    return true;
  }
  // True when a progress line is due at now_ms (then the next one is scheduled).
  bool progressDue(uint32_t now_ms) {
    if (static_cast<int32_t>(now_ms - next_progress_ms_) < 0) return false;
    next_progress_ms_ += kProgressMs;
    return true;
  }

  uint32_t startMs() const { return start_ms_; }
  uint16_t forceG() const { return force_g_; }
  uint16_t rampMs() const { return ramp_ms_; }
  uint16_t holdMs() const { return hold_ms_; }
  bool holding() const { return holding_; }

 private:
  uint32_t start_ms_ = 0;
  uint32_t next_progress_ms_ = 0;
  uint16_t force_g_ = 0;
  uint16_t ramp_ms_ = 0;
  uint16_t hold_ms_ = 0;
  bool holding_ = false;
};

}  // namespace rr
