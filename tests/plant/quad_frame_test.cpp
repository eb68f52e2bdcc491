// The tethered lift-off frame.
#include <gtest/gtest.h>

#include <cmath>

#include "plant/plant.hpp"

namespace {

using namespace plant;

std::array<ActuatorParams, 4> identical() {
  const ActuatorParams p = presetParams("kv1100_9x4.7");
  return {p, p, p, p};
}

// Pulse for `thrust_g` per motor on the frame's full pack (close enough for a lift-off).
double pulseFor(const ActuatorParams& p, double thrust_g) {
  return Actuator(p).pulseForThrust_us(thrust_g, 12.0);
}

TEST(QuadFrame, RestsOnTheFloorLevelWithMotorsOff) {
  QuadFrame q(QuadFrameParams{}, identical());
  q.run(1.0);
  const QuadState s = q.state();
  EXPECT_LE(s.height_m, 0.0);
  EXPECT_NEAR(s.tilt_deg, 0.0, 1e-9);
}

TEST(QuadFrame, FourIdenticalMotorsAtEqualThrustRiseStraightToTheRopes) {
  // given four identical motors commanded 350 g each on a 1 kg frame
  const auto motors = identical();
  QuadFrame q(QuadFrameParams{}, motors);
  const double pwm = pulseFor(motors[0], 350.0);
  for (int i = 0; i < 4; ++i) q.holdPulse(i, pwm);
  // when it runs for 3 s
  q.run(3.0);
  // then it has risen to the rope length, level, with no net moment
  const QuadState s = q.state();
  EXPECT_NEAR(s.height_m, q.params().rope_len_m, 0.01);
  EXPECT_LT(s.tilt_deg, 0.01);
  EXPECT_LT(q.maxTilt_deg(), 0.01);  // also on the way up
  EXPECT_NEAR(s.roll_moment_nm, 0.0, 1e-9);
  EXPECT_NEAR(s.pitch_moment_nm, 0.0, 1e-9);
  EXPECT_NEAR(s.yaw_moment_nm, 0.0, 1e-9);
}

TEST(QuadFrame, OneWeakerMotorTiltsTheFrameTowardItAsItLiftsOff) {
  // given motor 0 (front-left) with a propeller giving 15 % less thrust
  auto motors = identical();
  motors[0].prop.ct_low *= 0.85;
  motors[0].prop.ct_high *= 0.85;
  QuadFrame q(QuadFrameParams{}, motors);
  const double pwm = pulseFor(motors[1], 300.0);
  for (int i = 0; i < 4; ++i) q.holdPulse(i, pwm);
  // when all four get the same pulse (no calibration) and it lifts off
  QuadState worst;
  for (int k = 0; k < 3000; ++k) {
    q.step(0.001);
    const QuadState s = q.state();
    if (s.tilt_deg > worst.tilt_deg) worst = s;
  }
  // then it rises crooked: motor 0's corner lags, the others rise, tilt of several degrees
  EXPECT_GT(worst.tilt_deg, 3.0);
  EXPECT_NEAR(q.maxTilt_deg(), worst.tilt_deg, 1e-9);
  for (int i = 1; i < 4; ++i) EXPECT_LT(worst.corner_height_m[0], worst.corner_height_m[i]);
  EXPECT_LT(worst.roll_deg, 0.0);   // left (+y) side down
  EXPECT_GT(worst.pitch_deg, 0.0);  // nose (+x) down
  // and the moments say why
  const QuadState s = q.state();
  EXPECT_LT(s.roll_moment_nm, 0.0);
  EXPECT_GT(s.pitch_moment_nm, 0.0);
  EXPECT_LT(s.thrust_g[0], 0.9 * s.thrust_g[1]);
  // once all four ropes are taut they hold it nearly level, the weak corner still lowest
  for (int i = 1; i < 4; ++i) EXPECT_LT(s.corner_height_m[0], s.corner_height_m[i]);
}

TEST(QuadFrame, SharesOneBatteryThatSagsWithTheTotalCurrent) {
  QuadFrame q(QuadFrameParams{}, identical());
  const double rest = q.power().restingVoltage_v();
  for (int i = 0; i < 4; ++i) q.holdPulse(i, 1600.0);
  q.run(1.0);
  const QuadState s = q.state();
  EXPECT_GT(s.bus_current_a, 15.0);
  const BatteryParams& b = q.params().power;
  EXPECT_NEAR(s.bus_v, rest - s.bus_current_a * (b.r_internal_ohm + b.wiring_r_ohm), 0.3);
}

TEST(QuadFrame, UnequalSpinTorquesShowUpAsYawMoment) {
  auto motors = identical();
  motors[1].prop.cp_low *= 1.2;  // a draggier clockwise propeller
  motors[1].prop.cp_high *= 1.2;
  QuadFrame q(QuadFrameParams{}, motors);
  for (int i = 0; i < 4; ++i) q.holdPulse(i, 1450.0);
  q.run(1.0);
  EXPECT_GT(std::fabs(q.state().yaw_moment_nm), 0.001);
}

}  // namespace
