// Attitude from the MPU-6050: the gyro's bias measured at rest, then a complementary filter.
//
// Gyro bias (GyroCalibration): the mean of kSamples samples (1 s) taken while every axis stays
// within kStillSpreadLsb (2 deg/s) of its own range and the accelerometer reads 1 g +-15 %; any
// motion starts it again. The mean accelerometer of the same samples is the first attitude.
//
// Complementary filter (AttitudeEstimator), angles in radians, rates in rad/s, the IMU's axes
// the body's (x forward, y left, z up; roll positive = right side down, pitch positive = nose
// down, as the simulated airframe: docs/fly.md):
//   propagate (every frame, before the controller): body rates = (gyro - bias) * scale;
//     roll += (p + r * pitch) dt, pitch += (q - r * roll) dt (the Euler rates to first order);
//   correct (after the pulses, each axis every eighth frame): roll += k (atan2(ay, az) - roll),
//     pitch += k (atan2(-ax, sqrt(ay^2 + az^2)) - pitch), k = interval / kTimeConstantS, only
//     while |a| is within 15 % of 1 g (a linear acceleration or a crash says nothing of tilt).
// kTimeConstantS 0.5 s: the gyro rules the loop's band (a 2 Hz attitude loop), the accelerometer
// only its drift. Valid within +-90 deg of pitch; the crash limit disarms far inside that.
// atan2 is a polynomial (atan2Approx: one division, error below 0.00002 rad), not atan2f.
#pragma once
#include <stdint.h>

#include "mpu6050.hpp"

namespace fly {

// atan2(y, x) in radians, -pi..pi; 0 for (0, 0).
float atan2Approx(float y, float x);

class GyroCalibration {
 public:
  static constexpr uint16_t kSamples = 400;
  static constexpr int16_t kStillSpreadLsb = 33;  // 2 deg/s at 16.4 LSB per deg/s

  void restart();
  // Adds one sample; true once kSamples still samples are in (then bias and accelMean hold).
  bool add(const ImuSample& s);
  bool done() const { return done_; }
  uint16_t restarts() const { return restarts_; }  // motion seen since the last restart() call
  float biasLsb(uint8_t axis) const { return bias_lsb_[axis]; }
  float accelMeanLsb(uint8_t axis) const { return accel_mean_lsb_[axis]; }

 private:
  void begin();

  int32_t gyro_sum_[3] = {0, 0, 0};
  int32_t accel_sum_[3] = {0, 0, 0};
  int16_t gyro_min_[3] = {0, 0, 0};
  int16_t gyro_max_[3] = {0, 0, 0};
  uint16_t count_ = 0;
  uint16_t restarts_ = 0;
  bool done_ = false;
  float bias_lsb_[3] = {0, 0, 0};
  float accel_mean_lsb_[3] = {0, 0, 0};
};

struct Attitude {
  float roll_rad = 0;
  float pitch_rad = 0;
  float rate_rad_s[3] = {0, 0, 0};  // p, q, r about body x, y, z
};

class AttitudeEstimator {
 public:
  static constexpr float kTimeConstantS = 0.5f;
  static constexpr float kRadPerLsb = 3.14159265f / 180.0f / mpu::kGyroLsbPerDps;
  static constexpr float kRadPerQ4 = kRadPerLsb / 16.0f;

  // From a finished calibration: its bias, and the attitude its mean accelerometer gives.
  void start(const GyroCalibration& calibration);
  // Until the next start(): the gyro is being calibrated (again), the estimate is not flown.
  void stop() { started_ = false; }
  bool started() const { return started_; }
  void propagate(const ImuSample& s, float dt_s);
  // The accelerometer's correction of one axis, `interval_s` after that axis's last one.
  void correctRoll(const ImuSample& s, float interval_s);
  void correctPitch(const ImuSample& s, float interval_s);
  const Attitude& attitude() const { return attitude_; }
  uint32_t untrustedAccel() const { return untrusted_; }  // corrections skipped (|a| off 1 g)

 private:
  bool accelTrusted(const ImuSample& s) const;
  static float blend(float estimate, float measured, float interval_s);

  Attitude attitude_;
  int32_t bias_q4_[3] = {0, 0, 0};  // the bias in 1/16 LSB: subtracted before the one conversion
  bool started_ = false;
  uint32_t untrusted_ = 0;
};

}  // namespace fly
