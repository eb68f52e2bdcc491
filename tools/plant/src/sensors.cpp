#include "plant/sensors.hpp"

#include <algorithm>
#include <cmath>

namespace plant {

int adcCountsFromMillivolts(double mv) {
  const long whole_mv = std::lround(std::max(0.0, mv));
  const long counts = whole_mv * kAdcMaxCounts / static_cast<long>(kAdcRef_mv);
  return static_cast<int>(std::clamp(counts, 0L, static_cast<long>(kAdcMaxCounts)));
}

double LoadCellParams::idealMillivolts(double down_g) const {
  return offset_mv - millivoltsPerGram() * down_g;
}

LoadCellSensor::LoadCellSensor(const LoadCellParams& params) : p_(params), rng_(params.seed) {
  p_.order = std::clamp(p_.order, 0, 3);
  settle(0.0);
}

void LoadCellSensor::settle(double down_g) {
  const double v = std::clamp(p_.idealMillivolts(down_g + p_.plate_g), p_.out_min_mv, p_.out_max_mv);
  stage_mv_.fill(v);
}

void LoadCellSensor::step(double dt_s, double down_g, double thrust_g) {
  thrust_g_ = thrust_g;
  // The amplifier clips before the filter.
  const double in = std::clamp(p_.idealMillivolts(down_g + p_.plate_g), p_.out_min_mv, p_.out_max_mv);
  if (p_.order == 0) {
    stage_mv_[0] = in;
    return;
  }
  // The RC stages are continuous: sub-steps of at most kSubStepS, each stage exact for its input
  // held at the mean of its start and end values (second order: no lead or lag of its own, so a
  // step reaches the ADC as the analog cascade passes it, whatever the caller's step).
  constexpr double kSubStepS = 125e-6;
  const int subs = std::max(1, static_cast<int>(std::ceil(dt_s / kSubStepS - 1e-9)));
  const double h = dt_s / subs;
  if (h != gain_h_s_) {
    for (int i = 0; i < p_.order; ++i)
      gain_[i] = p_.lowpass_tau_s[i] > 0.0 ? 1.0 - std::exp(-h / p_.lowpass_tau_s[i]) : 1.0;
    gain_h_s_ = h;
  }
  for (int k = 0; k < subs; ++k) {
    double v_old = in, v_new = in;
    for (int i = 0; i < p_.order; ++i) {
      const double old = stage_mv_[i];
      stage_mv_[i] += (0.5 * (v_old + v_new) - old) * gain_[i];
      v_old = old;
      v_new = stage_mv_[i];
    }
  }
}

double LoadCellSensor::filteredMillivolts() const {
  return p_.order == 0 ? stage_mv_[0] : stage_mv_[p_.order - 1];
}

double LoadCellSensor::adcMillivolts() {
  double v = filteredMillivolts();
  if (p_.noise_mv > 0.0) v += rng_.normal(p_.noise_mv, 5.0);
  if (p_.vibration_frac > 0.0) {
    v += rng_.normal(p_.vibration_frac * std::fabs(thrust_g_) * p_.millivoltsPerGram(), 5.0);
  }
  return std::clamp(v, 0.0, kAdcRef_mv);
}

BatterySensor::BatterySensor(const BatterySensorParams& params) : p_(params), rng_(params.seed) {}

void BatterySensor::settle(double sensed_v) { pin_mv_ = sensed_v * 1000.0 * p_.ratio(); }

void BatterySensor::step(double dt_s, double sensed_v) {
  const double target = sensed_v * 1000.0 * p_.ratio();
  pin_mv_ = p_.tau_s > 0.0 ? pin_mv_ + (target - pin_mv_) * dt_s / (p_.tau_s + dt_s) : target;
}

double BatterySensor::adcMillivolts() {
  double v = pin_mv_;
  if (p_.noise_mv > 0.0) v += rng_.normal(p_.noise_mv, 5.0);
  return std::clamp(v, 0.0, kAdcRef_mv);
}

}  // namespace plant
