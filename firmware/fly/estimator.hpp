// Attitude from the MPU-6050: the gyro's bias measured at rest, then a complementary filter.
//
// Gyro bias (GyroCalibration): the mean of kSamples samples (1 s) taken while every axis stays
// within kStillSpreadLsb (2 deg/s) of its own range and the accelerometer reads 1 g +-15 %; any
// motion starts it again. The mean accelerometer of the same samples is the first attitude.
//
// Complementary filter (AttitudeEstimator), the IMU's axes the body's (x forward, y left, z up;
// roll positive = right side down, pitch positive = nose down, as the simulated airframe:
// docs/fly.md):
//   propagate (every frame, before the controller): body rates = gyro - bias;
//     roll += (p + r * pitch) dt, pitch += (q - r * roll) dt (the Euler rates to first order);
//   correct (after the pulses, each axis every eighth frame): roll += k (atan2(ay, az) - roll),
//     pitch += k (atan2(-ax, sqrt(ay^2 + az^2)) - pitch), k = interval / kTimeConstantS, only
//     while |a| is within 15 % of 1 g (a linear acceleration or a crash says nothing of tilt).
// kTimeConstantS 0.5 s: the gyro rules the loop's band (a 2 Hz attitude loop), the accelerometer
// only its drift. Valid within +-90 deg of pitch; the crash limit disarms far inside that.
// atan2 is a polynomial (atan2Approx: one division, error below 0.00002 rad), not atan2f.
//
// Level trim (the `level` command, as flight controllers calibrate their accelerometer): an
// MPU-6050's zero-g offsets may be +-50 mg on x and y, +-80 mg on z (its datasheet); on x and y
// that is up to 2.9 deg of tilt the accelerometer reports on a level vehicle, on z a tilt read
// short by up to 8 % (0.8 deg at 10 deg), and the controller holds what the estimate says. With
// the vehicle standing level and still, the calibration's mean x, y and z - 1 g become the trim,
// subtracted before every tilt the accelerometer gives. Refused beyond kMaxLevelTrimLsb on any
// axis (the vehicle is not level, or the sensor is off its datasheet), so a trim never hides a
// real tilt of more.
#pragma once
#include <stdint.h>

#include "fixed_point.hpp"
#include "fly_rules.hpp"
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

// The frame path's units (see the top).
constexpr float kRadPerRateUnit = 3.14159265f / 180.0f / mpu::kGyroLsbPerDps / 16.0f;
constexpr float kRadPerAngleUnit = kRadPerRateUnit * kFramePeriodS;
// Angles are held within +-100 rad (a board turned over and over while disarmed), far beyond
// any attitude flown, so an integral never wraps.
constexpr int32_t kMaxAngleUnits = static_cast<int32_t>(100.0f / kRadPerAngleUnit);

struct AttitudeQ {
  int32_t roll = 0;                // angle units
  int32_t pitch = 0;
  int32_t rate[3] = {0, 0, 0};     // rate units: p, q, r
};

// Radians to angle units, rounded and saturated (settings, slow jobs).
int32_t angleUnits(float rad);
// Whole degrees (0..255) to angle units, rounded: constant limits such as the crash limit.
constexpr int32_t angleUnitsOfDegrees(uint8_t deg) {
  return static_cast<int32_t>(deg * (3.14159265f / 180.0f) / kRadPerAngleUnit + 0.5f);
}
// |a|^2 in LSB^2, exactly.
uint32_t squaredNormLsb2(const ImuSample& s);

class AttitudeEstimator {
 public:
  static constexpr float kTimeConstantS = 0.5f;
  static constexpr int16_t kMaxLevelTrimLsb = 410;  // 100 mg at 4096 LSB/g: 5.7 deg on x, y

  // The level trim from a finished calibration taken level and still; false (the trim kept)
  // when an axis is beyond kMaxLevelTrimLsb. Takes effect at the next start().
  bool trimLevel(const GyroCalibration& calibration);
  int16_t levelTrimLsb(uint8_t axis) const { return trim_lsb_[axis]; }  // x, y, z
  // A trim kept from before (the saved parameters), each axis within kMaxLevelTrimLsb.
  void setLevelTrimLsb(const int16_t (&lsb)[3]) {
    for (uint8_t i = 0; i < 3; ++i) trim_lsb_[i] = lsb[i];
  }

  // From a finished calibration: its bias, and the attitude its mean accelerometer gives.
  void start(const GyroCalibration& calibration);
  // Until the next start(): the gyro is being calibrated (again), the estimate is not flown.
  void stop() { started_ = false; }
  bool started() const { return started_; }
  // A sample `frames` frames after the last one (1 unless the loop was late).
  void propagate(const ImuSample& s, uint8_t frames);
  // The accelerometer's correction of one axis, `interval_s` after that axis's last one.
  void correctRoll(const ImuSample& s, float interval_s);
  void correctPitch(const ImuSample& s, float interval_s);
  Attitude attitude() const;
  const AttitudeQ& fixed() const { return q_; }
  uint32_t untrustedAccel() const { return untrusted_; }  // corrections skipped (|a| off 1 g)

 private:
  bool accelTrusted(const ImuSample& s) const;
  int32_t blend(int32_t estimate, float measured_rad, float interval_s);

  AttitudeQ q_;
  int32_t bias_q4_[3] = {0, 0, 0};  // the bias in 1/16 LSB: rate units
  int16_t trim_lsb_[3] = {0, 0, 0};  // the accelerometer's level trim, x, y, z
  Gain blend_gain_;                 // k of the last interval_s
  float blend_interval_s_ = -1.0f;
  bool started_ = false;
  uint32_t untrusted_ = 0;
};

}  // namespace fly
