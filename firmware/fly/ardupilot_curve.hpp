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
// pulseUs is that arithmetic in float (one square root and a few products per motor), the
// reference; the frame path is pulseUsDg, integer, from a table made with the parameters:
//   the throttle at full voltage for a force, u = y v, solves e u^2 + (1 - e) u = F / full thrust
//   (lift_max cancels), so it depends on the parameters only. The table holds u at kTableNodes
//   forces (decigrams), spaced evenly in sqrt(2 e u + 1 - e) (the interpolation's error is then
//   the same in every segment, (sqrt(1 + e) - sqrt(1 - e))^2 / (4 |e| segments^2) in u), each
//   segment's slope as a gain; a force's segment is found from the motor's last one (a neighbour,
//   else by bisection) and interpolated, then
//   pulse = PWM_MIN + span (SPIN_MIN + (SPIN_MAX - SPIN_MIN) min(u / v, 1)) with the per-reading
//   gain. Within |e| <= kTableMaxExpo the table is within kTableMaxErrorUs of the float
//   arithmetic at every force and voltage (the tests sweep e and measure it: tableErrorUs);
//   beyond (an expo near +-1) pulseUsDg flies the float path.
// Part of fly's output stage (output_stage.hpp).
// Whatever depends only on the voltage is worked out once per battery reading (updateBattery).
#pragma once
#include <stdint.h>

#include "fixed_point.hpp"
#include "flight_types.hpp"
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
  // The pulse ArduPilot sends for `force_g` on one motor (float: the reference).
  uint16_t pulseUs(float force_g) const;
  // The same for a force in decigrams, from the table (the frame path); within a microsecond of
  // pulseUs. `segment` is the caller's hint (one per motor, any value 0..kTableSegments - 1 to
  // start): the table segment the last force was in. A motor's force moves little from frame
  // to frame, so its segment or a neighbour is checked first and the bisection runs only when
  // neither holds; the segment found is written back. The same pulse whatever the hint.
  uint16_t pulseUsDg(ForceDg force_dg, uint8_t& segment) const;
  uint16_t pulseUsDg(ForceDg force_dg) const {
    uint8_t segment = 0;
    return pulseUsDg(force_dg, segment);
  }
  // Whether pulseUsDg flies the table (false: the parameters need the float path).
  bool usesTable() const { return table_ok_; }

  static constexpr uint8_t kTableSegments = 40;
  static constexpr float kTableMaxErrorUs = 0.5f;
  static constexpr float kTableMaxExpo = 0.95f;
  // The table's worst error in microseconds of pulse against the float arithmetic, at the
  // lowest voltage the parameters allow (tests; slow on the AVR).
  float tableErrorUs() const;

 private:
  struct Node {
    ForceDg force_dg;  // at this node
    uint16_t u_q15;    // the throttle at full voltage there, 1/32768
    Gain slope;        // to the next node: u_q15 per decigram
  };

  void derive();
  float ratioFor(float vbat_v) const;
  void buildTable();
  float throttleAtFullVoltage(float force_g) const;
  int32_t tableThrottleQ15(ForceDg force_dg, uint8_t& segment) const;
  // Whether `segment` is the one the bisection finds for `force_dg`: the last node at or below
  // the force (the first segment below node 1, the last at and beyond node kTableSegments - 1).
  FLY_INLINE bool inSegment(uint8_t segment, ForceDg force_dg) const {
    return (segment == 0 || table_[segment].force_dg <= force_dg) &&
           (segment == kTableSegments - 1 || force_dg < table_[segment + 1].force_dg);
  }

  ArduPilotParams p_;
  float expo_ = 0.65f;     // clamped
  float inv_vmax_ = 0;     // 1 / MOT_BAT_VOLT_MAX
  float vmin_v_ = 0;       // MOT_BAT_VOLT_MIN raised to 0.6 MOT_BAT_VOLT_MAX
  float alpha_dt_s_ = -1;  // the filter's alpha for this dt (one dt in practice: no division)
  float alpha_ = 0;
  float ratio_filt_ = 1.0f;  // v through the filter
  bool filter_set_ = false;
  float lift_max_ = 1.0f;
  // The per-reading constants of pulseUs: thrust = F * thrust_per_g; y = (c + sqrt(a + b thrust)) d
  // (linear branch when e == 0: y = lin thrust); pulse = p0_ + p1_ y.
  struct FloatPath {
    float thrust_per_g = 0, a = 0, b = 0, c = 0, d = 0, lin = 0;
  };
  FloatPath floatPath() const;
  FloatPath float_path_;  // kept per reading only when the float path flies (!table_ok_)
  float p0_ = 0, p1_ = 0;  // the pulse at y = 0 and its span to y = 1 (the parameters only)
  // pulseUsDg: the table, and per reading the force that makes thrust 1 and u's pulse gain.
  Node table_[kTableSegments + 1];
  bool table_ok_ = false;
  ForceDg max_force_dg_ = 0;    // full thrust x lift_max
  int32_t p0_x16_ = 0;          // PWM_MIN + span SPIN_MIN, 1/16 us
  int32_t p_top_x16_ = 0;       // the pulse at y = 1
  Gain pulse_per_u_;            // 1/16 us per u_q15: span (SPIN_MAX - SPIN_MIN) / v
};

}  // namespace fly
