// The attitude controller in physical units, a stage of fly's loop: AttitudeQ and SetpointQ in,
// TorqueDg out (flight_types.hpp, where the units are); it depends on no other stage.
//
// Angle mode (the thesis's controller): roll and pitch angles (rad) to torques (N m) by a PID
// whose derivative acts on the measured body rate. The thesis's Iqarus flew a PD on roll and
// pitch (Kp 2.2, Kd 0.4 on degrees, its output microseconds added to and taken from opposite
// motors, sec. 2.2.1); the defaults below are those gains converted to torque on the Iqarus
// (docs/fly.md, "Gains"):
//   Kp 2.2 us/deg * 1.44 g/us (the thesis motor's slope at 300 g, table 5.1) = 3.17 g per deg on
//   each of two opposite motors 0.225 m out: 0.0140 N m/deg = 0.800 N m/rad;
//   Kd 0.4 us/(deg/s) the same way: 0.146 N m s/rad (taking the thesis's timeChange in seconds).
// The derivative on the rate, not on the error (the thesis differentiated the error): a setpoint
// step then does not kick the motors, and the gyro's rate needs no differencing.
// Rate mode (acro, from the receiver's sticks): roll and pitch rates by a PI on the body rate,
// as yaw is in both modes; the default's P is the angle mode's D (the same damping).
// Integrators: frozen on an axis the mixer had to limit (anti-windup), held within
// kIntegralMaxNm, reset on every arm; no integral term by default (the thesis had none).
// The frame path (torqueDg) is the law in fixed point on the estimator's AttitudeQ, its output
// already the mixer's decigrams: the gains times the mixer's scale, made when either changes;
// torque() in N m is the law as written, the reference torqueDg is tested against.
#pragma once
#include <stdint.h>

#include "fixed_point.hpp"
#include "flight_types.hpp"

namespace fly {

// Angle mode, roll and pitch.
struct AxisGains {
  float kp_nm_per_rad = 0;
  float ki_nm_per_rad_s = 0;  // per (rad s)
  float kd_nm_s_per_rad = 0;
};
// Rate mode roll and pitch, and yaw in both modes: a PI on the body rate.
struct RateGains {
  float kp_nm_s_per_rad = 0;  // per rad/s of rate error
  float ki_nm_per_rad = 0;    // per rad of integrated rate error
};
using YawGains = RateGains;

constexpr AxisGains kThesisGains = {0.800f, 0.0f, 0.146f};
constexpr RateGains kDefaultRateGains = {0.146f, 0.0f};
constexpr YawGains kDefaultYawGains = {0.100f, 0.0f};

// The controller's settings, one plain struct (fly's parameters point at it): the gains of each
// flight mode.
struct ControllerSettings {
  AxisGains angle = kThesisGains;
  RateGains rate = kDefaultRateGains;
  YawGains yaw = kDefaultYawGains;
};

// The setpoint in the frame path's units, made when it changes, and back (status, integrators).
SetpointQ fixedSetpoint(const Setpoint& sp);
Setpoint setpointOf(const SetpointQ& q);

class AttitudeController {
 public:
  static constexpr float kIntegralMaxNm = 0.25f;

  void setSettings(const ControllerSettings& s) {
    settings_ = s;
    scale();
  }
  const ControllerSettings& settings() const { return settings_; }
  // The mixer's decigrams per N m about x and y, and about z (Mixer::dgPerNmXy, dgPerNmZ).
  void setForceScale(float dg_per_nm_xy, float dg_per_nm_z) {
    dg_per_nm_xy_ = dg_per_nm_xy;
    dg_per_nm_z_ = dg_per_nm_z;
    scale();
  }
  void reset();
  // This frame's torque: P and D now, the integrals as they stand (the law, in N m).
  Torque torque(const Attitude& a, const Setpoint& sp) const;
  // The same in fixed point, as the mixer takes it (the frame path): each term rounded to a
  // decigram, so within a few of torque() times the scale, rounded.
  TorqueDg torqueDg(const AttitudeQ& a, const SetpointQ& sp) const;
  // Whether integrate() does anything: an integral gain of the mode is set.
  bool integrating(FlightMode mode) const {
    return mode == FlightMode::kAngle ? integrating_angle_ : integrating_rate_;
  }
  // The integrals advanced by dt (after the output), except on axes the mixer limited.
  void integrate(const Attitude& a, const Setpoint& sp, float dt_s, uint8_t mix_limits);
  float integralNm(uint8_t axis) const { return integral_nm_[axis]; }

 private:
  void scale();

  ControllerSettings settings_;
  float integral_nm_[3] = {0, 0, 0};
  bool has_integral_ = false;  // some integral is not 0 (torqueDg adds them)
  bool integrating_angle_ = false, integrating_rate_ = false;
  float dg_per_nm_xy_ = 0, dg_per_nm_z_ = 0;
  Gain kp_xy_, kd_xy_, kp_rate_xy_, kp_z_;  // decigrams per angle unit, per rate unit
};

}  // namespace fly
