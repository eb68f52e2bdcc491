// Gyro calibration and the complementary filter (estimator.hpp).
#include "estimator.hpp"

#include <math.h>

namespace fly {

namespace {
constexpr float kPi = 3.14159265f;
constexpr float kHalfPi = 1.57079633f;
// |a|^2 within (1 g +-15 %)^2, in LSB^2.
constexpr float kAccelMin2 = (0.85f * mpu::kAccelLsbPerG) * (0.85f * mpu::kAccelLsbPerG);
constexpr float kAccelMax2 = (1.15f * mpu::kAccelLsbPerG) * (1.15f * mpu::kAccelLsbPerG);

float squaredNorm(const ImuSample& s) {
  const float x = s.accel[0], y = s.accel[1], z = s.accel[2];
  return x * x + y * y + z * z;
}
}  // namespace

// atan on 0..1 as Abramowitz & Stegun 4.4.47 (a 9th-order odd polynomial, error <= 1e-5 rad),
// mapped to the quadrants.
float atan2Approx(float y, float x) {
  const float ax = fabsf(x), ay = fabsf(y);
  const float hi = ax > ay ? ax : ay;
  if (hi == 0.0f) return 0.0f;
  const float lo = ax > ay ? ay : ax;
  const float a = lo / hi;
  const float s = a * a;
  float r = ((((0.0208351f * s - 0.0851330f) * s + 0.1801410f) * s - 0.3302995f) * s + 0.9998660f) * a;
  if (ay > ax) r = kHalfPi - r;
  if (x < 0.0f) r = kPi - r;
  return y < 0.0f ? -r : r;
}

// ---------------------------------------------------------------------------------------------
// Gyro calibration

void GyroCalibration::restart() {
  restarts_ = 0;
  begin();
}

void GyroCalibration::begin() {
  for (uint8_t i = 0; i < 3; ++i) {
    gyro_sum_[i] = 0;
    accel_sum_[i] = 0;
  }
  count_ = 0;
  done_ = false;
}

bool GyroCalibration::add(const ImuSample& s) {
  if (done_) return true;
  const float n2 = squaredNorm(s);
  bool still = n2 >= kAccelMin2 && n2 <= kAccelMax2;
  for (uint8_t i = 0; i < 3 && still; ++i) {
    const int16_t g = s.gyro[i];
    if (count_ == 0 || g < gyro_min_[i]) gyro_min_[i] = g;
    if (count_ == 0 || g > gyro_max_[i]) gyro_max_[i] = g;
    still = gyro_max_[i] - gyro_min_[i] <= kStillSpreadLsb;
  }
  if (!still) {
    if (restarts_ != 0xFFFF) ++restarts_;
    begin();
    return false;
  }
  for (uint8_t i = 0; i < 3; ++i) {
    gyro_sum_[i] += s.gyro[i];
    accel_sum_[i] += s.accel[i];
  }
  if (++count_ < kSamples) return false;
  for (uint8_t i = 0; i < 3; ++i) {
    bias_lsb_[i] = static_cast<float>(gyro_sum_[i]) / kSamples;
    accel_mean_lsb_[i] = static_cast<float>(accel_sum_[i]) / kSamples;
  }
  done_ = true;
  return true;
}

// ---------------------------------------------------------------------------------------------
// Complementary filter

void AttitudeEstimator::start(const GyroCalibration& c) {
  for (uint8_t i = 0; i < 3; ++i) {
    const float q4 = c.biasLsb(i) * 16.0f;
    bias_q4_[i] = static_cast<int32_t>(q4 < 0 ? q4 - 0.5f : q4 + 0.5f);
    attitude_.rate_rad_s[i] = 0;
  }
  const float ax = c.accelMeanLsb(0), ay = c.accelMeanLsb(1), az = c.accelMeanLsb(2);
  attitude_.roll_rad = atan2Approx(ay, az);
  attitude_.pitch_rad = atan2Approx(-ax, sqrtf(ay * ay + az * az));
  started_ = true;
}

void AttitudeEstimator::propagate(const ImuSample& s, float dt_s) {
  float* w = attitude_.rate_rad_s;
  for (uint8_t i = 0; i < 3; ++i) w[i] = static_cast<float>(s.gyro[i] * 16L - bias_q4_[i]) * kRadPerQ4;
  const float roll = attitude_.roll_rad;
  attitude_.roll_rad = roll + (w[0] + w[2] * attitude_.pitch_rad) * dt_s;
  attitude_.pitch_rad += (w[1] - w[2] * roll) * dt_s;
}

bool AttitudeEstimator::accelTrusted(const ImuSample& s) const {
  const float n2 = squaredNorm(s);
  return n2 >= kAccelMin2 && n2 <= kAccelMax2;
}

float AttitudeEstimator::blend(float estimate, float measured, float interval_s) {
  float k = interval_s * (1.0f / kTimeConstantS);
  if (k > 1.0f) k = 1.0f;
  return estimate + k * (measured - estimate);
}

void AttitudeEstimator::correctRoll(const ImuSample& s, float interval_s) {
  if (!accelTrusted(s)) {
    ++untrusted_;
    return;
  }
  attitude_.roll_rad = blend(attitude_.roll_rad, atan2Approx(s.accel[1], s.accel[2]), interval_s);
}

void AttitudeEstimator::correctPitch(const ImuSample& s, float interval_s) {
  if (!accelTrusted(s)) {
    ++untrusted_;
    return;
  }
  const float y = s.accel[1], z = s.accel[2];
  attitude_.pitch_rad = blend(attitude_.pitch_rad,
                              atan2Approx(-static_cast<float>(s.accel[0]), sqrtf(y * y + z * z)), interval_s);
}

}  // namespace fly
