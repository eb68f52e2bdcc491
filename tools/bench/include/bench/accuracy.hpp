// Benchmark 1, accuracy: four varied KV1100 + 9x4.7 motors (plant::makeVaried, fixed seeds),
// each swept on the simulated thesis bench as gather_store sees it (bench/sweeps.hpp) at two
// voltages (a LiPo resting at 12.4 V and a bench supply at 10.5 V). From the same sweeps:
//   uncalibrated  one PWM map for every motor: the nominal preset's steady-state curve at
//                 11.1 V, no voltage term (what a generic thrust table gives);
//   thesis 2.1    tc::CurveBuilder curves per sweep, tc::forceToPwm (option 2.1) with the sag
//                 offsets of the first sweep added to the reading, as read_run flies it;
//   ardupilot     ArduPilot's own thrust model (lab/autopilot.hpp): thrust = (1 - e) y + e y^2,
//                 y = t V / V_max, t the throttle between spin-min and spin-max; spin-min, e and
//                 the full thrust fitted per motor to both sweeps (relative error);
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
#include "plant/dynamics_record.hpp"
#include "lab/autopilot.hpp"

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
  // 600 ms per step: long enough for the motor's time constant and the load cell's 3 x 30 ms
  // filter to settle; the thesis's 200 ms are not (benchmark 4 and the accuracy table's
  // "200 ms sweeps" rows).
  SweepSpec sweep = [] {
    SweepSpec s;
    s.settle_ms = 600;
    return s;
  }();
  // Fixed-settle sweeps corrected with each motor's dynamics (issue 26 item 2): the law through
  // the plant's own time constants at dyn's five operating points (bench dynamics shows dyn
  // measures them within a few percent), every time constant scaled by lag_tau_scale (1.05: a
  // measurement 5 % off), and the thesis load cell's three stages.
  bool lag_correction = false;
  double lag_tau_scale = 1.0;
};

// The dynamics gather_store's dyn would store for this motor, from the plant's own time
// constants (plant::stepTimeConstant_s) at 20..80 % of its force, each scaled by `scale`.
inline tc::MotorDynamics plantDynamics(const plant::ActuatorParams& motor, double scale = 1.0) {
  return plant::recordDynamics(motor, scale);
}

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

// ArduPilot's thrust model, computed by the one implementation the lab's `export --to
// ardupilot` also uses (lab/autopilot.hpp: AP_Motors_Thrust_Linearization's forward function,
// clamps and PWM truncation included): MOT_THST_EXPO and MOT_SPIN_MIN fitted, MOT_SPIN_MAX 0.95,
// MOT_PWM 1000..2000, voltage compensation for a 3S pack (MOT_BAT_VOLT_MAX 12.6 V, MIN 9.9 V).
struct ExpoModel {
  lab::autopilot::ArduPilotParams params;
  double full_g = 0;       // the force at MOT_SPIN_MAX on a full battery (V >= MOT_BAT_VOLT_MAX)
  double rms_fit_pct = 0;  // relative RMS residual of the fit
  double spinMin_us() const;
  double liftMax_g() const { return full_g; }
  double expo() const { return params.thst_expo; }
  double thrust_g(double pwm_us, double bus_v) const;
  // The PWM ArduPilot sends for this force at this voltage (its own int16 truncation).
  double pwmFor_us(double force_g, double bus_v) const;
};
// lab::autopilot::fitArduPilot on the samples between 10 g and 600 g, weighted 1 / force^2 so
// the residual is relative. Throws std::runtime_error when fewer than 6 samples qualify.
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
