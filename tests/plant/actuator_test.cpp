// ESC + motor + propeller behaviour in time.
#include <gtest/gtest.h>

#include <cmath>

#include "plant/plant.hpp"

namespace {

using namespace plant;

// Sends pulses of width pulse_us at frame_hz for duration_s, stepping the actuator at 1 ms.
void drive(Actuator& a, double pulse_us, double frame_hz, double duration_s, double bus_v = 11.1) {
  const double dt = 0.001;
  const double period = 1.0 / frame_hz;
  double next_pulse = a.time_s();
  const double end = a.time_s() + duration_s - 0.5 * dt;
  while (a.time_s() < end) {
    while (next_pulse <= a.time_s() + dt) {
      a.setPulse(pulse_us, next_pulse);
      next_pulse += period;
    }
    a.step(dt, bus_v);
  }
}

TEST(Esc, DoesNotArmBeforeOneSecondOfMinimumThrottle) {
  Actuator a(presetParams("kv1100_9x4.7"));
  drive(a, 1000.0, 50.0, 0.8);
  EXPECT_FALSE(a.isArmed());
  drive(a, 1000.0, 50.0, 0.4);
  EXPECT_TRUE(a.isArmed());
}

TEST(Esc, NeverArmsWhenTheFirstPulsesAreAboveMinimumThrottle) {
  Actuator a(presetParams("kv1100_9x4.7"));
  drive(a, 1500.0, 50.0, 3.0);
  EXPECT_FALSE(a.isArmed());
  EXPECT_EQ(a.rpm(), 0.0);
}

TEST(Esc, SpinsAfterArmingAndStopsAndDisarmsWhenPulsesStop) {
  // given an armed ESC running at 1500 us
  Actuator a(presetParams("kv1100_9x4.7"));
  drive(a, 1000.0, 50.0, 1.2);
  drive(a, 1500.0, 50.0, 1.0);
  ASSERT_GT(a.thrust_g(), 200.0);
  // when no pulse arrives for longer than the timeout
  for (int i = 0; i < 300; ++i) a.step(0.001, 11.1);
  // then it is disarmed and the motor coasts down
  EXPECT_FALSE(a.isArmed());
  for (int i = 0; i < 3000; ++i) a.step(0.001, 11.1);
  EXPECT_LT(a.rpm(), 50.0);
  // and pulses at 1500 us do not restart it without re-arming
  drive(a, 1500.0, 50.0, 1.0);
  EXPECT_LT(a.thrust_g(), 1.0);
}

struct FrameCase {
  double frame_hz;
  bool rejects_some;
};

class EscFrameRate : public testing::TestWithParam<FrameCase> {};

TEST_P(EscFrameRate, AcceptsFiftyToFourHundredNinetyHertzAndDropsPulsesFasterThanFiveHundred) {
  // given pulses at the frame rate for 1.5 s
  Actuator a(presetParams("kv1100_9x4.7"));
  drive(a, 1000.0, GetParam().frame_hz, 1.5);
  // then servo rates are all accepted; faster trains lose pulses (the rest still arm it)
  EXPECT_TRUE(a.isArmed());
  if (GetParam().rejects_some) {
    EXPECT_GT(a.rejectedPulses(), 100u);
  } else {
    EXPECT_EQ(a.rejectedPulses(), 0u);
  }
}

INSTANTIATE_TEST_SUITE_P(Rates, EscFrameRate,
                         testing::Values(FrameCase{50.0, false}, FrameCase{400.0, false},
                                         FrameCase{490.0, false}, FrameCase{1000.0, true}));

TEST(Esc, IgnoresPulsesOutsideTheServoRange) {
  Actuator a(presetParams("kv1100_9x4.7"));
  a.setPulse(500.0, 0.0);
  a.setPulse(2500.0, 0.02);
  EXPECT_EQ(a.rejectedPulses(), 2u);
  EXPECT_EQ(a.acceptedPulses(), 0u);
}

TEST(Esc, GivesNoThrustBelowTheStartPulse) {
  const Actuator a(presetParams("kv1100_9x4.7"));
  EXPECT_EQ(a.steadyState(1080.0, 12.6).thrust_g, 0.0);
  EXPECT_GT(a.steadyState(1200.0, 12.6).thrust_g, 5.0);
}

TEST(Actuator, TimeSteppingSettlesOnTheSteadyState) {
  // given a held pulse on a fixed 11.1 V bus
  Actuator a(presetParams("kv1100_9x4.7"));
  a.holdPulse(1550.0);
  // when we step for 2 s at 1 ms
  for (int i = 0; i < 2000; ++i) a.step(0.001, 11.1);
  // then thrust, rpm and current equal the steady-state solution (warm-up aside)
  a.setWindingTemp_c(a.environment().temp_c);
  const OperatingPoint ss = a.steadyState(1550.0, 11.1);
  EXPECT_NEAR(a.rpm(), ss.rpm, 0.01 * ss.rpm);
  EXPECT_NEAR(a.thrust_g(), ss.thrust_g, 0.02 * ss.thrust_g);
}

TEST(Actuator, LargeStepsStayStable) {
  Actuator a(presetParams("kv1100_9x4.7"));
  a.holdPulse(1700.0);
  for (int i = 0; i < 200; ++i) a.step(0.01, 11.1);
  const OperatingPoint ss = a.steadyState(1700.0, 11.1);
  EXPECT_NEAR(a.rpm(), ss.rpm, 0.03 * ss.rpm);
}

TEST(Actuator, SustainedLoadWarmsTheWindingAndLowersEfficiency) {
  // given the motor at high throttle
  Actuator a(presetParams("kv1100_9x4.7"));
  a.holdPulse(1650.0);
  for (int i = 0; i < 1000; ++i) a.step(0.001, 11.1);
  const double g_per_w_cold = a.thrust_g() / (a.busCurrent_a() * 11.1);
  const double rpm_cold = a.rpm();
  // when it runs for two minutes
  for (int i = 0; i < 120000; ++i) a.step(0.001, 11.1);
  // then the winding is warmer than the air; R up and flux down cost efficiency, and the
  // weaker magnets let it spin a little faster at the same pulse (Kv rises)
  EXPECT_GT(a.windingTemp_c(), a.environment().temp_c + 10.0);
  const double g_per_w_hot = a.thrust_g() / (a.busCurrent_a() * 11.1);
  EXPECT_LT(g_per_w_hot, 0.99 * g_per_w_cold);
  EXPECT_GT(a.rpm(), rpm_cold);
  // and after the motor stops it cools down again
  a.holdPulse(1000.0);
  for (int i = 0; i < 600000; ++i) a.step(0.001, 11.1);
  EXPECT_LT(a.windingTemp_c(), a.environment().temp_c + 2.0);
}

TEST(Actuator, ThinAirGivesLessThrustAtTheSamePulse) {
  Environment sea;  // 20 C, 101325 Pa
  Environment hot_high{35.0, 90000.0};
  EXPECT_NEAR(sea.airDensity_kg_per_m3(), 1.204, 0.001);
  const Actuator a_sea(presetParams("kv1100_9x4.7"), sea);
  const Actuator a_high(presetParams("kv1100_9x4.7"), hot_high);
  const double t_sea = a_sea.steadyState(1500.0, 11.1).thrust_g;
  const double t_high = a_high.steadyState(1500.0, 11.1).thrust_g;
  EXPECT_LT(t_high, 0.95 * t_sea);
  EXPECT_GT(t_high, 0.80 * t_sea);
}

TEST(Actuator, PulseForThrustInvertsTheSteadyState) {
  const Actuator a(presetParams("kv1100_9x4.7"));
  for (double g : {50.0, 200.0, 400.0}) {
    const double pwm = a.pulseForThrust_us(g, 11.1);
    EXPECT_NEAR(a.steadyState(pwm, 11.1).thrust_g, g, 0.1);
  }
  EXPECT_EQ(a.pulseForThrust_us(5000.0, 11.1), a.params().esc.full_us);
}

}  // namespace
