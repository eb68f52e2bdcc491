// The attitude controller in physical units: roll and pitch angles (rad) to torques (N m) by a
// PID whose derivative acts on the measured body rate, yaw by a PI on the body rate. The thesis's
// Iqarus flew a PD on roll and pitch (Kp 2.2, Kd 0.4 on degrees, its output microseconds added
// to and taken from opposite motors, sec. 2.2.1); the defaults below are those gains converted to
// torque on the Iqarus (docs/fly.md, "Gains"):
//   Kp 2.2 us/deg * 1.44 g/us (the thesis motor's slope at 300 g, table 5.1) = 3.17 g per deg on
//   each of two opposite motors 0.225 m out: 0.0140 N m/deg = 0.800 N m/rad;
//   Kd 0.4 us/(deg/s) the same way: 0.146 N m s/rad (taking the thesis's timeChange in seconds).
// The derivative on the rate, not on the error (the thesis differentiated the error): a setpoint
// step then does not kick the motors, and the gyro's rate needs no differencing.
// Integrators: frozen on an axis the mixer had to limit (anti-windup), held within
// kIntegralMaxNm, reset on every arm; no integral term by default (the thesis had none).
// The frame path (torqueQ4) is the same law in fixed point on the estimator's AttitudeQ, its
// output already the mixer's 1/16 g: the gains times the mixer's scale, made when either
// changes; torque() in N m is the law as written, the reference torqueQ4 is tested against.
#pragma once
#include <stdint.h>

#include "estimator.hpp"

namespace fly {

struct AxisGains {
  float kp_nm_per_rad = 0;
  float ki_nm_per_rad_s = 0;  // per (rad s)
  float kd_nm_s_per_rad = 0;
};
struct YawGains {
  float kp_nm_s_per_rad = 0;  // per rad/s of rate error
  float ki_nm_per_rad = 0;    // per rad of integrated rate error
};

constexpr AxisGains kThesisGains = {0.800f, 0.0f, 0.146f};
constexpr YawGains kDefaultYawGains = {0.100f, 0.0f};

struct Setpoint {
  float roll_rad = 0;
  float pitch_rad = 0;
  float yaw_rate_rad_s = 0;
};

struct Torque {
  float x_nm = 0;
  float y_nm = 0;
  float z_nm = 0;
};

// The setpoint in the estimator's units (estimator.hpp), made when it changes.
struct SetpointQ {
  int32_t roll = 0;      // angle units
  int32_t pitch = 0;
  int32_t yaw_rate = 0;  // rate units
};
SetpointQ fixedSetpoint(const Setpoint& sp);

// A torque as the mixer takes it: the force it adds to each motor, 1/16 g per lever (x, y) or
// per spin (z) (Mixer's units: torque times Mixer::q4PerNmXy / q4PerNmZ).
struct TorqueQ4 {
  int32_t x = 0;
  int32_t y = 0;
  int32_t z = 0;
};

// What the mixer had to give up (Mixer::mix's result): the integrators of those axes hold.
enum MixLimit : uint8_t {
  kMixRollPitchLimited = 1u << 0,
  kMixYawLimited = 1u << 1,
  kMixCollectiveLimited = 1u << 2,
};

class AttitudeController {
 public:
  static constexpr float kIntegralMaxNm = 0.25f;

  void setGains(const AxisGains& roll_pitch, const YawGains& yaw) {
    rp_ = roll_pitch;
    yaw_ = yaw;
    scale();
  }
  // The mixer's 1/16 g per N m about x and y, and about z (Mixer::q4PerNmXy, q4PerNmZ).
  void setForceScale(float q4_per_nm_xy, float q4_per_nm_z) {
    q4_per_nm_xy_ = q4_per_nm_xy;
    q4_per_nm_z_ = q4_per_nm_z;
    scale();
  }
  const AxisGains& gains() const { return rp_; }
  const YawGains& yawGains() const { return yaw_; }
  void reset();
  // This frame's torque: P and D now, the integrals as they stand (the law, in N m).
  Torque torque(const Attitude& a, const Setpoint& sp) const;
  // The same in fixed point, as the mixer takes it (the frame path): each term rounded to
  // 1/16 g, so within a few of torque() times the scale, rounded.
  TorqueQ4 torqueQ4(const AttitudeQ& a, const SetpointQ& sp) const;
  // Whether integrate() does anything: an integral gain is set.
  bool integrating() const { return integrating_; }
  // The integrals advanced by dt (after the output), except on axes the mixer limited.
  void integrate(const Attitude& a, const Setpoint& sp, float dt_s, uint8_t mix_limits);
  float integralNm(uint8_t axis) const { return integral_nm_[axis]; }

 private:
  void scale();

  AxisGains rp_ = kThesisGains;
  YawGains yaw_ = kDefaultYawGains;
  float integral_nm_[3] = {0, 0, 0};
  bool has_integral_ = false;  // some integral is not 0 (torqueQ4 adds them)
  bool integrating_ = false;
  float q4_per_nm_xy_ = 0, q4_per_nm_z_ = 0;
  Gain kp_xy_, kd_xy_, kp_z_;  // 1/16 g per angle unit, per rate unit
};

}  // namespace fly
