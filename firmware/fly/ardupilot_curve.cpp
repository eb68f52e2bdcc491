// ArduPilot's thrust linearisation (ardupilot_curve.hpp).
#include "ardupilot_curve.hpp"

#include <float.h>
#include <math.h>

namespace fly {

namespace {
float clamp(float v, float lo, float hi) { return v < lo ? lo : (v > hi ? hi : v); }
// AP_Math: is_zero(x) is |x| < FLT_EPSILON, is_positive(x) x >= FLT_EPSILON.
bool isZero(float x) { return fabsf(x) < FLT_EPSILON; }
bool isPositive(float x) { return x >= FLT_EPSILON; }
}  // namespace

void ArduPilotCurve::setParams(const ArduPilotParams& p) {
  p_ = p;
  expo_ = clamp(p.expo, -1.0f, 1.0f);
  const float vmax = p.bat_volt_max_v;
  inv_vmax_ = vmax > 0 ? 1.0f / vmax : 0.0f;
  // batt_voltage_min is raised to 0.6 V_MAX (and stays so).
  vmin_v_ = p.bat_volt_min_v > 0.6f * vmax ? p.bat_volt_min_v : 0.6f * vmax;
  filter_set_ = false;
  ratio_filt_ = 1.0f;
  derive();
}

float ArduPilotCurve::ratioFor(float vbat_v) const {
  const float vmax = p_.bat_volt_max_v;
  if (!(vmax > 0) || p_.bat_volt_min_v >= vmax || vbat_v < 0.25f * vmin_v_) return 1.0f;
  return clamp(vbat_v, vmin_v_, vmax) * inv_vmax_;
}

void ArduPilotCurve::updateBattery(uint16_t vbat_mv, float dt_s) {
  const float ratio = ratioFor(vbat_mv * 0.001f);
  if (!filter_set_) {
    ratio_filt_ = ratio;
    filter_set_ = true;
  } else {
    if (dt_s != alpha_dt_s_) {  // LowPassFilter: alpha = dt / (dt + 1 / (2 pi fc))
      alpha_ = dt_s / (dt_s + 1.0f / (2.0f * 3.14159265f * kFilterHz));
      alpha_dt_s_ = dt_s;
    }
    ratio_filt_ += alpha_ * (ratio - ratio_filt_);
  }
  derive();
}

void ArduPilotCurve::derive() {
  const float v = ratio_filt_;
  const float e = expo_;
  lift_max_ = v * (1.0f - e) + e * v * v;
  const float gain = lift_max_ > 0 ? 1.0f / lift_max_ : 1.0f;  // get_compensation_gain()
  const float battery_scale = isPositive(v) ? 1.0f / v : 1.0f;
  thrust_per_g_ = p_.full_thrust_g > 0 ? gain / p_.full_thrust_g : 0.0f;
  a_ = (1.0f - e) * (1.0f - e);
  b_ = 4.0f * e * lift_max_;
  c_ = e - 1.0f;
  d_ = isZero(e) ? 0.0f : battery_scale / (2.0f * e);
  lin_ = lift_max_ * battery_scale;
  const float span_us = static_cast<float>(p_.pwm_max_us) - static_cast<float>(p_.pwm_min_us);
  p0_ = static_cast<float>(p_.pwm_min_us) + span_us * p_.spin_min;
  p1_ = span_us * (p_.spin_max - p_.spin_min);
}

uint16_t ArduPilotCurve::pulseUs(float force_g) const {
  const float thrust = clamp(force_g * thrust_per_g_, 0.0f, 1.0f);
  float y;
  if (isZero(expo_)) {
    y = lin_ * thrust;  // the code does not clamp this branch
  } else {
    const float root = a_ + b_ * thrust;
    y = clamp((c_ + (root > 0 ? sqrtf(root) : 0.0f)) * d_, 0.0f, 1.0f);  // safe_sqrt
  }
  const float pulse = p0_ + p1_ * y;
  return pulse > 0 ? static_cast<uint16_t>(static_cast<int16_t>(pulse)) : 0;
}

}  // namespace fly
