// Analog front ends of the bench, as seen by the ATmega2560's 10-bit ADC (5 V reference).
//
// ADC convention (same as simavr 1.6): counts = floor(round(mV) * 1023 / 5000), clamped to
// 0..1023. The simulator injects adcMillivolts() (rounded to whole millivolts) into simavr,
// the model lab can use readCounts(); both agree exactly.
#pragma once
#include <array>
#include <cstdint>
#include "plant/random.hpp"

namespace plant {

constexpr double kAdcRef_mv = 5000.0;
constexpr int kAdcMaxCounts = 1023;
// floor(round(mv) * 1023 / 5000), clamped to 0..1023 (what simavr 1.6 does with injected mV).
int adcCountsFromMillivolts(double mv);

// Load cell (Vetek 1 kg single point, 1 mV/V) + INA125P + RC low-pass on A0.
// Pin voltage: v = offset_mv - gain * excitation_v * sensitivity_mv_per_v * (F_down_g / 1000)
// where F_down_g is everything pressing the plate down (plate + motor/prop + calibration
// weights - thrust). Weight lowers the reading, thrust raises it. The defaults reproduce the
// thesis line  line_g = 0.75 * counts - 156 = -F_down_g  (gain 1303.4, offset 1016.6 mV =
// 208 counts), and the INA125P output saturates at 4250 mV = 869 counts (thesis: "870 values,
// 650 g maximum"), so with the 60 g plate and a 81 g motor+prop the highest readable thrust is
// about 640 g; at 0 mV it clips (weight above 156 g with no thrust).
// Low-pass: `order` cascaded first-order stages (buffered), time constants lowpass_tau_s[i],
//   continuous (integrated in sub-steps of 125 us whatever the caller's step: a force step
//   reaches the ADC as the analog cascade passes it).
//   The thesis's 3rd-order RC (470k/1uF, 100k/2.2uF, 22k/10uF) as a loaded ladder would have an
//   Elmore delay of several seconds, which contradicts its observation that 200 ms per PWM step
//   settled; the default is three 30 ms stages (90 ms delay, settled to 0.1 % in ~0.5 s).
// Noise: electrical Gaussian noise_mv at the pin per sample, plus vibration: Gaussian with sigma
// vibration_frac * |thrust| grams per sample (propeller imbalance), both seeded.
struct LoadCellParams {
  double excitation_v = 5.0;
  double sensitivity_mv_per_v = 1.0;  // at capacity_g
  double capacity_g = 1000.0;
  double gain = 1303.37;               // INA125P: 4 + 60k / R_G
  double offset_mv = 1016.62;          // output with nothing on the cell (offset resistor)
  double out_min_mv = 0.0;
  double out_max_mv = 4250.0;
  double plate_g = 60.0;               // perpendicular plate (thesis 60 g)
  int order = 3;                       // 0 (no filter) .. 3
  std::array<double, 3> lowpass_tau_s = {0.03, 0.03, 0.03};
  double noise_mv = 2.0;
  double vibration_frac = 0.004;
  uint64_t seed = 1;

  // Ideal (no noise, no filter, no clipping) pin voltage for a downward load.
  double idealMillivolts(double down_g) const;
  double millivoltsPerGram() const { return gain * excitation_v * sensitivity_mv_per_v / capacity_g; }
};

class LoadCellSensor {
 public:
  explicit LoadCellSensor(const LoadCellParams& params = LoadCellParams());
  // Advance the low-pass by dt_s with down_g pressing on the plate (plate weight excluded: the
  // sensor adds plate_g itself) and thrust_g lifting it (thrust only sets vibration noise).
  void step(double dt_s, double down_g, double thrust_g);
  // Set the filter to steady state for this load (e.g. at power-up).
  void settle(double down_g);
  // One ADC sample: filtered voltage + noise, clipped to the amplifier range. Draws noise.
  double adcMillivolts();
  int readCounts() { return adcCountsFromMillivolts(adcMillivolts()); }
  // Filtered pin voltage without noise (for plots and tests).
  double filteredMillivolts() const;
  const LoadCellParams& params() const { return p_; }

 private:
  LoadCellParams p_;
  Rng rng_;
  std::array<double, 3> stage_mv_{};
  std::array<double, 3> gain_{};  // each stage's exact gain for a sub-step of gain_h_s_
  double gain_h_s_ = -1.0;
  double thrust_g_ = 0.0;
};

// Battery monitor on A1: 100k / 47k divider from the ESC / distribution point (so it sees the
// pack's internal-resistance and wiring drop under load: thesis 11.35 V resting read as 10.8 V
// at high throttle), then the ADC. Full scale (R1+R2)/R2 * 5 V = 15.638 V. Optional
// first-order filter (tau 0 = none), Gaussian noise_mv at the pin per sample.
struct BatterySensorParams {
  double r_top_ohm = 100e3;
  double r_bottom_ohm = 47e3;
  double divider_tolerance = 0.0;  // relative error of the ratio (e.g. 0.01 for 1 % parts)
  double tau_s = 0.0;
  double noise_mv = 1.5;
  uint64_t seed = 2;
  double ratio() const { return r_bottom_ohm / (r_top_ohm + r_bottom_ohm) * (1.0 + divider_tolerance); }
};

class BatterySensor {
 public:
  explicit BatterySensor(const BatterySensorParams& params = BatterySensorParams());
  void step(double dt_s, double sensed_v);
  void settle(double sensed_v);
  double adcMillivolts();  // draws noise; clipped to 0..5000
  int readCounts() { return adcCountsFromMillivolts(adcMillivolts()); }
  double filteredMillivolts() const { return pin_mv_; }
  const BatterySensorParams& params() const { return p_; }

 private:
  BatterySensorParams p_;
  Rng rng_;
  double pin_mv_ = 0.0;
};

}  // namespace plant
