// Test support: a physically faithful motor + bench, and sweeps recorded the way gather_store
// records them. Host only.
//
// Thrust follows the mean winding voltage: F = k * (duty * V_bus)^a, duty = (pwm - start) /
// span (a DC motor turning a propeller settles at a speed set by duty * V; thrust ~ speed^2
// with a Reynolds-number correction, hence a = 1.6..2). k is set so that full throttle at
// 9.9 V gives `full_at_9v9_g`. The bench source sags: V_bus = V_rest - R * I with
// I = i_500g_a * (F / 500 g)^1.5 (power ~ speed^3, current ~ power / V). The recorded force
// is quantized like the thesis load cell (0.75 g per ADC count after the median) and the
// recorded voltage like the 100k/47k monitor (15.638 V / 1023 per count).
#pragma once
#include <stdint.h>

#include <cmath>
#include <vector>

#include "thrustcal/model_v2.hpp"

namespace tc_test {

struct SyntheticMotor {
  double start_us = 1097.0;
  double span_us = 903.0;
  double exponent = 1.8;
  double full_at_9v9_g = 600.0;
  double source_r_ohm = 0.0;  // bench sag; 0 = stiff source
  double i_500g_a = 6.4;
  double current_limit_a = 0.0;  // bench supply current limit (thesis: 6.32 A); 0 = none

  double k() const { return full_at_9v9_g / std::pow(9.9, exponent); }

  // Steady thrust at a PWM and the bus voltage the motor sees.
  double forceG(double pwm_us, double vbus_v) const {
    if (pwm_us <= start_us) return 0.0;
    double duty = (pwm_us - start_us) / span_us;
    if (duty > 1.0) duty = 1.0;
    return k() * std::pow(duty * vbus_v, exponent);
  }

  double currentA(double force_g) const { return i_500g_a * std::pow(force_g / 500.0, 1.5); }

  // Bench operating point at a PWM from a resting source voltage: V = V_rest - R * I(F(V)).
  // A current-limited supply folds its voltage back so that I stays at the limit: the force
  // plateaus there while the recorded voltage collapses.
  void operatingPoint(double pwm_us, double rest_v, double& force_g, double& vbus_v) const {
    vbus_v = rest_v;
    for (int i = 0; i < 60; ++i) {
      force_g = forceG(pwm_us, vbus_v);
      vbus_v = rest_v - source_r_ohm * currentA(force_g);
    }
    force_g = forceG(pwm_us, vbus_v);
    if (current_limit_a > 0.0 && currentA(force_g) > current_limit_a) {
      force_g = 500.0 * std::pow(current_limit_a / i_500g_a, 2.0 / 3.0);
      vbus_v = std::pow(force_g / k(), 1.0 / exponent) * span_us / (pwm_us - start_us);
    }
  }

  // The PWM that truly gives `force_g` at `vbus_v` (for the ideal, continuous ESC).
  double truePwmUs(double force_g, double vbus_v) const {
    const double drive = std::pow(force_g / k(), 1.0 / exponent);
    return start_us + span_us * drive / vbus_v;
  }
};

struct Recording {
  bool quantize = true;   // load cell counts and monitor counts as on the thesis hardware
  double force_noise_g = 0.0;  // extra uniform noise, +-
  uint32_t seed = 12345;
};

inline double uniformPm1(uint32_t& state) {  // deterministic LCG, -1..1
  state = state * 1664525u + 1013904223u;
  return static_cast<double>(state >> 8) / static_cast<double>(1u << 23) - 1.0;
}

inline int16_t recordForceDg(double force_g, const Recording& rec, uint32_t& state) {
  double f = force_g + rec.force_noise_g * uniformPm1(state);
  if (rec.quantize) f = std::round(f / 0.75) * 0.75;  // thesis: 0.75 g per count
  return static_cast<int16_t>(std::lround(f * 10.0));
}

inline uint16_t recordMillivolts(double v, const Recording& rec) {
  if (!rec.quantize) return static_cast<uint16_t>(std::lround(v * 1000.0));
  const long counts = std::lround(v * 1023.0 / 15.638);
  return static_cast<uint16_t>(std::lround(counts * 15638.0 / 1023.0));
}

// One sweep, 1000..2000 us in `step_us` steps, fed into a fitter.
template <class Fitter>
void recordSweep(const SyntheticMotor& motor, double rest_v, Fitter& fitter, const Recording& rec,
                 uint16_t step_us = 10) {
  uint32_t state = rec.seed;
  fitter.reset();
  for (uint32_t pwm = 1000; pwm <= 2000; pwm += step_us) {
    double f = 0, v = 0;
    motor.operatingPoint(pwm, rest_v, f, v);
    fitter.add(static_cast<uint16_t>(pwm), recordForceDg(f, rec, state), recordMillivolts(v, rec));
  }
}

// The v2 model of a motor from one sweep at rest_v (empty model if the fit fails).
inline tc::ModelV2 fittedModel(const SyntheticMotor& motor, double rest_v,
                               const Recording& rec = Recording()) {
  static tc::ModelV2Fitter<128> fitter;  // 1 KB: not on the test's stack
  recordSweep(motor, rest_v, fitter, rec);
  tc::ModelV2 model;
  fitter.fit(model);
  return model;
}

// Force error of a controller over a grid of commands and bus voltages, in percent of the
// command. `pwm_for(force_g, vbus_mv)` returns the PWM the controller sends.
struct GridError {
  double rms_pct = 0.0;
  double max_pct = 0.0;
  int points = 0;
};

template <class PwmFor>
GridError gridError(const SyntheticMotor& motor, PwmFor pwm_for, double v_lo, double v_hi,
                    double f_lo = 100.0, double f_hi = 450.0, bool (*include)(double) = nullptr) {
  GridError g;
  double sum_sq = 0.0;
  for (int vi = 0;; ++vi) {
    const double v = v_lo + 0.1 * vi;
    if (v > v_hi + 1e-9) break;
    if (include && !include(v)) continue;
    for (double f = f_lo; f <= f_hi + 1e-9; f += 25.0) {
      const uint16_t mv = static_cast<uint16_t>(std::lround(v * 1000.0));
      const double truth = motor.forceG(pwm_for(f, mv), v);
      const double e = 100.0 * (truth - f) / f;
      sum_sq += e * e;
      g.max_pct = std::fmax(g.max_pct, std::fabs(e));
      ++g.points;
    }
  }
  g.rms_pct = g.points ? std::sqrt(sum_sq / g.points) : 0.0;
  return g;
}

}  // namespace tc_test
