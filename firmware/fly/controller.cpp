// The attitude controller (controller.hpp).
#include "controller.hpp"

namespace fly {

namespace {
float clampSym(float v, float limit) { return v > limit ? limit : (v < -limit ? -limit : v); }
}  // namespace

SetpointQ fixedSetpoint(const Setpoint& sp) {
  SetpointQ q;
  q.mode = sp.mode;
  q.roll = angleUnits(sp.roll_rad);
  q.pitch = angleUnits(sp.pitch_rad);
  q.rate[0] = rateUnits(sp.roll_rate_rad_s);
  q.rate[1] = rateUnits(sp.pitch_rate_rad_s);
  q.rate[2] = rateUnits(sp.yaw_rate_rad_s);
  return q;
}

Setpoint setpointOf(const SetpointQ& q) {
  Setpoint sp;
  sp.mode = q.mode;
  sp.roll_rad = q.roll * kRadPerAngleUnit;
  sp.pitch_rad = q.pitch * kRadPerAngleUnit;
  sp.roll_rate_rad_s = q.rate[0] * kRadPerRateUnit;
  sp.pitch_rate_rad_s = q.rate[1] * kRadPerRateUnit;
  sp.yaw_rate_rad_s = q.rate[2] * kRadPerRateUnit;
  return sp;
}

void AttitudeController::reset() {
  for (float& i : integral_nm_) i = 0;
  has_integral_ = false;
}

void AttitudeController::scale() {
  const ControllerSettings& s = settings_;
  kp_xy_ = gainOf(s.angle.kp_nm_per_rad * dg_per_nm_xy_ * kRadPerAngleUnit);
  kd_xy_ = gainOf(s.angle.kd_nm_s_per_rad * dg_per_nm_xy_ * kRadPerRateUnit);
  kp_rate_xy_ = gainOf(s.rate.kp_nm_s_per_rad * dg_per_nm_xy_ * kRadPerRateUnit);
  kp_z_ = gainOf(s.yaw.kp_nm_s_per_rad * dg_per_nm_z_ * kRadPerRateUnit);
  const bool yaw = s.yaw.ki_nm_per_rad != 0.0f;
  integrating_angle_ = s.angle.ki_nm_per_rad_s != 0.0f || yaw;
  integrating_rate_ = s.rate.ki_nm_per_rad != 0.0f || yaw;
}

TorqueDg AttitudeController::torqueDg(const AttitudeQ& a, const SetpointQ& sp) const {
  TorqueDg t;
  if (sp.mode == FlightMode::kAngle) {
    t.x = applyGain(sp.roll - a.roll, kp_xy_) - applyGain(a.rate[0], kd_xy_);
    t.y = applyGain(sp.pitch - a.pitch, kp_xy_) - applyGain(a.rate[1], kd_xy_);
  } else {
    t.x = applyGain(sp.rate[0] - a.rate[0], kp_rate_xy_);
    t.y = applyGain(sp.rate[1] - a.rate[1], kp_rate_xy_);
  }
  t.z = applyGain(sp.rate[2] - a.rate[2], kp_z_);
  if (has_integral_) {  // float, only while an integral gain is in use
    t.x += roundToInt32(integral_nm_[0] * dg_per_nm_xy_);
    t.y += roundToInt32(integral_nm_[1] * dg_per_nm_xy_);
    t.z += roundToInt32(integral_nm_[2] * dg_per_nm_z_);
  }
  return t;
}

Torque AttitudeController::torque(const Attitude& a, const Setpoint& sp) const {
  const ControllerSettings& s = settings_;
  Torque t;
  if (sp.mode == FlightMode::kAngle) {
    t.x_nm = s.angle.kp_nm_per_rad * (sp.roll_rad - a.roll_rad) - s.angle.kd_nm_s_per_rad * a.rate_rad_s[0];
    t.y_nm = s.angle.kp_nm_per_rad * (sp.pitch_rad - a.pitch_rad) - s.angle.kd_nm_s_per_rad * a.rate_rad_s[1];
  } else {
    t.x_nm = s.rate.kp_nm_s_per_rad * (sp.roll_rate_rad_s - a.rate_rad_s[0]);
    t.y_nm = s.rate.kp_nm_s_per_rad * (sp.pitch_rate_rad_s - a.rate_rad_s[1]);
  }
  t.z_nm = s.yaw.kp_nm_s_per_rad * (sp.yaw_rate_rad_s - a.rate_rad_s[2]) + integral_nm_[2];
  t.x_nm += integral_nm_[0];
  t.y_nm += integral_nm_[1];
  return t;
}

// Axes without an integral gain (the thesis's default) cost nothing: their integral stays 0.
void AttitudeController::integrate(const Attitude& a, const Setpoint& sp, float dt_s, uint8_t mix_limits) {
  const ControllerSettings& s = settings_;
  if (!(mix_limits & kMixRollPitchLimited)) {
    float error[2] = {0, 0};
    float ki = 0;
    if (sp.mode == FlightMode::kAngle) {
      ki = s.angle.ki_nm_per_rad_s;
      error[0] = sp.roll_rad - a.roll_rad;
      error[1] = sp.pitch_rad - a.pitch_rad;
    } else {
      ki = s.rate.ki_nm_per_rad;
      error[0] = sp.roll_rate_rad_s - a.rate_rad_s[0];
      error[1] = sp.pitch_rate_rad_s - a.rate_rad_s[1];
    }
    if (ki != 0.0f) {
      for (uint8_t i = 0; i < 2; ++i) integral_nm_[i] = clampSym(integral_nm_[i] + ki * dt_s * error[i], kIntegralMaxNm);
    }
  }
  if (s.yaw.ki_nm_per_rad != 0.0f && !(mix_limits & kMixYawLimited)) {
    integral_nm_[2] = clampSym(
        integral_nm_[2] + s.yaw.ki_nm_per_rad * dt_s * (sp.yaw_rate_rad_s - a.rate_rad_s[2]), kIntegralMaxNm);
  }
  has_integral_ = integral_nm_[0] != 0.0f || integral_nm_[1] != 0.0f || integral_nm_[2] != 0.0f;
}

}  // namespace fly
