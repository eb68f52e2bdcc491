// A sweep read faster than the motor and the load cell settle, corrected with the measured
// dynamics (issue 26 item 2): gather_store's fixed-settle sweeps (`settle MS`) and the bench's
// simulated ones.
//
// Each step's pulse reaches the ESC at an edge e_j; the motor's force follows as a first-order
// lag (the motor's spin-up time constant at that force, thrustcal/dynamics.hpp) and the load
// cell's stages add theirs, so what the sweep reads at t_k is
//
//     y_k = F_0 + sum_j dF_j * g(t_k - e_j)      g: the step response of motor and cell
//
// and with the force rising by about the same dF per step around k (a staircase with a smooth
// curve under it)
//
//     F_k = y_k + dF_k * L_k,   L_k = sum_{j <= k} (1 - g(t_k - e_j))
//
// L_k (steps the reading trails by) is summed over the actual edges, so the ESC frame's jitter
// in when a pulse starts counts exactly; dF_k is the readings' own central difference. The
// motor lag's time constant at F_k comes from the record, the cell's from the board settings.
// (1 - g) is the tail of the sum of an exponential and an Erlang delay, in closed form; when the
// motor's time constant is within 10 % of a cell stage's the two are taken as one Erlang stage
// more with their mean delay.
//
// Streaming, one step behind: each step's reading is corrected when the next one (its slope) is
// in; finish() gives the last. Float: gather_store runs it once per step, never in flight.
#pragma once
#include <stdint.h>

#include "thrustcal/dynamics.hpp"
#include "thrustcal/model_v2.hpp"

namespace tc {

// 1 - g(t): the part of a unit step not yet read t seconds after its edge, for a motor lag of
// tau_s through `bench`.
float lagTail(float t_s, float tau_s, const BenchResponse& bench);

class SweepLagCorrector {
 public:
  static constexpr uint8_t kEdges = 12;  // edges remembered: about 1.5 s of the fastest sweep

  // `dynamics` must outlive the corrector's use.
  void start(const MotorDynamics& dynamics, const BenchResponse& bench);
  // One step: the edge that carried its pulse and the centre of its force reading (seconds on
  // one clock), and the sample as read. True when `out` holds the step before it, corrected.
  bool push(float edge_s, float read_s, const SweepPointV2& raw, SweepPointV2& out);
  // The last step, corrected with the slope before it. False when no step is pending.
  bool finish(SweepPointV2& out);
  // Steps the last corrected reading trailed by (L), and the largest correction so far.
  float lastLagSteps() const { return last_lag_steps_; }
  int16_t largestCorrectionDg() const { return largest_dg_; }

 private:
  SweepPointV2 correct(const SweepPointV2& p, float lag_steps, float slope_dg);

  const MotorDynamics* dynamics_ = nullptr;
  BenchResponse bench_;
  float edges_[kEdges] = {};
  uint8_t edge_count_ = 0;  // edges seen (saturates)
  uint8_t pending_ = 0;     // steps seen, up to 2
  SweepPointV2 prev_ = {0, 0, 0};
  int16_t prev2_dg_ = 0;
  float prev_lag_ = 0.0f;
  float last_lag_steps_ = 0.0f;
  int16_t largest_dg_ = 0;
};

}  // namespace tc
