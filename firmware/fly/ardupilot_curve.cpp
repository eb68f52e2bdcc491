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
  const float span_us = static_cast<float>(p_.pwm_max_us) - static_cast<float>(p_.pwm_min_us);
  p0_ = static_cast<float>(p_.pwm_min_us) + span_us * p_.spin_min;
  p1_ = span_us * (p_.spin_max - p_.spin_min);
  p0_x16_ = roundToInt32(p0_ * 16.0f);
  p_top_x16_ = roundToInt32((p0_ + p1_) * 16.0f);
  buildTable();
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

// Per battery reading (50 a second): lift_max and what the table's path needs. The float
// reference's constants are worked out here only when that path flies (an expo beyond
// kTableMaxExpo); otherwise pulseUs() works them out when it is called (tests, the reference):
// their four divisions were most of the reading's cost.
void ArduPilotCurve::derive() {
  const float v = ratio_filt_;
  const float e = expo_;
  lift_max_ = v * (1.0f - e) + e * v * v;
  const float battery_scale = isPositive(v) ? 1.0f / v : 1.0f;
  // pulseUsDg's: thrust 1 at full thrust x lift_max; pulse = p0 + p1 u / v (pulses in 1/16 us)
  max_force_dg_ = roundToInt32(p_.full_thrust_g * lift_max_ * kDgPerGram);
  pulse_per_u_ = gainOf(p1_ * battery_scale * (16.0f / 32768.0f));
  if (!table_ok_) float_path_ = floatPath();
}

ArduPilotCurve::FloatPath ArduPilotCurve::floatPath() const {
  const float v = ratio_filt_;
  const float e = expo_;
  const float gain = lift_max_ > 0 ? 1.0f / lift_max_ : 1.0f;  // get_compensation_gain()
  const float battery_scale = isPositive(v) ? 1.0f / v : 1.0f;
  FloatPath f;
  f.thrust_per_g = p_.full_thrust_g > 0 ? gain / p_.full_thrust_g : 0.0f;
  f.a = (1.0f - e) * (1.0f - e);
  f.b = 4.0f * e * lift_max_;
  f.c = e - 1.0f;
  f.d = isZero(e) ? 0.0f : battery_scale / (2.0f * e);
  f.lin = lift_max_ * battery_scale;
  return f;
}

// u for a force at full voltage: e u^2 + (1 - e) u = x, x = F / full thrust in 0..1, as
// 2 x / ((1 - e) + sqrt((1 - e)^2 + 4 e x)): no cancellation, whatever e.
float ArduPilotCurve::throttleAtFullVoltage(float force_g) const {
  const float x = clamp(force_g / p_.full_thrust_g, 0.0f, 1.0f);
  if (x <= 0.0f) return 0.0f;
  const float b = 1.0f - expo_;
  const float root = b * b + 4.0f * expo_ * x;
  return clamp(2.0f * x / (b + (root > 0 ? sqrtf(root) : 0.0f)), 0.0f, 1.0f);
}

// Nodes evenly spaced in sqrt(2 e u + 1 - e) (in u when e is near 0), each node's force rounded
// to a decigram and its u worked out again at that force, so a node is exact where it lies.
void ArduPilotCurve::buildTable() {
  table_ok_ = false;
  if (!ready()) return;
  const float e = expo_;
  const bool near_linear = fabsf(e) < 0.01f;
  const float w0 = sqrtf(1.0f - e), w1 = sqrtf(1.0f + e);
  for (uint8_t i = 0; i <= kTableSegments; ++i) {
    const float t = static_cast<float>(i) / kTableSegments;
    const float w = w0 + (w1 - w0) * t;
    const float u = near_linear ? t : clamp((w * w - (1.0f - e)) / (2.0f * e), 0.0f, 1.0f);
    Node& n = table_[i];
    n.force_dg = roundToInt32((e * u * u + (1.0f - e) * u) * p_.full_thrust_g * kDgPerGram);
    n.u_q15 = static_cast<uint16_t>(roundToInt32(throttleAtFullVoltage(gramsOf(n.force_dg)) * 32768.0f));
  }
  for (uint8_t i = 0; i < kTableSegments; ++i) {
    const int32_t df = table_[i + 1].force_dg - table_[i].force_dg;
    const float du = static_cast<float>(table_[i + 1].u_q15) - static_cast<float>(table_[i].u_q15);
    table_[i].slope = df > 0 ? gainOf(du / static_cast<float>(df)) : Gain();
  }
  table_[kTableSegments].slope = Gain();
  table_ok_ = fabsf(e) <= kTableMaxExpo;
}

// The table's worst error in pulse, at the lowest voltage ratio the parameters allow (the
// largest 1 / v), from three forces inside each segment: the tests' measure of kTableMaxExpo
// (too slow for the AVR to run on every parameter change: 120 float throttles).
float ArduPilotCurve::tableErrorUs() const {
  float worst_u = 0;
  for (uint8_t i = 0; i < kTableSegments; ++i) {
    const int32_t from = table_[i].force_dg, width = table_[i + 1].force_dg - from;
    for (int32_t k = 1; k <= 3; ++k) {
      const int32_t f = from + width * k / 4;
      uint8_t segment = i;
      const float u_table = tableThrottleQ15(f, segment) / 32768.0f;
      const float error = fabsf(u_table - throttleAtFullVoltage(gramsOf(f)));
      if (error > worst_u) worst_u = error;
    }
  }
  const bool scaled = p_.bat_volt_max_v > 0 && p_.bat_volt_min_v < p_.bat_volt_max_v;
  const float lowest_ratio = scaled ? vmin_v_ * inv_vmax_ : 1.0f;
  return worst_u * p1_ / lowest_ratio + 1.0f / 16.0f;  // + the pulse's own 1/16 us
}

int32_t ArduPilotCurve::tableThrottleQ15(ForceDg force_dg, uint8_t& segment) const {
  uint8_t lo = segment < kTableSegments ? segment : 0;
  if (!inSegment(lo, force_dg)) {
    if (lo + 1 < kTableSegments && inSegment(static_cast<uint8_t>(lo + 1), force_dg)) {
      ++lo;
    } else if (lo > 0 && inSegment(static_cast<uint8_t>(lo - 1), force_dg)) {
      --lo;
    } else {
      lo = 0;
      uint8_t hi = kTableSegments;  // table_[lo].force_dg <= force_dg < table_[hi].force_dg
      while (hi - lo > 1) {
        const uint8_t mid = static_cast<uint8_t>((lo + hi) / 2);
        if (table_[mid].force_dg <= force_dg) {
          lo = mid;
        } else {
          hi = mid;
        }
      }
    }
  }
  segment = lo;
  const Node& n = table_[lo];
  return n.u_q15 + applyGain(force_dg - n.force_dg, n.slope);
}

uint16_t ArduPilotCurve::pulseUsDg(ForceDg force_dg, uint8_t& segment) const {
  if (!table_ok_) return pulseUs(gramsOf(force_dg));
  const int32_t f = force_dg < 0 ? 0 : (force_dg > max_force_dg_ ? max_force_dg_ : force_dg);
  int32_t pulse_x16 = p0_x16_ + applyGain(tableThrottleQ15(f, segment), pulse_per_u_);
  if (pulse_x16 > p_top_x16_) pulse_x16 = p_top_x16_;  // y <= 1
  return pulse_x16 > 0 ? static_cast<uint16_t>(pulse_x16 >> 4) : 0;  // truncated, as output_to_pwm
}

uint16_t ArduPilotCurve::pulseUs(float force_g) const {
  const FloatPath f = table_ok_ ? floatPath() : float_path_;
  const float thrust = clamp(force_g * f.thrust_per_g, 0.0f, 1.0f);
  float y;
  if (isZero(expo_)) {
    y = f.lin * thrust;  // the code does not clamp this branch
  } else {
    const float root = f.a + f.b * thrust;
    y = clamp((f.c + (root > 0 ? sqrtf(root) : 0.0f)) * f.d, 0.0f, 1.0f);  // safe_sqrt
  }
  const float pulse = p0_ + p1_ * y;
  return pulse > 0 ? static_cast<uint16_t>(static_cast<int16_t>(pulse)) : 0;
}

}  // namespace fly
