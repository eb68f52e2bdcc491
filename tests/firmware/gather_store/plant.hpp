// A simple bench plant for gather_store host tests, wired into the fake HAL: the tick hook
// moves the thrust toward the ESC pulse's steady-state value (first order), the ADC source
// turns thrust and battery into counts on A0 and A1.
//
//   thrust_g(pwm) = full_g * (vbat / 12.6 V)^2 * ((pwm - 1080) / 720)^2   above 1080 us
//   A0 counts     = base_counts + thrust_g / g_per_count - extra_weight_g / g_per_count
//                   (+ spike_counts on every 4th conversion: a median must reject them)
//   A1            = (vbat - sag_v_at_full * thrust / full_g) * 47 / 147, in mV -> counts
#pragma once
#include <cmath>
#include <cstdint>

#include "hal/fake.hpp"
#include "hal/hal.hpp"

namespace gs_test {

struct Plant {
  uint8_t slot = 0;             // which ESC output drives this motor
  double full_g = 600.0;        // thrust at 1800 us and 12.6 V
  double vbat_v = 12.6;         // open-circuit battery
  double sag_v_at_full = 0.5;   // monitor reads this much lower at full_g
  double base_counts = 100.0;   // A0 with the motor mounted and stopped
  double g_per_count = 0.75;    // amplifier gain (thesis line: 0.75 g per count)
  double extra_weight_g = 0.0;  // weight lying on the plate (span calibration)
  double tau_ms = 30.0;         // thrust time constant
  uint16_t spike_counts = 300;  // added to every 4th A0 conversion; 0 = none

  double thrust_g = 0.0;        // state
  uint32_t a0_conversions = 0;

  static constexpr double kStartUs = 1080.0;
  static constexpr double kSpanUs = 720.0;

  double steadyThrust(double pwm_us) const {
    if (pwm_us <= kStartUs) return 0.0;
    const double x = (pwm_us - kStartUs) / kSpanUs;
    const double v = vbat_v / 12.6;
    return full_g * v * v * x * x;
  }
  // Inverse: the PWM that gives `grams` at steady state.
  double pwmFor(double grams) const {
    const double v = vbat_v / 12.6;
    return kStartUs + kSpanUs * std::sqrt(grams / (full_g * v * v));
  }
  void tick() {
    const double target = steadyThrust(hal::Esc::pulseUs(slot));
    thrust_g += (target - thrust_g) / tau_ms;
  }
  uint16_t adc(uint8_t channel) {
    if (channel == hal::kAdcLoadCell) {
      double counts = base_counts + (thrust_g - extra_weight_g) / g_per_count;
      if (spike_counts != 0 && (a0_conversions++ % 4) == 3) counts += spike_counts;
      if (counts < 0) counts = 0;
      if (counts > 1023) counts = 1023;
      return static_cast<uint16_t>(std::lround(counts));
    }
    if (channel == hal::kAdcBattery) {
      const double read_v = vbat_v - sag_v_at_full * thrust_g / full_g;
      const double pin_mv = read_v * 1000.0 * 47.0 / 147.0;
      return static_cast<uint16_t>(std::lround(pin_mv * 1023.0 / 5000.0));
    }
    return 0;
  }
  // Connects this plant to the fake HAL (the plant must outlive the connection).
  void attach() {
    hal::fake::setTickHook([this](uint32_t) { tick(); });
    hal::fake::setAdcSource([this](uint8_t ch) { return adc(ch); });
  }
};

}  // namespace gs_test
