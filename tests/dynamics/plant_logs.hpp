// Step logs as gather_store records them, made on the plant on the host (no simulator): the
// bench (plant::Bench) stepped every millisecond, the load cell converted every kConversionS
// into blocks of tc::kDynBlockConversions, the ESC fed 50 Hz frames. For the identification
// tests; the bench's simulated sessions use the real firmware instead.
#pragma once
#include <cstdint>
#include <utility>
#include <vector>

#include "plant/bench.hpp"
#include "thrustcal/dynamics_fit.hpp"
#include "thrustcal/battery_monitor.hpp"
#include "thrustcal/load_cell.hpp"

namespace dyntest {

constexpr double kConversionS = 108e-6;  // 13 ADC clocks at 125 kHz and the loop around them
constexpr double kFrameS = 0.02;         // gather_store's 50 Hz ESC frames

// Per block: the load cell's conversions, then one of the battery monitor.
constexpr int kBlockConversions = tc::kDynBlockConversions + 1;

struct LoggedStep {
  std::vector<int16_t> force_dg;
  std::vector<uint16_t> vbat_mv;
  uint16_t from_us = 0, to_us = 0;
  float start_us = 0;  // 0: no voltage log in log()
  tc::StepLog log() const {
    tc::StepLog l;
    l.force_dg = force_dg.data();
    l.blocks = static_cast<uint16_t>(force_dg.size());
    l.block_s = static_cast<float>(kConversionS * kBlockConversions);
    l.step_s = static_cast<float>(step_s);
    if (start_us > 0) {
      l.vbat_mv = vbat_mv.data();
      l.from_us = from_us;
      l.to_us = to_us;
      l.start_us = start_us;
    }
    return l;
  }
  double step_s = 0;
  double bus_v = 0;  // mean bus voltage over the log
};

// Drives the bench's ESC with `pulse_us` frames, converting the load cell, until t_end.
class BenchDriver {
 public:
  explicit BenchDriver(plant::Bench& bench) : bench_(bench) { cell_.tare(bench_.readCounts(0)); }
  void setPulse(double pulse_us) { pulse_us_ = pulse_us; }
  // Runs for `seconds` without logging.
  void run(double seconds) { advance(bench_.time_s() + seconds, nullptr); }
  // Logs `pre_s`, then calls `at_step()` (which changes the pulse or the weights), then logs
  // `post_s`. step_s: the ESC edge that carried the new pulse (or the instant at_step ran).
  template <class F>
  LoggedStep logStep(double pre_s, double post_s, F at_step, bool edge_timed);
  tc::LoadCell& cell() { return cell_; }

 private:
  void advance(double until_s, LoggedStep* out);
  plant::Bench& bench_;
  tc::LoadCell cell_;
  double pulse_us_ = 1000;
  double next_frame_s_ = 0;
  std::vector<std::pair<double, double>> edges_;  // (width us, falling edge s) not yet seen
  double next_conv_s_ = 0;
  double log_start_s_ = 0;
  int32_t block_sum_ = 0;
  int block_n_ = 0;
  uint32_t vbat_sum_ = 0;
  int vbat_n_ = 0;
  tc::BatteryMonitor monitor_;
  double v_sum_ = 0;
  int v_n_ = 0;
};

inline void BenchDriver::advance(double until_s, LoggedStep* out) {
  while (bench_.time_s() < until_s - 1e-9) {
    const double t0 = bench_.time_s(), t1 = t0 + 0.001;
    while (next_frame_s_ < t1) {  // a frame starts: its width is latched, its edge to come
      edges_.push_back({pulse_us_, next_frame_s_ + pulse_us_ * 1e-6});
      next_frame_s_ += kFrameS;
    }
    // The ESC takes a pulse at its falling edge; the plant, stepped in whole milliseconds, from
    // the step that contains it (as the simulated board delivers it).
    while (!edges_.empty() && edges_.front().second < t1) {
      bench_.setPulse(edges_.front().first, edges_.front().second);
      edges_.erase(edges_.begin());
    }
    bench_.step(0.001);
    while (next_conv_s_ < t1) {
      next_conv_s_ += kConversionS;
      if (out == nullptr) continue;
      if (block_n_ == tc::kDynBlockConversions) {  // the battery's conversion ends the block
        vbat_sum_ += bench_.readCounts(1);
        if (++vbat_n_ == tc::kDynBlocksPerVbat) {
          out->vbat_mv.push_back(monitor_.millivoltsFromCounts(static_cast<uint16_t>((vbat_sum_ + 2) / 4)));
          vbat_sum_ = 0, vbat_n_ = 0;
        }
        const int32_t mg = cell_.forceMilligramsQ4(static_cast<uint16_t>(block_sum_));
        out->force_dg.push_back(static_cast<int16_t>((mg + (mg >= 0 ? 50 : -50)) / 100));
        block_sum_ = 0;
        block_n_ = 0;
        continue;
      }
      block_sum_ += bench_.readCounts(0);
      ++block_n_;
    }
    if (out) v_sum_ += bench_.busVoltage_v(), ++v_n_;
  }
}

template <class F>
LoggedStep BenchDriver::logStep(double pre_s, double post_s, F at_step, bool edge_timed) {
  LoggedStep step;
  next_conv_s_ = bench_.time_s();
  log_start_s_ = next_conv_s_;
  block_sum_ = 0, block_n_ = 0, v_sum_ = 0, v_n_ = 0, vbat_sum_ = 0, vbat_n_ = 0;
  step.from_us = static_cast<uint16_t>(pulse_us_);
  advance(log_start_s_ + pre_s, &step);
  at_step();
  // The new pulse rides the next frame: its falling edge is where the ESC takes it.
  const double edge = next_frame_s_ + pulse_us_ * 1e-6;
  step.step_s = (edge_timed ? edge : bench_.time_s()) - log_start_s_;
  step.to_us = static_cast<uint16_t>(pulse_us_);
  advance(log_start_s_ + pre_s + post_s, &step);
  step.bus_v = v_n_ ? v_sum_ / v_n_ : 0;
  return step;
}

}  // namespace dyntest
