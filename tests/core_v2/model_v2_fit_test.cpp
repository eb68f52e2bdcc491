// Model v2 fitting: one sweep (and a refining second sweep) as gather_store records them ->
// ModelV2, checked against the synthetic motor that produced the sweep.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "synthetic_motor.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/model_v2_curve.hpp"

using tc_test::GridError;
using tc_test::Recording;
using tc_test::SyntheticMotor;

namespace {

using Fitter = tc::ModelV2Fitter<128>;

GridError v2GridError(const SyntheticMotor& motor, const tc::ModelV2& model, double v_lo = 9.9,
                      double v_hi = 12.6) {
  return tc_test::gridError(
      motor,
      [&](double f_g, uint16_t mv) {
        tc::BusVoltageFilter bus;
        bus.reset(mv);
        return static_cast<double>(
            tc::forceToPwmV2(model, static_cast<uint16_t>(std::lround(f_g * 10)), bus).pwm_us);
      },
      v_lo, v_hi);
}

struct FitCase {
  const char* name;
  double exponent;
  double start_us;
  double source_r_ohm;
  bool quantize;
  double noise_g;
};

const FitCase kFitCases[] = {
    {"a1.8 start1097 stiff exact", 1.8, 1097, 0.00, false, 0.0},
    {"a1.8 start1097 sag quantized", 1.8, 1097, 0.05, true, 0.0},
    {"a1.6 start1097 sag quantized", 1.6, 1097, 0.05, true, 0.0},
    {"a2.0 start1097 sag quantized", 2.0, 1097, 0.05, true, 0.0},
    {"a1.8 start1080 sag quantized noisy", 1.8, 1080, 0.05, true, 0.6},
    {"a1.7 start1120 strong sag quantized noisy", 1.7, 1120, 0.10, true, 0.6},
};

}  // namespace

TEST(ModelV2Fit, OneSweepAt12V4PredictsForceWithin1PercentRmsAnd3PercentMaxFrom9V9To12V6) {
  for (const FitCase& c : kFitCases) {
    SCOPED_TRACE(c.name);
    // given: a motor swept once at 12.4 V, recorded like gather_store records it
    SyntheticMotor motor;
    motor.exponent = c.exponent;
    motor.start_us = c.start_us;
    motor.source_r_ohm = c.source_r_ohm;
    Recording rec;
    rec.quantize = c.quantize;
    rec.force_noise_g = c.noise_g;
    Fitter fitter;
    tc_test::recordSweep(motor, 12.4, fitter, rec);
    // when
    tc::ModelV2 model;
    const tc::FitV2Report rep = fitter.fit(model);
    // then
    ASSERT_EQ(rep.status, tc::FitV2Status::kOk) << tc::fitV2StatusText(rep.status);
    // One sweep: the start comes from the low end's shape, where 0.75 g load-cell steps are a
    // few percent of the force: within 5 us (~1 % of force at 9.9 V at worst); the force
    // error below is the real measure.
    EXPECT_NEAR(model.start_q4_us / 16.0, c.start_us, 5.0);
    EXPECT_GE(rep.estimates, 10);
    const GridError g = v2GridError(motor, model);
    EXPECT_LE(g.rms_pct, 1.0);
    EXPECT_LE(g.max_pct, 3.0);
    RecordProperty(std::string("rms_pct_") + c.name, std::to_string(g.rms_pct));
  }
}

TEST(ModelV2Fit, SecondSweepAt10V5MeasuresTheStartThresholdWithinOneMicrosecond) {
  for (const FitCase& c : kFitCases) {
    SCOPED_TRACE(c.name);
    // given: a first sweep at 12.4 V fitted, then a second sweep at 10.5 V
    SyntheticMotor motor;
    motor.exponent = c.exponent;
    motor.start_us = c.start_us;
    motor.source_r_ohm = c.source_r_ohm;
    Recording rec;
    rec.quantize = c.quantize;
    rec.force_noise_g = c.noise_g;
    Fitter fitter;
    tc_test::recordSweep(motor, 12.4, fitter, rec);
    tc::ModelV2 model;
    ASSERT_EQ(fitter.fit(model).status, tc::FitV2Status::kOk);
    const double single_start_us = model.start_q4_us / 16.0;
    rec.seed = 777;
    tc_test::recordSweep(motor, 10.5, fitter, rec);
    // when
    const tc::FitV2Report rep = fitter.refine(model);
    // then
    ASSERT_EQ(rep.status, tc::FitV2Status::kOk) << tc::fitV2StatusText(rep.status);
    std::printf("%-45s start single %.2f refined %.2f truth %.0f (%d knots)\n", c.name,
                single_start_us, model.start_q4_us / 16.0, c.start_us, rep.estimates);
    EXPECT_NEAR(model.start_q4_us / 16.0, c.start_us, 1.0);
    EXPECT_TRUE(model.flags & tc::kV2Refined);
    EXPECT_NEAR(model.second_mv, 10500, 60);
    const GridError g = v2GridError(motor, model);
    EXPECT_LE(g.rms_pct, 1.0);
    EXPECT_LE(g.max_pct, 3.0);
  }
}

TEST(ModelV2Fit, SecondSweepAtAHigherVoltageRefinesToo) {
  // given: the first sweep on a tired pack (10.5 V), the second on a full one (12.4 V)
  SyntheticMotor motor;
  motor.start_us = 1105;
  motor.source_r_ohm = 0.05;
  Fitter fitter;
  tc_test::recordSweep(motor, 10.5, fitter, Recording{});
  tc::ModelV2 model;
  ASSERT_EQ(fitter.fit(model).status, tc::FitV2Status::kOk);
  tc_test::recordSweep(motor, 12.4, fitter, Recording{true, 0.0, 31});
  // when
  const tc::FitV2Report rep = fitter.refine(model);
  // then: the curve keeps the first sweep's range, the start comes from both
  ASSERT_EQ(rep.status, tc::FitV2Status::kOk);
  EXPECT_NEAR(model.start_q4_us / 16.0, 1105.0, 1.0);
  EXPECT_NEAR(model.rest_mv, 10500, 20);
  EXPECT_NEAR(model.second_mv, 12400, 20);
  const GridError g = v2GridError(motor, model);
  EXPECT_LE(g.rms_pct, 1.0);
  EXPECT_LE(g.max_pct, 3.0);
}

TEST(ModelV2Fit, CurrentLimitedBenchSupplyEndsTheCurveAtItsPlateau) {
  // given: the thesis bench supply, limited to 6.32 A: the force plateaus near 495 g while
  // the recorded voltage collapses
  SyntheticMotor motor;
  motor.current_limit_a = 6.32;
  Fitter fitter;
  tc_test::recordSweep(motor, 12.4, fitter, Recording{});
  // when
  tc::ModelV2 model;
  const tc::FitV2Report rep = fitter.fit(model);
  // then: the curve stops at the plateau; below it the model is as good as ever
  ASSERT_EQ(rep.status, tc::FitV2Status::kOk);
  const double plateau_g = 500.0 * std::pow(6.32 / 6.4, 2.0 / 3.0);
  EXPECT_NEAR(rep.max_force_dg / 10.0, plateau_g, 2.0);
  EXPECT_LE(model.maxForceDg() / 10.0, plateau_g);
  const GridError g = v2GridError(motor, model);
  EXPECT_LE(g.rms_pct, 1.0);
  EXPECT_LE(g.max_pct, 3.0);
  tc::BusVoltageFilter bus;
  bus.reset(12600);
  EXPECT_EQ(tc::forceToPwmV2(model, 5500, bus).flags, tc::kSaturated) << "550 g is beyond the curve";
}

TEST(ModelV2Fit, PlacesSixteenFineKnotsBelowAQuarterOfTheRangeAndSixteenCoarseAbove) {
  struct Row {
    const char* name;
    double full_at_9v9_g;
    bool two_runs;
  };
  const Row rows[] = {
      {"~900 g at 12.4 V: two runs", 600.0, true},
      {"a small motor (~135 g): one run of 32 knots, Q16 knot position", 90.0, false},
  };
  for (const Row& r : rows) {
    SCOPED_TRACE(r.name);
    SyntheticMotor motor;
    motor.full_at_9v9_g = r.full_at_9v9_g;
    Fitter fitter;
    tc_test::recordSweep(motor, 12.4, fitter, Recording{false, 0.0, 1});
    tc::ModelV2 model;
    const tc::FitV2Report rep = fitter.fit(model);
    ASSERT_EQ(rep.status, tc::FitV2Status::kOk);
    if (r.two_runs) {
      EXPECT_EQ(model.knots, 32);
      EXPECT_EQ(model.fine_knots, 16);
      EXPECT_EQ(model.step_dg, rep.max_force_dg / 64);
      EXPECT_NEAR(model.coarse_step_dg, 3 * model.step_dg, 2);
      EXPECT_EQ(model.knotForceDg(15), 16 * model.step_dg);
      EXPECT_EQ(model.knotForceDg(16), 16 * model.step_dg + model.coarse_step_dg);
    } else {
      EXPECT_EQ(model.step_dg, rep.max_force_dg / 32);
      EXPECT_LT(model.step_dg, tc::kV2MinStepDg);
      EXPECT_EQ(model.q16_inverse, 1);
      EXPECT_EQ(model.fine_knots, model.knots);
      EXPECT_EQ(model.coarse_step_dg, 0);
      EXPECT_EQ(model.knots, 32);
    }
    EXPECT_LE(model.maxForceDg(), rep.max_force_dg) << "the last knot is a measured force";
    EXPECT_GT(model.maxForceDg(), rep.max_force_dg - 2 * 16 * model.step_dg / 16 - 32);
    for (uint8_t k = 1; k < model.knots; ++k) {
      EXPECT_GT(model.knotForceDg(k), model.knotForceDg(k - 1)) << "knot " << int(k);
      EXPECT_GE(model.drive_512usmv[k], model.drive_512usmv[k - 1]) << "knot " << int(k);
    }
  }
}

TEST(ModelV2Fit, RecordsTheBenchSagAtEachKnotAndTheRestingVoltage) {
  // given: a soft bench source, 0.1 ohm
  SyntheticMotor motor;
  motor.source_r_ohm = 0.1;
  Fitter fitter;
  tc_test::recordSweep(motor, 12.4, fitter, Recording{false, 0.0, 1});
  // when
  tc::ModelV2 model;
  ASSERT_EQ(fitter.fit(model).status, tc::FitV2Status::kOk);
  // then: rest voltage and sag = R * I(F) at a low, a middle and the top knot
  EXPECT_NEAR(model.rest_mv, 12400, 5);
  for (uint8_t k : {uint8_t(3), uint8_t(15), uint8_t(20), uint8_t(model.knots - 1)}) {
    const double f_g = model.knotForceDg(k) / 10.0;
    const double sag_mv = 1000.0 * motor.source_r_ohm * motor.currentA(f_g);
    EXPECT_NEAR(model.sag_10mv[k] * 10.0, sag_mv, 10.0) << "knot " << int(k);
  }
}

TEST(ModelV2Fit, NonMonotoneNoisySweepGivesANonDecreasingCurve) {
  // given: heavy force noise (+-3 g) that makes the raw sweep go backwards in places
  SyntheticMotor motor;
  Fitter fitter;
  tc_test::recordSweep(motor, 12.4, fitter, Recording{true, 3.0, 99}, 5);
  // when
  tc::ModelV2 model;
  const tc::FitV2Report rep = fitter.fit(model);
  // then
  ASSERT_EQ(rep.status, tc::FitV2Status::kOk);
  EXPECT_GT(rep.violations, 0);
  for (uint8_t k = 1; k < model.knots; ++k)
    EXPECT_GE(model.drive_512usmv[k], model.drive_512usmv[k - 1]);
  for (uint16_t i = 1; i < fitter.size(); ++i)
    EXPECT_GE(fitter.sample(i).force_dg, fitter.sample(i - 1).force_dg);
}

TEST(ModelV2Fit, AcceptsSamplesInAnyOrder) {
  SyntheticMotor motor;
  Fitter ascending, shuffled;
  tc_test::recordSweep(motor, 12.4, ascending, Recording{false, 0.0, 1});
  // a descending sweep of the same points
  for (int i = ascending.size() - 1; i >= 0; --i)
    shuffled.add(ascending.sample(i).pwm_us, ascending.sample(i).force_dg, ascending.sample(i).vbat_mv);
  tc::ModelV2 a, b;
  ASSERT_EQ(ascending.fit(a).status, tc::FitV2Status::kOk);
  ASSERT_EQ(shuffled.fit(b).status, tc::FitV2Status::kOk);
  EXPECT_EQ(a.start_q4_us, b.start_q4_us);
  for (uint8_t k = 0; k < a.knots; ++k) EXPECT_EQ(a.drive_512usmv[k], b.drive_512usmv[k]);
}

TEST(ModelV2Fit, RefusesSweepsItCannotFitAndClearsTheModel) {
  struct Row {
    const char* name;
    std::vector<tc::SweepPointV2> samples;
    tc::FitV2Status expect;
  };
  std::vector<tc::SweepPointV2> flat, low_battery, short_sweep;
  for (uint16_t p = 1000; p <= 2000; p += 20) {
    flat.push_back({p, 3, 12000});                                    // motor never spins
    low_battery.push_back({p, static_cast<int16_t>(p - 1000), 2900});  // monitor unplugged
  }
  for (uint16_t p = 1000; p < 1070; p += 10) short_sweep.push_back({p, 100, 12000});
  const Row rows[] = {
      {"7 samples", short_sweep, tc::FitV2Status::kTooFewSamples},
      {"no force", flat, tc::FitV2Status::kNoForce},
      {"monitor reads 2.9 V (below one cell)", low_battery, tc::FitV2Status::kBadVoltage},
  };
  for (const Row& r : rows) {
    SCOPED_TRACE(r.name);
    Fitter fitter;
    for (const auto& s : r.samples) fitter.add(s.pwm_us, s.force_dg, s.vbat_mv);
    tc::ModelV2 model;
    model.start_q4_us = 1;  // garbage that must be cleared
    model.knots = 3;
    EXPECT_EQ(fitter.fit(model).status, r.expect);
    EXPECT_FALSE(model.isPresent());
    EXPECT_STRNE(tc::fitV2StatusText(r.expect), "unknown");
  }
}

TEST(ModelV2Fit, SweepWhoseShapePointsToAStartBelow800UsIsRefused) {
  // given: force ~ (pwm - 700 us)^2, already 100 g at 1000 us: no ESC starts at 700 us
  Fitter fitter;
  for (uint16_t p = 1000; p <= 2000; p += 10) {
    const double x = (p - 700.0) / 100.0;
    fitter.add(p, static_cast<int16_t>(100.0 * x * x / 9.0 * 10.0), 12000);
  }
  // when
  tc::ModelV2 model;
  const tc::FitV2Report rep = fitter.fit(model);
  // then
  EXPECT_EQ(rep.status, tc::FitV2Status::kStartNotFound);
  EXPECT_FALSE(model.isPresent());
}

TEST(ModelV2Fit, RefineRefusesAndKeepsTheModelWhenItCannotRefine) {
  SyntheticMotor motor;
  Fitter fitter;
  tc_test::recordSweep(motor, 12.4, fitter, Recording{});
  tc::ModelV2 model;
  ASSERT_EQ(fitter.fit(model).status, tc::FitV2Status::kOk);
  const tc::ModelV2 before = model;
  // second sweep only 0.3 V lower
  tc_test::recordSweep(motor, 12.1, fitter, Recording{});
  EXPECT_EQ(fitter.refine(model).status, tc::FitV2Status::kVoltagesTooClose);
  EXPECT_EQ(model.start_q4_us, before.start_q4_us);
  EXPECT_EQ(model.flags, before.flags);
  for (uint8_t k = 0; k < model.knots; ++k) EXPECT_EQ(model.drive_512usmv[k], before.drive_512usmv[k]);
  // no model to refine
  tc::ModelV2 empty;
  tc_test::recordSweep(motor, 10.5, fitter, Recording{});
  EXPECT_EQ(fitter.refine(empty).status, tc::FitV2Status::kNoModel);
}

TEST(ModelV2Fit, FitterRefusesSamplesBeyondItsCapacity) {
  tc::ModelV2Fitter<8> fitter;
  for (uint16_t i = 0; i < 8; ++i) EXPECT_TRUE(fitter.add(1000 + i, 0, 12000));
  EXPECT_FALSE(fitter.add(1100, 0, 12000));
  EXPECT_EQ(fitter.size(), 8);
  static_assert(sizeof(tc::ModelV2Fitter<128>) <= 1024 + 3 * sizeof(void*) + 8,
                "fit work space: 8 bytes per sample (1 KB for 128) plus a small header");
}

TEST(ModelV2FromCurve, LabCurveInDoublesFlysWithin0p3PercentOfTheTruth) {
  // given: the exact curve of a motor, densely sampled, as the model lab would export it
  SyntheticMotor motor;
  std::vector<double> drive, force, sag;
  for (int i = 1; i <= 400; ++i) {
    const double d_usv = i * 25.0;  // (pwm - start) * V in us*V
    drive.push_back(d_usv);
    force.push_back(motor.k() * std::pow(d_usv / motor.span_us, motor.exponent));
    sag.push_back(20.0 + i);
  }
  // when
  tc::ModelV2 model;
  ASSERT_TRUE(tc::modelV2FromCurve(model, motor.start_us, drive.data(), force.data(),
                                   static_cast<uint16_t>(drive.size()), 12400.0, sag.data(), 10500.0));
  // then
  EXPECT_EQ(model.start_q4_us, 1097 * 16);
  EXPECT_EQ(model.knots, 32);
  EXPECT_EQ(model.rest_mv, 12400);
  EXPECT_EQ(model.second_mv, 10500);
  EXPECT_TRUE(model.flags & tc::kV2Refined);
  const GridError g = v2GridError(motor, model);
  EXPECT_LE(g.rms_pct, 0.3);
  EXPECT_LE(g.max_pct, 1.0);
}

TEST(ModelV2FromCurve, RefusesCurvesItCannotStore) {
  const double d_ok[] = {100.0, 5000.0}, f_ok[] = {1.0, 500.0};
  const double d_down[] = {5000.0, 100.0}, f_small[] = {1.0, 4.0}, f_big[] = {1.0, 5001.0};
  tc::ModelV2 model;
  EXPECT_TRUE(tc::modelV2FromCurve(model, 1097.0, d_ok, f_ok, 2, 12000.0));
  EXPECT_FALSE(tc::modelV2FromCurve(model, 1097.0, d_ok, f_ok, 1, 12000.0)) << "one point";
  EXPECT_FALSE(model.isPresent());
  EXPECT_FALSE(tc::modelV2FromCurve(model, 1097.0, d_down, f_ok, 2, 12000.0)) << "descending";
  EXPECT_FALSE(tc::modelV2FromCurve(model, 1097.0, d_ok, f_small, 2, 12000.0)) << "4 g max";
  EXPECT_FALSE(tc::modelV2FromCurve(model, 1097.0, d_ok, f_big, 2, 12000.0)) << "5001 g max";
  EXPECT_FALSE(tc::modelV2FromCurve(model, 300.0, d_ok, f_ok, 2, 12000.0)) << "start 300 us";
  EXPECT_FALSE(tc::modelV2FromCurve(model, 1097.0, d_ok, f_ok, 2, 2900.0)) << "rest 2.9 V";
}

TEST(ModelV2Fit, SweepThatStartsWithTheMotorAlreadyPushingIsRefused) {
  // given: a sweep from 1250 us: the first sample already makes more than the first knot
  SyntheticMotor motor;
  Fitter fitter;
  for (uint16_t p = 1250; p <= 2000; p += 10)
    fitter.add(p, static_cast<int16_t>(std::lround(motor.forceG(p, 12.4) * 10)), 12400);
  // when
  tc::ModelV2 model;
  const tc::FitV2Report rep = fitter.fit(model);
  // then
  EXPECT_EQ(rep.status, tc::FitV2Status::kStartNotFound);
  EXPECT_FALSE(model.isPresent());
}

TEST(ModelV2Fit, RefineWithASecondSweepBelowTheFirstKnotKeepsTheModel) {
  // given: a fitted model, and a second sweep that stops at 1200 us (13.5 g, below 28 g)
  SyntheticMotor motor;
  Fitter fitter;
  tc_test::recordSweep(motor, 12.4, fitter, Recording{false, 0.0, 1});
  tc::ModelV2 model;
  ASSERT_EQ(fitter.fit(model).status, tc::FitV2Status::kOk);
  const uint16_t start_before = model.start_q4_us;
  fitter.reset();
  for (uint16_t p = 1000; p <= 1200; p += 10)
    fitter.add(p, static_cast<int16_t>(std::lround(motor.forceG(p, 10.5) * 10)), 10500);
  // when
  const tc::FitV2Report rep = fitter.refine(model);
  // then
  EXPECT_EQ(rep.status, tc::FitV2Status::kStartNotFound);
  EXPECT_EQ(rep.estimates, 0);
  EXPECT_EQ(model.start_q4_us, start_before);
  EXPECT_FALSE(model.flags & tc::kV2Refined);
}

TEST(ModelV2Fit, EveryStatusHasItsOwnText) {
  const tc::FitV2Status all[] = {tc::FitV2Status::kOk,           tc::FitV2Status::kTooFewSamples,
                                 tc::FitV2Status::kNoForce,      tc::FitV2Status::kBadVoltage,
                                 tc::FitV2Status::kStartNotFound, tc::FitV2Status::kVoltagesTooClose,
                                 tc::FitV2Status::kNoModel};
  for (auto a : all) {
    EXPECT_STRNE(tc::fitV2StatusText(a), "unknown");
    for (auto b : all)
      if (a != b) {
        EXPECT_STRNE(tc::fitV2StatusText(a), tc::fitV2StatusText(b));
      }
  }
  EXPECT_STREQ(tc::fitV2StatusText(static_cast<tc::FitV2Status>(99)), "unknown");
}

TEST(ModelV2FromCurve, CurveStartingAboveZeroForceIsJoinedToTheOrigin) {
  // given: points from 50 g up; the first knots lie between the origin and 50 g
  const double drive[] = {2000.0, 6000.0, 9000.0};
  const double force[] = {50.0, 300.0, 600.0};
  tc::ModelV2 model;
  ASSERT_TRUE(tc::modelV2FromCurve(model, 1100.0, drive, force, 3, 12000.0));
  // then: knot 0 (18.7 g) sits on the straight line from the origin to (2000 us*V, 50 g)
  const double knot0_g = model.step_dg / 10.0;
  EXPECT_NEAR(model.drive_512usmv[0] * 512.0 / 1000.0, 2000.0 * knot0_g / 50.0, 1.0);
  EXPECT_FALSE(tc::modelV2FromCurve(model, -5.0, drive, force, 3, 12000.0)) << "negative start";
  EXPECT_FALSE(tc::modelV2FromCurve(model, 1100.0, drive, force, 3, 12000.0, nullptr, -1.0))
      << "negative second voltage";
}
