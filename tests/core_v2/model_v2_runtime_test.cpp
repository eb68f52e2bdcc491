// Model v2 at run time: the bus voltage filter and force -> PWM in fixed point, with every
// edge (saturation, no model, bad voltage, clamping), headroom, the inverse, and the sag
// prediction on command steps.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "synthetic_motor.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/model_v2_curve.hpp"

using tc_test::SyntheticMotor;

namespace {

tc::BusVoltageFilter busAt(uint16_t mv) {
  tc::BusVoltageFilter bus;
  bus.reset(mv);
  return bus;
}

uint16_t exactRecip(uint16_t mv) { return static_cast<uint16_t>(tc::kRecipOne / mv); }

const tc::ModelV2& model12V4() {
  static const tc::ModelV2 m = tc_test::fittedModel(SyntheticMotor(), 12.4);
  return m;
}

}  // namespace

// ---- BusVoltageFilter ----------------------------------------------------------------------

TEST(BusVoltageFilter, IsInvalidUntilTheFirstSaneSample) {
  tc::BusVoltageFilter bus;
  EXPECT_FALSE(bus.isValid());
  bus.update(2900);  // below 3 V (one empty cell): ignored
  EXPECT_FALSE(bus.isValid());
  EXPECT_EQ(bus.rejected, 1);
  bus.update(11100);
  EXPECT_TRUE(bus.isValid());
  EXPECT_EQ(bus.mv, 11100);
  EXPECT_EQ(bus.recip_q27, exactRecip(11100));
}

TEST(BusVoltageFilter, MovesOneEighthOfTheWayPerFrameAndSettlesExactly) {
  // given: steady at 12000 mV, then the reading drops to 11200 mV
  tc::BusVoltageFilter bus = busAt(12000);
  // when / then: y_n = 11200 + 800 * (7/8)^n, rounded
  const struct {
    int frame;
    uint16_t expect_mv;
  } rows[] = {{1, 11900}, {2, 11813}, {3, 11736}, {8, 11475}, {16, 11294}, {200, 11200}};
  int frame = 0;
  for (const auto& r : rows) {
    while (frame < r.frame) {
      bus.update(11200);
      ++frame;
    }
    EXPECT_NEAR(bus.mv, r.expect_mv, 1) << "frame " << r.frame;
  }
  EXPECT_EQ(bus.mv, 11200);
}

TEST(BusVoltageFilter, ReciprocalTracksADrainingPackWithoutDivisions) {
  // given: a pack draining 12.6 V -> 9.9 V over 3000 frames (a minute at 50 Hz) with ADC steps
  tc::BusVoltageFilter bus = busAt(12600);
  int worst_lsb = 0;
  for (int i = 0; i <= 3000; ++i) {
    const uint16_t sample = static_cast<uint16_t>(12600 - (2700 * i) / 3000 + ((i * 7) % 31) - 15);
    bus.update(sample);
    worst_lsb = std::max(worst_lsb, std::abs(int(bus.recip_q27) - int(exactRecip(bus.mv))));
  }
  // then: the Newton step alone kept the reciprocal within 1 LSB (relative 2e-5 at 10 V)
  EXPECT_LE(worst_lsb, 1);
  EXPECT_EQ(bus.reseeds, 0);
}

TEST(BusVoltageFilter, ReseedsByDivisionAfterAJumpAndIgnoresInsaneSamples) {
  tc::BusVoltageFilter bus = busAt(12000);
  bus.shift = 0;  // no filtering: the reading itself
  bus.update(8000);  // -33 %: beyond a Newton step
  EXPECT_EQ(bus.mv, 8000);
  EXPECT_EQ(bus.reseeds, 1);
  EXPECT_EQ(bus.recip_q27, exactRecip(8000));
  bus.update(26100);  // above 26 V (six full cells and the divider's tolerance): ignored
  bus.update(0);
  EXPECT_EQ(bus.mv, 8000);
  EXPECT_EQ(bus.rejected, 2);
  bus.reset(2500);  // insane reset: invalid
  EXPECT_FALSE(bus.isValid());
}

// ---- forceToPwmV2 --------------------------------------------------------------------------

TEST(ForceToPwmV2, EdgeCasesHaveDefinedResultsAndFlags) {
  const tc::ModelV2& m = model12V4();
  ASSERT_TRUE(m.isPresent());
  tc::ForcePwmLimits limits;
  tc::ForcePwmLimits high_min;
  high_min.pwm_min_us = 1150;
  const tc::ModelV2 none;
  const tc::BusVoltageFilter invalid;
  const SyntheticMotor motor;  // the motor model12V4() was fitted on
  const uint16_t pwm_300g_12v = static_cast<uint16_t>(std::lround(motor.truePwmUs(300.0, 12.0)));
  const uint16_t pwm_300g_rest =
      static_cast<uint16_t>(std::lround(motor.truePwmUs(300.0, m.rest_mv / 1000.0)));
  const uint16_t pwm_end_17v =
      static_cast<uint16_t>(std::lround(motor.truePwmUs(m.maxForceDg() / 10.0, 17.0)));
  struct Row {
    const char* name;
    const tc::ModelV2* model;
    uint16_t force_dg;
    tc::BusVoltageFilter bus;
    tc::ForcePwmLimits limits;
    uint16_t expect_pwm_lo, expect_pwm_hi;
    uint8_t expect_flags;
  };
  const Row rows[] = {
      {"no model", &none, 3000, busAt(12000), limits, 1000, 1000, tc::kNotCalibrated},
      {"force 0 stops", &m, 0, busAt(12000), limits, 1000, 1000, tc::kStopped},
      {"300 g at 12 V", &m, 3000, busAt(12000), limits, uint16_t(pwm_300g_12v - 2),
       uint16_t(pwm_300g_12v + 2), 0},
      {"beyond the curve: its last knot", &m, 20000, busAt(17000), limits,
       uint16_t(pwm_end_17v - 2), uint16_t(pwm_end_17v + 2), tc::kSaturated},
      {"600 g at 9 V: not enough voltage", &m, 6000, busAt(9000), limits, 2000, 2000, tc::kSaturated},
      {"no voltage: rest voltage used", &m, 3000, invalid, limits, uint16_t(pwm_300g_rest - 2),
       uint16_t(pwm_300g_rest + 2), tc::kVoltageInvalid},
      {"0.1 g below the ESC minimum", &m, 1, busAt(12000), high_min, 1150, 1150, tc::kClamped},
  };
  for (const Row& r : rows) {
    SCOPED_TRACE(r.name);
    const tc::ForcePwmResult res = tc::forceToPwmV2(*r.model, r.force_dg, r.bus, r.limits);
    EXPECT_GE(res.pwm_us, r.expect_pwm_lo);
    EXPECT_LE(res.pwm_us, r.expect_pwm_hi);
    EXPECT_EQ(res.flags, r.expect_flags);
  }
}

TEST(ForceToPwmV2, InvalidVoltageFallsBackToTheCalibrationVoltage) {
  const tc::ModelV2& m = model12V4();
  const tc::BusVoltageFilter invalid;
  const tc::ForcePwmResult at_rest = tc::forceToPwmV2(m, 3000, busAt(m.rest_mv));
  const tc::ForcePwmResult fallback = tc::forceToPwmV2(m, 3000, invalid);
  EXPECT_EQ(fallback.pwm_us, at_rest.pwm_us);
}

TEST(ForceToPwmV2, PwmRisesWithForceAndFallsWithVoltage) {
  const tc::ModelV2& m = model12V4();
  for (uint16_t mv = 9900; mv <= 12600; mv += 300) {
    uint16_t prev = 0;
    for (uint16_t f_dg = 100; f_dg <= 4500; f_dg += 50) {
      const uint16_t pwm = tc::forceToPwmV2(m, f_dg, busAt(mv)).pwm_us;
      EXPECT_GE(pwm, prev) << f_dg << " dg at " << mv << " mV";
      prev = pwm;
    }
  }
  for (uint16_t f_dg = 1000; f_dg <= 4500; f_dg += 500) {
    uint16_t prev = 2000;
    for (uint16_t mv = 9900; mv <= 12600; mv += 100) {
      const uint16_t pwm = tc::forceToPwmV2(m, f_dg, busAt(mv)).pwm_us;
      EXPECT_LE(pwm, prev) << f_dg << " dg at " << mv << " mV";
      prev = pwm;
    }
  }
}

TEST(ForceToPwmV2, FollowsTheThesisTable5p1ShapeAt300Grams) {
  // given: a motor fitted at 12.4 V; table 5.1 says (PWM - 1097) * V is constant at 300 g
  const tc::ModelV2& m = model12V4();
  const uint16_t pwm_12v = tc::forceToPwmV2(m, 3000, busAt(12000)).pwm_us;
  for (uint16_t mv : {9700, 10500, 11000, 12500, 13000, 14000}) {
    const uint16_t pwm = tc::forceToPwmV2(m, 3000, busAt(mv)).pwm_us;
    const double product_ratio = (pwm - 1097.0) * mv / ((pwm_12v - 1097.0) * 12000.0);
    EXPECT_NEAR(product_ratio, 1.0, 0.01) << mv << " mV";
  }
}

TEST(ForceToPwmV2, GramsWrapperEqualsDecigrams) {
  const tc::ModelV2& m = model12V4();
  const tc::BusVoltageFilter bus = busAt(11000);
  for (uint16_t g : {1, 50, 100, 333, 450}) {
    const tc::ForcePwmResult a = tc::forceGramsToPwmV2(m, g, bus);
    const tc::ForcePwmResult b = tc::forceToPwmV2(m, static_cast<uint16_t>(g * 10), bus);
    EXPECT_EQ(a.pwm_us, b.pwm_us);
    EXPECT_EQ(a.flags, b.flags);
  }
  EXPECT_EQ(tc::forceGramsToPwmV2(m, 60000, bus).flags, tc::kSaturated);
}

// ---- headroom and the inverse --------------------------------------------------------------

TEST(HeadroomV2, IsTheForceAtFullThrottleAtThePresentVoltage) {
  const SyntheticMotor motor;
  const tc::ModelV2& m = model12V4();
  for (uint16_t mv : {9900, 10500, 11100, 11700}) {
    SCOPED_TRACE(mv);
    const uint16_t head_dg = tc::headroomDg(m, mv);
    EXPECT_NEAR(head_dg / 10.0, motor.forceG(2000, mv / 1000.0), motor.forceG(2000, mv / 1000.0) * 0.01);
    // just below the headroom: not saturated; above it: saturated at full throttle
    EXPECT_EQ(tc::forceToPwmV2(m, static_cast<uint16_t>(head_dg - 20), busAt(mv)).flags, 0);
    const tc::ForcePwmResult over = tc::forceToPwmV2(m, static_cast<uint16_t>(head_dg + 50), busAt(mv));
    EXPECT_EQ(over.flags, tc::kSaturated);
    EXPECT_EQ(over.pwm_us, 2000);
  }
  // above the calibration voltage the curve's end caps it
  EXPECT_EQ(tc::headroomDg(m, 16000), m.maxForceDg());
  EXPECT_EQ(tc::headroomDg(tc::ModelV2(), 12000), 0);
}

TEST(ForceForPwmV2, InvertsForceToPwmWithinOneMicrosecondOfPwm) {
  const tc::ModelV2& m = model12V4();
  for (uint16_t mv : {9900, 11000, 12600}) {
    for (uint16_t f_dg = 500; f_dg <= 4500; f_dg += 250) {
      const uint16_t pwm = tc::forceToPwmV2(m, f_dg, busAt(mv)).pwm_us;
      const uint16_t lo = tc::forceForPwmDg(m, static_cast<uint16_t>(pwm - 1), mv);
      const uint16_t hi = tc::forceForPwmDg(m, static_cast<uint16_t>(pwm + 1), mv);
      EXPECT_LE(lo, f_dg) << f_dg << " dg at " << mv;
      EXPECT_GE(hi, f_dg) << f_dg << " dg at " << mv;
    }
  }
  EXPECT_EQ(tc::forceForPwmDg(m, 1000, 12000), 0) << "below the start threshold";
}

// ---- sag prediction ------------------------------------------------------------------------

TEST(ForceToPwmV2, SagPredictionSendsTheSteadyStatePwmOnTheFirstFrameOfAStep) {
  // given: a soft source (0.1 ohm) on the bench and in the air, a motor at 100 g
  SyntheticMotor motor;
  motor.source_r_ohm = 0.1;
  const tc::ModelV2 m = tc_test::fittedModel(motor, 12.4);
  ASSERT_TRUE(m.isPresent());
  const double rest_v = 12.0;
  const double pwm_100 = motor.truePwmUs(100.0, rest_v);  // near enough for the voltage
  double f = 0, v_now = 0, v_400 = 0;
  motor.operatingPoint(pwm_100, rest_v, f, v_now);
  motor.operatingPoint(motor.truePwmUs(400.0, rest_v - 0.1 * motor.currentA(400.0)), rest_v, f, v_400);
  const tc::BusVoltageFilter now = busAt(static_cast<uint16_t>(std::lround(v_now * 1000)));
  const tc::BusVoltageFilter later = busAt(static_cast<uint16_t>(std::lround(v_400 * 1000)));
  // when: the command steps from 100 g to 400 g
  const int plain = tc::forceToPwmV2(m, 4000, now).pwm_us;
  const int predicted = tc::forceToPwmV2(m, 4000, now, 1000).pwm_us;
  const int steady = tc::forceToPwmV2(m, 4000, later).pwm_us;
  // then: the prediction lands within 2 us of the steady state, the plain call does not
  EXPECT_GT(std::abs(plain - steady), 6);
  EXPECT_LE(std::abs(predicted - steady), 2);
  // and in steady state (command == present force) both calls agree
  EXPECT_EQ(tc::forceToPwmV2(m, 4000, later, 4000).pwm_us, steady);
}

TEST(ForceToPwmV2, SagPredictionMatchesTheFormulaEvenWhereTheSagTableIsSteep) {
  // given: a model whose sag jumps by 2 V between 60 g and 66 g (far steeper than any pack:
  // more than 127 units of 10 mV between two knots) and the synthetic motor's curve
  const SyntheticMotor motor;
  std::vector<double> drive, force, sag;
  for (int i = 1; i <= 200; ++i) {
    const double f = i * 3.0;
    force.push_back(f);
    drive.push_back(motor.span_us * std::pow(f / motor.k(), 1.0 / motor.exponent));
    sag.push_back(f < 60 ? 0.0 : (f < 66 ? (f - 60) * 333.0 : 2000.0));
  }
  tc::ModelV2 m;
  ASSERT_TRUE(tc::modelV2FromCurve(m, motor.start_us, drive.data(), force.data(), 200, 12400.0,
                                   sag.data()));
  auto sagAt = [&](double f_dg) {  // the model's own table, linear between knots, in mV
    double f_lo = 0.0, s_lo = 0.0;
    for (uint8_t k = 0; k < m.knots; ++k) {
      const double f_hi = m.knotForceDg(k), s_hi = m.sag_10mv[k] * 10.0;
      if (f_dg <= f_hi) return s_lo + (f_dg - f_lo) / (f_hi - f_lo) * (s_hi - s_lo);
      f_lo = f_hi;
      s_lo = s_hi;
    }
    return s_lo;
  };
  const tc::BusVoltageFilter bus = busAt(12000);
  int steep = 0;
  for (uint8_t k = 1; k < m.knots; ++k) steep += m.sag_10mv[k] - m.sag_10mv[k - 1] > 127;
  ASSERT_GT(steep, 0) << "the table must hold a jump of more than 127 units";
  for (uint16_t now_dg : {100, 500, 650, 900, 1500}) {
    for (uint16_t cmd_dg : {150, 620, 680, 700, 720, 800, 950, 2000}) {
      SCOPED_TRACE(::testing::Message() << now_dg << " -> " << cmd_dg << " dg");
      // when
      const int plain = tc::forceToPwmV2(m, cmd_dg, bus).pwm_us;
      const int predicted = tc::forceToPwmV2(m, cmd_dg, bus, now_dg).pwm_us;
      // then: duty * (1 + delta + delta^2) with delta = (sag(cmd) - sag(now)) / V
      const double delta = (sagAt(cmd_dg) - sagAt(now_dg)) / 12000.0;
      const double duty = plain - m.start_q4_us / 16.0;
      const double expect = m.start_q4_us / 16.0 + duty * (1.0 + delta + delta * delta);
      EXPECT_NEAR(predicted, expect, 1.0);
    }
  }
}

TEST(ForceToPwmV2, SagPredictionHandlesNoVoltageAndForcesBeyondTheCurve) {
  SyntheticMotor motor;
  motor.source_r_ohm = 0.1;
  const tc::ModelV2 m = tc_test::fittedModel(motor, 12.4);
  const tc::BusVoltageFilter invalid;
  // no bus voltage: the rest voltage, flagged, like the plain call
  const tc::ForcePwmResult r = tc::forceToPwmV2(m, 3000, invalid, 3000);
  EXPECT_EQ(r.flags, tc::kVoltageInvalid);
  EXPECT_EQ(r.pwm_us, tc::forceToPwmV2(m, 3000, invalid).pwm_us);
  // from beyond the curve down to 300 g: the sag shrinks, so less PWM than in steady state
  const tc::BusVoltageFilter bus = busAt(11000);
  const tc::ForcePwmResult down = tc::forceToPwmV2(m, 3000, bus, 30000);
  EXPECT_EQ(down.flags, 0);
  EXPECT_LT(down.pwm_us, tc::forceToPwmV2(m, 3000, bus).pwm_us);
  // up to beyond the curve: saturated like the plain call
  EXPECT_EQ(tc::forceToPwmV2(m, 30000, bus, 1000).flags & tc::kSaturated, tc::kSaturated);
  EXPECT_EQ(tc::forceToPwmV2(tc::ModelV2(), 3000, bus, 1000).flags, tc::kNotCalibrated);
  EXPECT_EQ(tc::forceToPwmV2(m, 0, bus, 1000).flags, tc::kStopped);
}
