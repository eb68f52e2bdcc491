// Gyro calibration and the complementary filter (estimator.hpp).
#include "estimator.hpp"

#include <math.h>

namespace fly {

namespace {
constexpr float kHalfPi = 1.57079633f;
// |a|^2 within (1 g +-15 %)^2, in LSB^2, the bounds rounded inwards; integers, so the host and
// the AVR (whose double is a float) agree to the LSB.
constexpr uint32_t kLsbPerG = kAccelLsbPerG;
constexpr uint32_t kAccelMinTenths = 85 * kLsbPerG / 10;   // 0.85 g in 1/10 LSB
constexpr uint32_t kAccelMaxTenths = 115 * kLsbPerG / 10;  // 1.15 g
constexpr uint32_t kAccelMin2 = (kAccelMinTenths * kAccelMinTenths + 99) / 100;
constexpr uint32_t kAccelMax2 = kAccelMaxTenths * kAccelMaxTenths / 100;
bool nearOneG(const ImuSample& s) {
  const uint32_t n2 = squaredNormLsb2(s);
  return n2 >= kAccelMin2 && n2 <= kAccelMax2;
}

// r * angle in rate units (the Euler rates' coupling): r in whole gyro LSB times the angle in
// 1024 angle units, a 16 x 16 product, times the unit that product is.
constexpr Gain kCouplingGain = gainOf(16.0f * 1024.0f * kRadPerAngleUnit);
int16_t saturated16(int32_t v) { return v > 32767 ? 32767 : (v < -32768 ? -32768 : static_cast<int16_t>(v)); }
int32_t coupling(int32_t r, int32_t angle) {
  const int32_t product = static_cast<int32_t>(saturated16((r + 8) >> 4)) * saturated16((angle + 512) >> 10);
  return applyGain(product, kCouplingGain);
}
// A frame's rate (rate units) as the angle it turns (angle units): the loop rate's one appearance.
constexpr Gain kAnglePerRateFrame = gainOf(kRadPerRateUnit * kFramePeriodS / kRadPerAngleUnit);
int32_t heldAngle(int32_t angle) {
  return angle > kMaxAngleUnits ? kMaxAngleUnits : (angle < -kMaxAngleUnits ? -kMaxAngleUnits : angle);
}
}  // namespace

uint32_t squaredNormLsb2(const ImuSample& s) {
  uint32_t sum = 0;
  for (uint8_t i = 0; i < 3; ++i) {
    const int32_t a = s.accel[i];
    sum += static_cast<uint32_t>(a * a);
  }
  return sum;
}

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
  bool still = nearOneG(s);
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
    bias_q4_[i] = roundToInt32(c.biasLsb(i) * 16.0f);
    q_.rate[i] = 0;
  }
  const float ax = c.accelMeanLsb(0) - trim_.lsb[0], ay = c.accelMeanLsb(1) - trim_.lsb[1];
  const float az = c.accelMeanLsb(2) - trim_.lsb[2];
  q_.roll = angleUnits(atan2Approx(ay, az));
  q_.pitch = angleUnits(atan2Approx(-ax, sqrtf(ay * ay + az * az)));
  started_ = true;
}

bool AttitudeEstimator::trimLevel(const GyroCalibration& c) {
  LevelTrim trim;
  for (uint8_t i = 0; i < 3; ++i) {
    const float off = c.accelMeanLsb(i) - (i == 2 ? kAccelLsbPerG : 0);  // level: (0, 0, 1 g)
    if (off > kMaxLevelTrimLsb || off < -kMaxLevelTrimLsb) return false;
    trim.lsb[i] = static_cast<int16_t>(off < 0 ? off - 0.5f : off + 0.5f);
  }
  trim_ = trim;
  return true;
}

bool AttitudeEstimator::setLevelTrim(const LevelTrim& trim) {
  for (uint8_t i = 0; i < 3; ++i) {
    if (trim.lsb[i] > kMaxLevelTrimLsb || trim.lsb[i] < -kMaxLevelTrimLsb) return false;
  }
  trim_ = trim;
  return true;
}

// Integer only: the Euler rates times the frames passed, to angle units by one constant gain.
void AttitudeEstimator::propagate(const ImuSample& s, uint8_t frames) {
  int32_t* w = q_.rate;
  for (uint8_t i = 0; i < 3; ++i) w[i] = s.gyro[i] * 16L - bias_q4_[i];
  int32_t roll_rate = w[0] + coupling(w[2], q_.pitch);
  int32_t pitch_rate = w[1] - coupling(w[2], q_.roll);
  if (frames != 1) {
    roll_rate *= frames;
    pitch_rate *= frames;
  }
  q_.roll = heldAngle(q_.roll + applyGain(roll_rate, kAnglePerRateFrame));
  q_.pitch = heldAngle(q_.pitch + applyGain(pitch_rate, kAnglePerRateFrame));
}

Attitude AttitudeEstimator::attitude() const {
  Attitude a;
  a.roll_rad = q_.roll * kRadPerAngleUnit;
  a.pitch_rad = q_.pitch * kRadPerAngleUnit;
  for (uint8_t i = 0; i < 3; ++i) a.rate_rad_s[i] = q_.rate[i] * kRadPerRateUnit;
  return a;
}

bool AttitudeEstimator::accelTrusted(const ImuSample& s) const { return nearOneG(s); }

// estimate + k (measured - estimate), k = interval / kTimeConstantS at most 1; k's gain is made
// again only when the interval changes (fly's is always the same).
int32_t AttitudeEstimator::blend(int32_t estimate, float measured_rad, float interval_s) {
  if (interval_s != blend_interval_s_) {
    const float k = interval_s * (1.0f / kTimeConstantS);
    blend_gain_ = gainOf(k > 1.0f ? 1.0f : k);
    blend_interval_s_ = interval_s;
  }
  return heldAngle(estimate + applyGain(angleUnits(measured_rad) - estimate, blend_gain_));
}

void AttitudeEstimator::correctRoll(const ImuSample& s, float interval_s) {
  if (!accelTrusted(s)) {
    ++untrusted_;
    return;
  }
  const float y = static_cast<float>(s.accel[1] - trim_.lsb[1]);
  q_.roll = blend(q_.roll, atan2Approx(y, static_cast<float>(s.accel[2] - trim_.lsb[2])), interval_s);
}

void AttitudeEstimator::correctPitch(const ImuSample& s, float interval_s) {
  if (!accelTrusted(s)) {
    ++untrusted_;
    return;
  }
  const float x = static_cast<float>(s.accel[0] - trim_.lsb[0]);
  const float y = static_cast<float>(s.accel[1] - trim_.lsb[1]);
  const float z = static_cast<float>(s.accel[2] - trim_.lsb[2]);
  q_.pitch = blend(q_.pitch, atan2Approx(-x, sqrtf(y * y + z * z)), interval_s);
}

}  // namespace fly
