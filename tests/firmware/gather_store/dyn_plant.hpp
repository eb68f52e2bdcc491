// A bench plant with dynamics for gather_store's dyn tests (fake HAL): the ESC takes a pulse at
// the falling edge of the frame after it was written, the motor's speed follows it as a
// first-order lag (spin-up and spin-down time constants of their own), thrust = speed^2, and the
// load cell passes the net force through `stages` equal continuous low-pass stages. Each ADC
// conversion takes 104 us of fake time (hal::fake::setAdcConversionUs) and reads the cell with a
// little dither (a deterministic +-1 count), as a real cell's noise dithers its quantisation.
//
//   steady thrust = full_g * (vbat / 12.6 V)^2 * ((pulse - 1080) / 720)^2 above 1080 us
//   A0 counts     = base_counts + (filtered thrust - weight) / g_per_count
#pragma once
#include <cmath>
#include <cstdint>

#include "hal/fake.hpp"
#include "hal/hal.hpp"

namespace gs_test {

struct DynPlant {
  uint8_t slot = 0;
  double full_g = 500.0, vbat_v = 12.6;
  double base_counts = 150.0, g_per_count = 0.75;
  double tau_up_s = 0.080, tau_down_s = 0.095;  // the motor's speed
  int stages = 3;
  double stage_tau_s = 0.030;                   // the load cell's low-pass
  double weight_g = 0.0;                        // on the plate (dyn cell lifts it off)
  uint32_t lift_weight_at_ms = 0;               // 0: never

  double applied_us = 1000.0, latched_us = 1000.0;
  double speed = 0.0;  // sqrt(g)
  double stage[4] = {};
  uint32_t now_ms = 0, conversions = 0;

  static double steady(double pulse_us, double vbat_v, double full_g) {
    if (pulse_us <= 1080.0) return 0.0;
    const double x = (pulse_us - 1080.0) / 720.0, v = vbat_v / 12.6;
    return full_g * v * v * x * x;
  }
  void tick(uint32_t t_ms) {
    now_ms = t_ms;
    const uint32_t frame_ms = 20;
    if (t_ms % frame_ms == 0) latched_us = hal::Esc::pulseUs(slot);  // the frame starts
    if (t_ms % frame_ms == static_cast<uint32_t>(std::ceil(latched_us / 1000.0))) applied_us = latched_us;
    if (lift_weight_at_ms != 0 && t_ms == lift_weight_at_ms) weight_g = 0.0;
    const double target = std::sqrt(steady(applied_us, vbat_v, full_g));
    const double tau = target > speed ? tau_up_s : tau_down_s;
    speed += (target - speed) * (1.0 - std::exp(-0.001 / tau));
    const double in = speed * speed - weight_g;
    for (int k = 0; k < 8; ++k) {
      double u = in;
      for (int i = 0; i < stages; ++i) {
        stage[i] += (u - stage[i]) * (1.0 - std::exp(-0.000125 / stage_tau_s));
        u = stage[i];
      }
    }
  }
  uint16_t adc(uint8_t channel) {
    if (channel == hal::kAdcLoadCell) {
      const double dither = static_cast<double>((conversions++ * 2654435761u) >> 30) / 2.0 - 0.75;
      const double counts = base_counts + stage[stages - 1] / g_per_count + dither;
      return static_cast<uint16_t>(std::lround(std::fmin(1023.0, std::fmax(0.0, counts))));
    }
    if (channel == hal::kAdcBattery) return static_cast<uint16_t>(std::lround(vbat_v * 1000.0 * 47.0 / 147.0 * 1023.0 / 5000.0));
    return 0;
  }
  void attach() {
    hal::fake::setAdcConversionUs(104);
    hal::fake::setTickHook([this](uint32_t t) { tick(t); });
    hal::fake::setAdcSource([this](uint8_t ch) { return adc(ch); });
  }
  // The load cell settled on the present weight (the filter starts where it would rest).
  void settle() {
    for (int i = 0; i < stages; ++i) stage[i] = speed * speed - weight_g;
  }
};

}  // namespace gs_test
