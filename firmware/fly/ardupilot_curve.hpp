// ArduPilot's thrust linearisation, as ArduPilot flies it and as `thrustcal lab export --to
// ardupilot` fits it (tools/lab/include/lab/autopilot.hpp has the sources and commits read):
// one curve for all motors, scaled with the battery voltage; what users fly today, to compare
// with per-motor calibration on one airframe (fly's ardupilot mode).
//   voltage:   v = clamp(V, max(V_MIN, 0.6 V_MAX), V_MAX) / V_MAX, through ArduPilot's 0.5 Hz
//              low-pass (1 when MOT_BAT_VOLT_MAX <= 0, V_MIN >= V_MAX or V < V_MIN / 4);
//              lift_max = v (1 - e) + e v^2
//   a force:   thrust = F / full thrust, times 1 / lift_max (get_compensation_gain), in 0..1;
//              throttle y solves e y^2 + (1 - e) y = lift_max thrust, divided by v, in 0..1;
//              actuator = SPIN_MIN + (SPIN_MAX - SPIN_MIN) y;
//              pulse = PWM_MIN + (PWM_MAX - PWM_MIN) actuator, truncated (int16, output_to_pwm).
// e = MOT_THST_EXPO (clamped to -1..1), SPIN_MIN/MAX, PWM_MIN/MAX, BAT_VOLT_MAX/MIN as the .parm
// file names them; the full thrust (grams at the top pulse on a full battery) is what the fit
// prints next to them (or (take-off weight / motors) / MOT_THST_HOVER).
// Per motor one square root and four products: whatever depends only on the voltage is worked
// out once per battery reading (updateBattery).
#pragma once
#include <stdint.h>

#include "thrustcal/record_limits.hpp"

namespace fly {

struct ArduPilotParams {
  float expo = 0.65f;          // MOT_THST_EXPO
  float spin_min = 0.15f;      // MOT_SPIN_MIN
  float spin_max = 0.95f;      // MOT_SPIN_MAX
  uint16_t pwm_min_us = tc::kThrottleMinUs;  // MOT_PWM_MIN
  uint16_t pwm_max_us = tc::kThrottleMaxUs;  // MOT_PWM_MAX
  float bat_volt_max_v = 0;    // MOT_BAT_VOLT_MAX (0: no voltage scaling)
  float bat_volt_min_v = 0;    // MOT_BAT_VOLT_MIN
  float full_thrust_g = 0;     // 0: not given (the mode refuses to arm)
};

class ArduPilotCurve {
 public:
  static constexpr float kFilterHz = 0.5f;  // ArduPilot's battery-voltage filter

  ArduPilotCurve() { setParams(ArduPilotParams()); }
  void setParams(const ArduPilotParams& p);
  const ArduPilotParams& params() const { return p_; }
  bool ready() const { return p_.full_thrust_g > 0; }
  // A battery reading `dt_s` after the last one (the first sets the filter).
  void updateBattery(uint16_t vbat_mv, float dt_s);
  float voltageRatio() const { return ratio_filt_; }
  float liftMax() const { return lift_max_; }
  // The most it will ask of a motor at this voltage: full thrust x lift_max (its thrust 1).
  float maxForceG() const { return p_.full_thrust_g * lift_max_; }
  // The pulse ArduPilot sends for `force_g` on one motor.
  uint16_t pulseUs(float force_g) const;

 private:
  void derive();
  float ratioFor(float vbat_v) const;

  ArduPilotParams p_;
  float expo_ = 0.65f;     // clamped
  float inv_vmax_ = 0;     // 1 / MOT_BAT_VOLT_MAX
  float vmin_v_ = 0;       // MOT_BAT_VOLT_MIN raised to 0.6 MOT_BAT_VOLT_MAX
  float alpha_dt_s_ = -1;  // the filter's alpha for this dt (one dt in practice: no division)
  float alpha_ = 0;
  float ratio_filt_ = 1.0f;  // v through the filter
  bool filter_set_ = false;
  float lift_max_ = 1.0f;
  // Per-reading constants of pulseUs: thrust = F * thrust_per_g_; y = (c_ + sqrt(a_ + b_ thrust)) d_
  // (linear branch when e == 0: y = lin_ thrust); pulse = p0_ + p1_ y.
  float thrust_per_g_ = 0, a_ = 0, b_ = 0, c_ = 0, d_ = 0, lin_ = 0, p0_ = 0, p1_ = 0;
};

}  // namespace fly
