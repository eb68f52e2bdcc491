// The attitude controller (controller.hpp).
#include "controller.hpp"

namespace fly {

namespace {
float clampSym(float v, float limit) { return v > limit ? limit : (v < -limit ? -limit : v); }
}  // namespace

void AttitudeController::reset() {
  for (float& i : integral_nm_) i = 0;
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
}

}  // namespace fly
