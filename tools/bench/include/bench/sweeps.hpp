// A calibration sweep as gather_store sees it, simulated on the plant's thesis bench without
// the firmware: per PWM step the ESC holds the pulse for settle_ms (or settles by measurement,
// as gather_store's settle auto does), then the load cell is read
// 201 times and the battery monitor 101 times through the plant's sensors (noise, ADC
// quantization), the medians are converted with core/'s LoadCell (tared before the sweep) and
// BatteryMonitor. What comes out is what gather_store streams: (pwm_us, force_dg, vbat_mv).
#pragma once
#include <cstdint>
#include <vector>

#include "plant/params.hpp"
#include "plant/power_source.hpp"
#include "thrustcal/dynamics.hpp"

namespace bench {

struct SweepSpec {
  int pwm_min_us = 1000;
  int pwm_max_us = 1800;
  int step_us = 10;
  int settle_ms = 200;      // per step; with settle_auto the cap
  uint64_t noise_seed = 1;  // load cell and battery monitor noise
  // gather_store's `settle auto` (its default sweep), the rule of thrustcal/sweep_rules.hpp:
  // force medians until it says the step has settled, settle_ms the cap.
  bool settle_auto = false;
  // gather_store's force reading with settle auto: the central mean (tc::kForceCentral of the
  // 201 readings, 1/16 count; tare too) instead of their median (the thesis's reading).
  bool fine_force = false;
  // A fixed-settle sweep corrected with the motor's measured dynamics and the bench's response
  // (tc::SweepLagCorrector, as gather_store corrects its own: issue 26 item 2). Ignored with
  // settle_auto or when the dynamics are not present.
  tc::MotorDynamics lag_dynamics;
  tc::BenchResponse lag_bench;
};

struct SweepPoint {
  uint16_t pwm_us;
  int16_t force_dg;  // tared load-cell reading, thrust positive
  uint16_t vbat_mv;  // battery monitor reading (sagged under load)
  double true_thrust_g;
  double true_bus_v;
};

struct Sweep {
  std::vector<SweepPoint> points;
  double largest_correction_g = 0;  // lag correction: the largest shift of a reading
  double rest_v = 0;  // source resting voltage before the sweep
  double simulated_s = 0;
};

// LiPo (3S) whose resting voltage is rest_v: state of charge from the OCV table.
plant::BatteryParams lipoAt(double rest_v);

Sweep simulateSweep(const plant::ActuatorParams& motor, const plant::BatteryParams& power,
                    const SweepSpec& spec);

// What read_run's battery monitor reads for a bus voltage: the divider, the 10-bit ADC and the
// thesis map() (no noise: the grids built on it are about the model, not about one noisy sample).
uint16_t monitorReading_mv(double bus_v);

}  // namespace bench
