// fly's estimator alone (firmware/fly/estimator.hpp, linking fly_estimator and the flight types
// only): atan2, the gyro's bias at rest, a static tilt, a rate step, yaw coupling and the
// accelerometer's correction, on samples made here.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "estimator.hpp"

namespace {

using namespace fly;
constexpr double kDeg = M_PI / 180.0;


ImuSample sampleAt(double roll_deg, double pitch_deg, const double (&rate_dps)[3] = {0, 0, 0},
                   const int16_t (&bias_lsb)[3] = {0, 0, 0}, double g = 1.0) {
  const double r = roll_deg * kDeg, p = pitch_deg * kDeg;
  ImuSample s;
  const double a[3] = {-std::sin(p), std::sin(r) * std::cos(p), std::cos(r) * std::cos(p)};
  for (int i = 0; i < 3; ++i) {
    s.accel[i] = static_cast<int16_t>(std::lround(a[i] * g * 4096.0));
    s.gyro[i] = static_cast<int16_t>(std::lround(rate_dps[i] * 16.4) + bias_lsb[i]);
  }
  s.fresh = true;
  return s;
}

TEST(Estimator, Atan2ApproxIsWithinTwoHundredThousandthsOfARadianEverywhere) {
  double worst = 0;
  for (int i = 0; i < 720; ++i) {
    const double angle = (i - 360) * M_PI / 360.0 + 0.001;
    for (double radius : {0.01, 1.0, 4096.0}) {
      const float y = static_cast<float>(radius * std::sin(angle)),
                  x = static_cast<float>(radius * std::cos(angle));
      worst = std::max(worst, std::fabs(static_cast<double>(atan2Approx(y, x)) - std::atan2(y, x)));
    }
  }
  EXPECT_LT(worst, 2e-5);
  EXPECT_EQ(atan2Approx(0, 0), 0.0f);
  EXPECT_NEAR(atan2Approx(1, 0), M_PI / 2, 1e-6);
  EXPECT_NEAR(atan2Approx(0, -1), M_PI, 1e-6);
}

TEST(Estimator, GyroBiasAtRestIsTheMeanAndMotionStartsTheCalibrationAgain) {
  GyroCalibration cal;
  cal.restart();
  const int16_t bias[3] = {100, -50, 20};
  // given: a moving start (30 deg/s about x), then rest with +-3 LSB of noise
  EXPECT_FALSE(cal.add(sampleAt(0, 0, {0, 0, 0}, bias)));
  EXPECT_FALSE(cal.add(sampleAt(0, 0, {30, 0, 0}, bias)));
  EXPECT_EQ(cal.restarts(), 1);
  int n = 0;
  bool done = false;
  while (!done && n < 1000) {
    ImuSample s = sampleAt(0, 0, {0, 0, 0}, bias);
    for (int i = 0; i < 3; ++i) s.gyro[i] = static_cast<int16_t>(s.gyro[i] + (n + 2 * i) % 7 - 3);
    done = cal.add(s);
    ++n;
  }
  // then
  EXPECT_EQ(n, GyroCalibration::kSamples);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(cal.biasLsb(i), bias[i], 0.5) << i;
  EXPECT_NEAR(cal.accelMeanLsb(2), 4096, 1);
}

TEST(Estimator, AnAccelerometerFarFromOneGIsNoRestForTheCalibration) {
  GyroCalibration cal;
  cal.restart();
  for (int n = 0; n < 500; ++n) EXPECT_FALSE(cal.add(sampleAt(0, 0, {0, 0, 0}, {0, 0, 0}, 1.3)));
  EXPECT_FALSE(cal.done());
}

AttitudeEstimator startedAt(double roll_deg, double pitch_deg, const int16_t (&bias)[3] = {0, 0, 0}) {
  GyroCalibration cal;
  cal.restart();
  while (!cal.add(sampleAt(roll_deg, pitch_deg, {0, 0, 0}, bias))) {
  }
  AttitudeEstimator e;
  e.start(cal);
  return e;
}

TEST(Estimator, AStaticTiltIsTheFirstAttitude) {
  const struct { double roll, pitch; } tilts[] = {{0, 0}, {10, -5}, {-30, 20}, {60, 0}, {0, -80}};
  for (const auto& t : tilts) {
    const AttitudeEstimator e = startedAt(t.roll, t.pitch);
    EXPECT_NEAR(e.attitude().roll_rad / kDeg, t.roll, 0.05) << t.roll << " " << t.pitch;
    EXPECT_NEAR(e.attitude().pitch_rad / kDeg, t.pitch, 0.05) << t.roll << " " << t.pitch;
  }
}

TEST(Estimator, ARateStepIntegratesWithTheBiasRemoved) {
  const int16_t bias[3] = {-120, 80, 33};
  AttitudeEstimator e = startedAt(0, 0, bias);
  for (int k = 0; k < 100; ++k) e.propagate(sampleAt(0, 0, {100, 0, 0}, bias), 1);  // 0.25 s, a frame each
  EXPECT_NEAR(e.attitude().roll_rad / kDeg, 25.0, 0.1);
  EXPECT_NEAR(e.attitude().pitch_rad / kDeg, 0.0, 0.01);
  EXPECT_NEAR(e.attitude().rate_rad_s[0] / kDeg, 100.0, 0.05);
  for (int k = 0; k < 100; ++k) e.propagate(sampleAt(25, 0, {0, -40, 0}, bias), 1);
  EXPECT_NEAR(e.attitude().pitch_rad / kDeg, -10.0, 0.1);
}

TEST(Estimator, YawingWhileRolledTurnsRollIntoPitch) {
  AttitudeEstimator e = startedAt(10, 0);
  for (int k = 0; k < 40; ++k) e.propagate(sampleAt(10, 0, {0, 0, 90}), 1);  // 0.1 s at 90 deg/s
  // pitch' = q - r roll: -90 deg/s * 0.1745 rad * 0.1 s = -1.57 deg
  EXPECT_NEAR(e.attitude().pitch_rad / kDeg, -1.57, 0.05);
}

TEST(Estimator, TheAccelerometerPullsADriftedEstimateBackWithItsTimeConstant) {
  AttitudeEstimator e = startedAt(0, 0);
  // the vehicle is at roll 5, pitch -3 deg, still; the estimate says level
  const ImuSample s = sampleAt(5, -3);
  const float interval_s = 8 * 0.0025f;
  const int per_tau = static_cast<int>(AttitudeEstimator::kTimeConstantS / interval_s + 0.5f);
  for (int k = 0; k < per_tau; ++k) {
    e.correctRoll(s, interval_s);
    e.correctPitch(s, interval_s);
  }
  EXPECT_NEAR(e.attitude().roll_rad / kDeg, 5.0 * (1 - std::exp(-1.0)), 0.1) << "one time constant";
  for (int k = 0; k < 6 * per_tau; ++k) {
    e.correctRoll(s, interval_s);
    e.correctPitch(s, interval_s);
  }
  EXPECT_NEAR(e.attitude().roll_rad / kDeg, 5.0, 0.02);
  EXPECT_NEAR(e.attitude().pitch_rad / kDeg, -3.0, 0.02);
  // a specific force far from 1 g (a jolt) says nothing of tilt: ignored
  const float before = e.attitude().roll_rad;
  e.correctRoll(sampleAt(40, 0, {0, 0, 0}, {0, 0, 0}, 1.4), interval_s);
  EXPECT_EQ(e.attitude().roll_rad, before);
  EXPECT_EQ(e.untrustedAccel(), 1u);
}


// The angle unit does not depend on the loop rate: a rate held for a second turns the estimate
// by that rate's angle whether it comes in 400 frames or in 200 late ones of two frames each.
TEST(Estimator, AnglesAreTheSameWhateverTheFramesTheRateCameIn) {
  AttitudeEstimator every = startedAt(0, 0), late = startedAt(0, 0);
  for (int k = 0; k < kLoopHz; ++k) every.propagate(sampleAt(0, 0, {30, -12, 0}), 1);
  for (int k = 0; k < kLoopHz / 2; ++k) late.propagate(sampleAt(0, 0, {30, -12, 0}), 2);
  EXPECT_NEAR(every.attitude().roll_rad / kDeg, 30.0, 0.02);
  EXPECT_NEAR(every.attitude().pitch_rad / kDeg, -12.0, 0.02);
  EXPECT_NEAR(late.attitude().roll_rad, every.attitude().roll_rad, 2 * kRadPerAngleUnit * kLoopHz);
  EXPECT_NEAR(late.attitude().pitch_rad, every.attitude().pitch_rad, 2 * kRadPerAngleUnit * kLoopHz);
}

TEST(Estimator, ASavedLevelTrimIsTakenWithinItsLimitAndRefusedBeyond) {
  AttitudeEstimator e;
  LevelTrim trim;
  trim.lsb[0] = 160;  // 39 mg
  trim.lsb[2] = -AttitudeEstimator::kMaxLevelTrimLsb;
  EXPECT_TRUE(e.setLevelTrim(trim));
  EXPECT_EQ(e.levelTrimLsb(0), 160);
  trim.lsb[1] = AttitudeEstimator::kMaxLevelTrimLsb + 1;
  EXPECT_FALSE(e.setLevelTrim(trim));
  EXPECT_EQ(e.levelTrimLsb(1), 0) << "the trim before kept";
}

}  // namespace
