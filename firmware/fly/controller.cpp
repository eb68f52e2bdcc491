// The attitude controller (controller.hpp).
#include "controller.hpp"

namespace fly {

namespace {
float clampSym(float v, float limit) { return v > limit ? limit : (v < -limit ? -limit : v); }
}  // namespace

SetpointQ fixedSetpoint(const Setpoint& sp) {
  SetpointQ q;
  q.roll = angleUnits(sp.roll_rad);
  q.pitch = angleUnits(sp.pitch_rad);
  q.yaw_rate = roundToInt32(sp.yaw_rate_rad_s * (1.0f / kRadPerRateUnit));
  return q;
}

void AttitudeController::reset() {
  for (float& i : integral_nm_) i = 0;
  has_integral_ = false;
}

void AttitudeController::scale() {
  kp_xy_ = gainOf(rp_.kp_nm_per_rad * q4_per_nm_xy_ * kRadPerAngleUnit);
  kd_xy_ = gainOf(rp_.kd_nm_s_per_rad * q4_per_nm_xy_ * kRadPerRateUnit);
  kp_z_ = gainOf(yaw_.kp_nm_s_per_rad * q4_per_nm_z_ * kRadPerRateUnit);
  integrating_ = rp_.ki_nm_per_rad_s != 0.0f || yaw_.ki_nm_per_rad != 0.0f;
}

TorqueQ4 AttitudeController::torqueQ4(const AttitudeQ& a, const SetpointQ& sp) const {
  TorqueQ4 t;
  t.x = applyGain(sp.roll - a.roll, kp_xy_) - applyGain(a.rate[0], kd_xy_);
  t.y = applyGain(sp.pitch - a.pitch, kp_xy_) - applyGain(a.rate[1], kd_xy_);
  t.z = applyGain(sp.yaw_rate - a.rate[2], kp_z_);
  if (has_integral_) {  // float, only while an integral gain is in use
    t.x += roundToInt32(integral_nm_[0] * q4_per_nm_xy_);
    t.y += roundToInt32(integral_nm_[1] * q4_per_nm_xy_);
    t.z += roundToInt32(integral_nm_[2] * q4_per_nm_z_);
  }
  return t;
}

Torque AttitudeController::torque(const Attitude& a, const Setpoint& sp) const {
  Torque t;
  t.x_nm = rp_.kp_nm_per_rad * (sp.roll_rad - a.roll_rad) - rp_.kd_nm_s_per_rad * a.rate_rad_s[0] +
           integral_nm_[0];
  t.y_nm = rp_.kp_nm_per_rad * (sp.pitch_rad - a.pitch_rad) - rp_.kd_nm_s_per_rad * a.rate_rad_s[1] +
           integral_nm_[1];
  t.z_nm = yaw_.kp_nm_s_per_rad * (sp.yaw_rate_rad_s - a.rate_rad_s[2]) + integral_nm_[2];
  return t;
}

// Axes without an integral gain (the thesis's default) cost nothing: their integral stays 0.
void AttitudeController::integrate(const Attitude& a, const Setpoint& sp, float dt_s, uint8_t mix_limits) {
  if (rp_.ki_nm_per_rad_s != 0.0f && !(mix_limits & kMixRollPitchLimited)) {
    const float k = rp_.ki_nm_per_rad_s * dt_s;
    integral_nm_[0] = clampSym(integral_nm_[0] + k * (sp.roll_rad - a.roll_rad), kIntegralMaxNm);
    integral_nm_[1] = clampSym(integral_nm_[1] + k * (sp.pitch_rad - a.pitch_rad), kIntegralMaxNm);
  }
  if (yaw_.ki_nm_per_rad != 0.0f && !(mix_limits & kMixYawLimited)) {
    integral_nm_[2] = clampSym(
        integral_nm_[2] + yaw_.ki_nm_per_rad * dt_s * (sp.yaw_rate_rad_s - a.rate_rad_s[2]), kIntegralMaxNm);
  }
  has_integral_ = integral_nm_[0] != 0.0f || integral_nm_[1] != 0.0f || integral_nm_[2] != 0.0f;
}

}  // namespace fly
