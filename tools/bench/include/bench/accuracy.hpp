// Benchmark 1, accuracy: four varied KV1100 + 9x4.7 motors (plant::makeVaried, fixed seeds),
// each swept on the simulated thesis bench as gather_store sees it (bench/sweeps.hpp) at two
// voltages (a LiPo resting at 12.4 V and a bench supply at 10.5 V). From the same sweeps:
//   uncalibrated  one PWM map for every motor: the nominal preset's steady-state curve at
//                 11.1 V, no voltage term (what a generic thrust table gives);
//   thesis 2.1    tc::CurveBuilder curves per sweep, tc::forceToPwm (option 2.1) with the sag
//                 offsets of the first sweep added to the reading, as read_run flies it;
//   ardupilot     thrust = (1 - e) u + e u^2 (MOT_THST_EXPO e), u = a V / V_max, a the
//                 throttle between spin-min and spin-max; spin-min, e and the lift at V_max
//                 fitted per motor to both sweeps by weighted least squares (relative error);
//   v2            tc::ModelV2Fitter: fit on the first sweep, refine with the second.
// Then each motor runs in steady state (plant::Actuator::steadyState) on a grid of commands
// and bus voltages; every model is given the battery monitor's reading of that voltage
// (ADC-quantized) and its PWM is applied; the error is (thrust - command) / command.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/sweeps.hpp"

namespace bench {

struct AccuracyConfig {
  std::string preset = "kv1100_9x4.7";
  std::vector<uint64_t> seeds = {11, 12, 13, 14};
  double variation = 0.03;
  double v_min = 9.9, v_max = 12.6, v_step = 0.1;     // bus voltage grid, V
  int force_min_g = 100, force_max_g = 450, force_step_g = 25;
  double cal_high_v = 12.4;  // first sweep: LiPo resting at this voltage
  double cal_low_v = 10.5;   // second sweep: bench supply (6.32 A limit) at this voltage
  double nominal_v = 11.1;   // the uncalibrated map's voltage
  // 600 ms per step: the readings settle (motor ~0.08 s + the load cell's 3 x 30 ms filter)
  // to within 0.3 %; the thesis's 200 ms lag by most of a step (see benchmark 4 and the
  // accuracy table's "200 ms sweeps" rows).
  SweepSpec sweep = SweepSpec{1000, 1800, 10, 600, 1};
};

struct ErrorStats {
  double rms_pct = 0, max_pct = 0;  // of |thrust - command| / command
  int points = 0;
  nlohmann::json toJson() const;
};

struct ModelAccuracy {
  std::string key;          // "uncalibrated", "thesis_2_1", "ardupilot", "v2"
  std::string name;
  ErrorStats all;           // the whole grid
  ErrorStats inside;        // cal_low_v <= V <= cal_high_v
  ErrorStats outside;       // V outside the two calibration voltages
  std::vector<std::pair<double, ErrorStats>> by_voltage;  // per grid voltage, all motors
  double mean_pct = 0;      // signed mean over the grid (bias)
};

// ArduPilot-style expo thrust model with voltage scaling, in physical units:
//   thrust_g = c1 x + c2 x^2,  x = (pwm - spin_min_us) * V   [us*V]
// which is (1 - e) u + e u^2 scaled by the lift at V_max with u = (pwm - spin_min) V /
// ((spin_max - spin_min) V_max); expo() and liftMax_g() give ArduPilot's parameters.
struct ExpoModel {
  double spin_min_us = 1100;
  double c1 = 0, c2 = 0;
  double spin_max_us = 1950;  // MOT_SPIN_MAX 0.95 of 1000-2000 us
  double v_max = 12.6;        // MOT_BAT_VOLT_MAX
  double rms_fit_pct = 0;     // relative RMS residual of the fit
  double liftMax_g() const;
  double expo() const;
  double thrust_g(double pwm_us, double bus_v) const;
  double pwmFor_us(double force_g, double bus_v) const;  // exact inverse, clamped 1000..2000
};
// Least squares over spin-min (search) and c1, c2 (linear, Eigen), rows weighted by 1/force so
// the residual is relative; samples between 10 g and 600 g. Throws std::runtime_error when
// fewer than 6 samples qualify.
ExpoModel fitExpo(const std::vector<SweepPoint>& points);

struct MotorSummary {
  uint64_t seed = 0;
  std::string fit_v2;          // fit/refine status text
  double v2_start_us = 0;
  double expo = 0, expo_spin_min_us = 0, expo_lift_max_g = 0, expo_fit_rms_pct = 0;
  double sweep_high_rest_v = 0, sweep_low_rest_v = 0;
  int sweep_samples = 0;
  // the sweep's force readings against the plant's true thrust at the end of each step
  // (settling lag, noise, quantization), RMS in % over samples of 50-600 g (the amplifier
  // clips near 640 g)
  double sweep_reading_error_rms_pct = 0;
  double sweep_reading_bias_pct = 0;  // mean of the same
};

struct AccuracyResult {
  AccuracyConfig config;
  std::vector<ModelAccuracy> models;  // in the order above
  std::vector<MotorSummary> motors;
  const ModelAccuracy& model(const std::string& key) const;  // throws if unknown
  nlohmann::json toJson() const;
};

// Deterministic. Throws std::runtime_error when a fit fails (the message names motor and fit).
AccuracyResult runAccuracy(const AccuracyConfig& config = AccuracyConfig());

}  // namespace bench
