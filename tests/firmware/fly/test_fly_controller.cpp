// fly's attitude controller alone (firmware/fly/controller.hpp, linking fly_controller and the
// flight types only): the thesis's gains, P on the angle and D on the measured rate in angle
// mode, a PI on the rate in rate mode, the integrators, and the fixed-point frame path against
// the law in N m.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "controller.hpp"

namespace {

using namespace fly;
constexpr double kG0 = 9.80665;
constexpr double kDeg = M_PI / 180.0;
// The mixer's scale on the plus layout, 0.225 m arms, Q/T 14.9 mm (as Mixer works it out).
constexpr float kDgPerNmXy = 10.0f * 1000.0f / 9.80665f / (2.0f * 0.225f);
constexpr float kDgPerNmZ = 10.0f * 1000.0f / 9.80665f / (4.0f * 0.0149f);

ControllerSettings settings(const AxisGains& angle, const YawGains& yaw) {
  ControllerSettings s;
  s.angle = angle;
  s.yaw = yaw;
  return s;
}


TEST(Controller, TheThesisGainsAreKp22AndKd04ConvertedToTorqueOnTheIqarus) {
  // 2.2 us/deg and 0.4 us/(deg/s) on two opposite motors 0.225 m out, 1.44 g/us (table 5.1:
  // 300 g at 1514 us, thrust from ~1097 us, F ~ (pwm - start)^2).
  const double slope_g_per_us = 2.0 * 300.0 / (1514.0 - 1097.0);
  const double nm_per_us_per_motor_pair = slope_g_per_us * 2.0 * 0.225 * kG0 / 1000.0;
  EXPECT_NEAR(kThesisGains.kp_nm_per_rad, 2.2 * nm_per_us_per_motor_pair / kDeg, 0.001);
  EXPECT_NEAR(kThesisGains.kd_nm_s_per_rad, 0.4 * nm_per_us_per_motor_pair / kDeg, 0.001);
  EXPECT_EQ(kThesisGains.ki_nm_per_rad_s, 0.0f) << "the thesis flew a PD";
}

TEST(Controller, ProportionalOnTheAngleErrorDerivativeOnTheMeasuredRate) {
  AttitudeController c;
  c.setSettings(settings({0.8f, 0.0f, 0.15f}, {0.1f, 0.0f}));
  Attitude a;
  a.roll_rad = 0.1f;
  a.pitch_rad = -0.05f;
  a.rate_rad_s[0] = 0.5f;
  a.rate_rad_s[1] = 0.0f;
  a.rate_rad_s[2] = 0.2f;
  Setpoint sp;
  sp.pitch_rad = 0.05f;
  const Torque t = c.torque(a, sp);
  EXPECT_NEAR(t.x_nm, 0.8 * -0.1 - 0.15 * 0.5, 1e-6);
  EXPECT_NEAR(t.y_nm, 0.8 * 0.1, 1e-6);
  EXPECT_NEAR(t.z_nm, 0.1 * -0.2, 1e-6);
  // a setpoint step changes the torque by kp times the step, no more (no derivative kick)
  Setpoint step = sp;
  step.roll_rad += 0.2f;
  EXPECT_NEAR(c.torque(a, step).x_nm - t.x_nm, 0.8 * 0.2, 1e-6);
}

TEST(Controller, IntegratorsAccumulateClampHoldWhenTheMixerLimitsAndReset) {
  AttitudeController c;
  c.setSettings(settings({0.0f, 2.0f, 0.0f}, {0.0f, 1.0f}));
  Attitude a;
  a.rate_rad_s[2] = -0.5f;
  Setpoint sp;
  sp.roll_rad = 0.1f;
  c.integrate(a, sp, 0.0025f, 0);
  EXPECT_NEAR(c.integralNm(0), 2.0 * 0.1 * 0.0025, 1e-7);
  EXPECT_NEAR(c.integralNm(2), 1.0 * 0.5 * 0.0025, 1e-7);
  c.integrate(a, sp, 0.0025f, kMixRollPitchLimited);
  EXPECT_NEAR(c.integralNm(0), 2.0 * 0.1 * 0.0025, 1e-7) << "held while roll/pitch are limited";
  EXPECT_NEAR(c.integralNm(2), 2 * 1.0 * 0.5 * 0.0025, 1e-7);
  for (int i = 0; i < 10000; ++i) c.integrate(a, sp, 0.0025f, kMixYawLimited);
  EXPECT_FLOAT_EQ(c.integralNm(0), AttitudeController::kIntegralMaxNm);
  EXPECT_NEAR(c.integralNm(2), 2 * 1.0 * 0.5 * 0.0025, 1e-7) << "yaw held";
  EXPECT_NEAR(c.torque(a, sp).x_nm, AttitudeController::kIntegralMaxNm, 1e-6);
  c.reset();
  EXPECT_EQ(c.integralNm(0), 0.0f);
  EXPECT_EQ(c.integralNm(2), 0.0f);
}

// The frame path (torqueDg on the estimator's fixed-point units, in the mixer's decigrams) is the
// law torque() writes in N m, times the mixer's scale: within a decigram or two per term, in both
// flight modes.
TEST(Controller, TheFixedPointTorqueIsTheLawTimesTheMixersScaleInBothModes) {
  AttitudeController c;
  ControllerSettings s = settings({0.8f, 0.0f, 0.146f}, {0.1f, 0.0f});
  s.rate = {0.2f, 0.0f};
  c.setSettings(s);
  c.setForceScale(kDgPerNmXy, kDgPerNmZ);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> angle(-0.6, 0.6), rate(-6.0, 6.0);
  for (int k = 0; k < 2000; ++k) {
    AttitudeQ q;
    q.roll = angleUnits(static_cast<float>(angle(rng)));
    q.pitch = angleUnits(static_cast<float>(angle(rng)));
    for (int32_t& r : q.rate) r = static_cast<int32_t>(std::lround(rate(rng) / kRadPerRateUnit));
    Setpoint sp;
    sp.mode = k % 2 ? FlightMode::kRate : FlightMode::kAngle;
    sp.roll_rad = static_cast<float>(angle(rng) / 3);
    sp.pitch_rad = static_cast<float>(angle(rng) / 3);
    sp.roll_rate_rad_s = static_cast<float>(rate(rng) / 3);
    sp.pitch_rate_rad_s = static_cast<float>(rate(rng) / 3);
    sp.yaw_rate_rad_s = static_cast<float>(rate(rng) / 6);
    Attitude a;  // the same state in radians, in double first
    a.roll_rad = static_cast<float>(q.roll * static_cast<double>(kRadPerAngleUnit));
    a.pitch_rad = static_cast<float>(q.pitch * static_cast<double>(kRadPerAngleUnit));
    for (int i = 0; i < 3; ++i) a.rate_rad_s[i] = static_cast<float>(q.rate[i] * static_cast<double>(kRadPerRateUnit));
    const Torque t = c.torque(a, sp);
    const TorqueDg f = c.torqueDg(q, fixedSetpoint(sp));
    ASSERT_NEAR(f.x, t.x_nm * kDgPerNmXy, 2.0) << k;
    ASSERT_NEAR(f.y, t.y_nm * kDgPerNmXy, 2.0) << k;
    ASSERT_NEAR(f.z, t.z_nm * kDgPerNmZ, 2.0) << k;
  }
}


TEST(Controller, RateModeHoldsTheBodyRatesWithAPiAndIgnoresTheAngles) {
  AttitudeController c;
  ControllerSettings s = settings({0.8f, 0.0f, 0.146f}, {0.1f, 0.0f});
  s.rate = {0.2f, 0.5f};
  c.setSettings(s);
  Attitude a;
  a.roll_rad = 0.3f;  // far off level: rate mode does not care
  a.rate_rad_s[0] = 0.5f;
  a.rate_rad_s[1] = -0.2f;
  Setpoint sp;
  sp.mode = FlightMode::kRate;
  sp.roll_rate_rad_s = 1.0f;
  const Torque t = c.torque(a, sp);
  EXPECT_NEAR(t.x_nm, 0.2 * (1.0 - 0.5), 1e-6);
  EXPECT_NEAR(t.y_nm, 0.2 * 0.2, 1e-6);
  EXPECT_TRUE(c.integrating(FlightMode::kRate));
  EXPECT_FALSE(c.integrating(FlightMode::kAngle)) << "angle mode has no integral gain here";
  c.integrate(a, sp, 0.0025f, 0);
  EXPECT_NEAR(c.integralNm(0), 0.5 * 0.5 * 0.0025, 1e-7) << "the rate error integrated";
  EXPECT_NEAR(c.integralNm(1), 0.5 * 0.2 * 0.0025, 1e-7);
}

}  // namespace
