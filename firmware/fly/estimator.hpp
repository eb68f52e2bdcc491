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
// A stage of fly's loop: ImuSample in, AttitudeQ out (flight_types.hpp, where the units are);
// it depends on no other stage.
#pragma once
#include <stdint.h>

#include "fixed_point.hpp"
#include "flight_types.hpp"

namespace fly {

// atan2(y, x) in radians, -pi..pi; 0 for (0, 0).
float atan2Approx(float y, float x);

class GyroCalibration {
 public:
  static constexpr uint16_t kSamples = framesIn(1000);  // one sample per frame: 1 s
  static constexpr int16_t kStillSpreadLsb = static_cast<int16_t>(2.0f * kGyroLsbPerDps + 0.5f);  // 2 deg/s

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

// |a|^2 in LSB^2, exactly.
uint32_t squaredNormLsb2(const ImuSample& s);

// The accelerometer's level trim (`level`): subtracted from every sample's x, y, z before a tilt
// is taken from it. A setting (fly's parameters keep it).
struct LevelTrim {
  int16_t lsb[3] = {0, 0, 0};  // x, y, z in accelerometer counts
};

class AttitudeEstimator {
 public:
  static constexpr float kTimeConstantS = 0.5f;
  static constexpr int16_t kMaxLevelTrimLsb = (kAccelLsbPerG + 5) / 10;  // 100 mg (410 LSB): 5.7 deg on x, y

  // The level trim from a finished calibration taken level and still; false (the trim kept)
  // when an axis is beyond kMaxLevelTrimLsb. Takes effect at the next start().
  bool trimLevel(const GyroCalibration& calibration);
  // A trim from elsewhere (saved settings): false (the trim kept) beyond kMaxLevelTrimLsb.
  bool setLevelTrim(const LevelTrim& trim);
  const LevelTrim& levelTrim() const { return trim_; }
  int16_t levelTrimLsb(uint8_t axis) const { return trim_.lsb[axis]; }  // x, y, z

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
  LevelTrim trim_;                  // the accelerometer's level trim
  Gain blend_gain_;                 // k of the last interval_s
  float blend_interval_s_ = -1.0f;
  bool started_ = false;
  uint32_t untrusted_ = 0;
};

}  // namespace fly
