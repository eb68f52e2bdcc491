// How gather_store reads one sweep step: the window of load-cell readings, the force reading of
// its default sweep, and settle auto (when the force has stopped changing, so the sweep may
// step on). One home for the rule: gather_store's sweep runner and the bench's simulated sweeps
// (tools/bench/src/sweeps.cpp) both call it, so the benchmark measures the rule the board runs.
// Why these numbers: docs/gather_store.md ("settle"); what they give: docs/results.md.
#pragma once
#include <stdint.h>

namespace tc {

// Load-cell readings per force reading (thesis: the median of 201).
constexpr uint16_t kForceWindow = 201;
// With settle auto the force (and the tare) is the mean of the middle kForceCentral of those
// readings (MedianFilter::centralMeanQ4, 1/16 count): as robust to spikes as the median, but
// not stuck to whole counts, because the noise dithers the readings between two counts.
constexpr uint16_t kForceCentral = 65;

// Settle auto: a force median every kSettleProbeMs; the step is settled once
// kSettledAgreements successive pairs of medians differ by at most kSettledCounts ADC counts
// (0: three equal medians in a row), or once the cap (the `settle MS` setting) has passed.
// A looser rule (one count) steps on too early at the low end, where one step moves the force
// by only a few counts.
constexpr uint16_t kSettleProbeMs = 20;
constexpr uint16_t kSettledCounts = 0;
constexpr uint8_t kSettledAgreements = 2;
// gather_store's default sweep settles by measurement with this cap: long enough for the motor
// and the load cell's low-pass to settle at every step, where the thesis's fixed 200 ms reads a
// rising curve late (`settle 200` keeps the thesis timing).
constexpr uint16_t kDefaultSettleCapMs = 500;

// The fast calibration (issue 26 item 2): on a slot whose record holds the motor's dynamics
// (`dyn`) and a bench whose settings hold the load cell's response (`dyn cell`), a sweep with
// `step 15` and `settle 150` reads each step before it has settled and gather_store corrects the
// reading for the lag (thrustcal/sweep_lag.hpp). Model v2 is a fitted curve, so 54 corrected
// steps do instead of 81 settled ones: at least 2.5x quicker than the default sweep with model
// v2 within issue 26's accuracy target (`thrustcal bench calibration`, docs/model_v2.md
// "Dynamics").
constexpr uint16_t kFastSweepStepUs = 15;
constexpr uint16_t kFastSweepSettleMs = 150;

// What settle auto remembers between the medians of one step; a step starts from {}.
struct SettleAuto {
  uint16_t previous_counts = 0;
  bool has_previous = false;
  uint8_t agreements = 0;  // successive agreeing pairs so far
};

// The state after one more force median (ADC counts) of the same step.
constexpr SettleAuto settleAutoNext(SettleAuto s, uint16_t counts) {
  if (s.has_previous) {
    const uint16_t change = counts > s.previous_counts ? static_cast<uint16_t>(counts - s.previous_counts)
                                                       : static_cast<uint16_t>(s.previous_counts - counts);
    s.agreements = change <= kSettledCounts ? static_cast<uint8_t>(s.agreements + 1) : 0;
  }
  s.previous_counts = counts;
  s.has_previous = true;
  return s;
}

// True when the step is settled: enough agreeing medians, or `elapsed_ms` since the pulse
// changed has reached the cap. Never false for ever: the cap ends every step.
constexpr bool settleAutoDone(const SettleAuto& s, uint32_t elapsed_ms, uint16_t cap_ms) {
  return s.agreements >= kSettledAgreements || elapsed_ms >= cap_ms;
}

}  // namespace tc
