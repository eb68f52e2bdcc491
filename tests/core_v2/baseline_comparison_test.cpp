// v2 against the thesis's option 2.1 (tc::forceToPwm with curves built by tc::CurveBuilder at
// 12.4 V and 10.5 V) on the same synthetic motor, the same sweeps and the same grid of
// commands (100-450 g) and bus voltages (9.9-12.6 V).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "synthetic_motor.hpp"
#include "thrustcal/curve_builder.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/model_v2.hpp"

using tc_test::GridError;
using tc_test::Recording;
using tc_test::SyntheticMotor;

namespace {

bool outsideCalibration(double v) { return v < 10.5 - 1e-9 || v > 12.4 + 1e-9; }
bool insideCalibration(double v) { return !outsideCalibration(v); }

// Thesis curve from the same recorded sweep (the builder sees PWM and force only).
void thesisCurve(const SyntheticMotor& motor, double rest_v, tc::ThesisCurve& curve) {
  tc::ModelV2Fitter<128> recorder;  // records exactly what the v2 fit sees
  tc_test::recordSweep(motor, rest_v, recorder, Recording());
  tc::CurveBuilder<128> builder;
  for (uint16_t i = 0; i < recorder.size(); ++i)
    builder.add(recorder.sample(i).pwm_us, recorder.sample(i).force_dg);
  ASSERT_EQ(builder.build(curve).status, tc::BuildStatus::kOk);
  curve.start_mv = static_cast<uint16_t>(std::lround(rest_v * 1000));
}

struct Errors {
  GridError inside, outside, all;
};

template <class PwmFor>
Errors errorsOf(const SyntheticMotor& motor, PwmFor pwm_for) {
  Errors e;
  e.inside = tc_test::gridError(motor, pwm_for, 9.9, 12.6, 100, 450, insideCalibration);
  e.outside = tc_test::gridError(motor, pwm_for, 9.9, 12.6, 100, 450, outsideCalibration);
  e.all = tc_test::gridError(motor, pwm_for, 9.9, 12.6);
  return e;
}

void print(const char* name, const Errors& e) {
  std::printf("  %-34s  all %5.2f / %5.2f   inside 10.5-12.4 V %5.2f / %5.2f   outside %5.2f / %5.2f  (RMS / max %%)\n",
              name, e.all.rms_pct, e.all.max_pct, e.inside.rms_pct, e.inside.max_pct,
              e.outside.rms_pct, e.outside.max_pct);
}

}  // namespace

TEST(BaselineComparison, V2BeatsOption2p1AtLeast3xOutsideItsCalibrationVoltages) {
  const double exponents[] = {1.6, 1.8, 2.0};
  for (double a : exponents) {
    SCOPED_TRACE(a);
    // given: one motor, swept at 12.4 V and at 10.5 V, stiff bench source
    SyntheticMotor motor;
    motor.exponent = a;
    tc::MotorCalibration cal;
    thesisCurve(motor, 12.4, cal.first);
    thesisCurve(motor, 10.5, cal.second);
    tc::ModelV2Fitter<128> fitter;
    tc_test::recordSweep(motor, 12.4, fitter, Recording());
    tc::ModelV2 single;
    ASSERT_EQ(fitter.fit(single).status, tc::FitV2Status::kOk);
    tc::ModelV2 refined = single;
    tc_test::recordSweep(motor, 10.5, fitter, Recording{true, 0.0, 4242});
    ASSERT_EQ(fitter.refine(refined).status, tc::FitV2Status::kOk);

    // when: each controller drives the grid
    const Errors thesis = errorsOf(motor, [&](double f_g, uint16_t mv) {
      return static_cast<double>(tc::forceToPwm(cal, static_cast<uint16_t>(std::lround(f_g)), mv).pwm_us);
    });
    auto v2 = [](const tc::ModelV2& m) {
      return [&m](double f_g, uint16_t mv) {
        tc::BusVoltageFilter bus;
        bus.reset(mv);
        return static_cast<double>(tc::forceToPwmV2(m, static_cast<uint16_t>(std::lround(f_g * 10)), bus).pwm_us);
      };
    };
    const Errors e_single = errorsOf(motor, v2(single));
    const Errors e_refined = errorsOf(motor, v2(refined));
    std::printf("exponent %.1f, grid 100-450 g x 9.9-12.6 V:\n", a);
    print("option 2.1 (12.4 V + 10.5 V curves)", thesis);
    print("v2, one sweep at 12.4 V", e_single);
    print("v2, refined with 10.5 V", e_refined);

    // then: v2 meets the targets and beats option 2.1 outside its two voltages
    for (const Errors* e : {&e_single, &e_refined}) {
      EXPECT_LE(e->all.rms_pct, 1.0);
      EXPECT_LE(e->all.max_pct, 3.0);
      EXPECT_LE(3.0 * e->outside.rms_pct, thesis.outside.rms_pct);
    }
    // and option 2.1 really errs there (else this comparison would prove nothing): PWM per
    // volt is a hyperbola, its chord misses by ~1 % in force between the two voltages and
    // by ~2 % at 9.9 V
    EXPECT_GT(thesis.outside.rms_pct, 1.0);
    EXPECT_GT(thesis.outside.max_pct, thesis.inside.max_pct);
  }
}
