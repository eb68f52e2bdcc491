// The autopilots' thrust models (lab/autopilot.hpp) against values computed by hand from their
// sources' formulas, clamps and edge cases included. Their fits and the export:
// autopilot_fit_test.cpp.
//
// Hand values: each expected number below was worked out from the formula quoted next to it
// (a calculator, not this code), to the digits shown.
#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <cstdio>
#include <cstdlib>

#include "lab/autopilot.hpp"
#include "lab/autopilot_export.hpp"
#include "lab/cli.hpp"
#include "lab_cli_run.hpp"
#include "lab/dataset.hpp"
#include "lab/generate.hpp"

#include "autopilot_params.hpp"

namespace {

namespace fs = std::filesystem;
namespace ap = lab::autopilot;
namespace ardu = lab::autopilot::ardupilot;
namespace px4 = lab::autopilot::px4;
namespace bf = lab::autopilot::betaflight;

// ---- ArduPilot: AP_Motors_Thrust_Linearization -----------------------------------------------

TEST(ArduPilotModel, VoltageRatioIsTheClampedVoltageOverBatVoltMaxOrOneWhenOff) {
  struct Case {
    double vmax, vmin, volts, ratio;
  };
  const Case cases[] = {
      {12.6, 9.9, 11.34, 0.9},          // 11.34 / 12.6
      {12.6, 9.9, 14.0, 1.0},           // above V_MAX: clamped to it
      {12.6, 9.9, 9.0, 9.9 / 12.6},     // below V_MIN: clamped to it (0.785714)
      {12.6, 5.0, 7.0, 0.6},            // V_MIN raised to 0.6 V_MAX = 7.56 V: 7.56 / 12.6
      {12.6, 9.9, 2.0, 1.0},            // below a quarter of V_MIN (2.475 V): compensation off
      {0.0, 9.9, 11.0, 1.0},            // V_MAX 0: off (the default)
      {12.6, 13.0, 11.0, 1.0},          // V_MIN >= V_MAX: off
      {12.6, 9.9, NAN, 1.0},            // no voltage logged: off
  };
  for (const Case& c : cases) {
    ap::ArduPilotParams p;
    p.bat_volt_max_v = c.vmax;
    p.bat_volt_min_v = c.vmin;
    EXPECT_NEAR(ardu::voltageRatio(p, c.volts), c.ratio, 1e-9) << c.vmax << " " << c.vmin << " " << c.volts;
  }
  // lift_max = v (1 - e) + e v^2 = 0.9 * 0.35 + 0.65 * 0.81
  EXPECT_NEAR(ardu::liftMax(ardu3s(), 11.34), 0.8415, 1e-9);
}

TEST(ArduPilotModel, ThrustToActuatorFollowsTheSourceFormulaWithItsClamps) {
  struct Case {
    double expo, thrust, volts, actuator;
  };
  // actuator = spin_min + (spin_max - spin_min) * clamp(ratio / v, 0, 1),
  // ratio = ((e - 1) + sqrt((1 - e)^2 + 4 e lift thrust)) / (2 e)
  const Case cases[] = {
      {0.65, 0.5, 11.34, 0.6648225},  // v 0.9, lift 0.8415: ratio 0.579175, / 0.9 = 0.643528
      {0.65, 1.0, 9.9, 0.95},         // full demand reaches SPIN_MAX at any voltage
      {0.65, 0.3, 14.0, 0.5192308},   // above V_MAX: v = 1, ratio (-0.35 + sqrt(0.1225 + 0.78)) / 1.3
      {0.65, 0.5, 9.0, 0.6597400},    // below V_MIN: as at 9.9 V
      {0.65, 1.5, 12.6, 0.95},        // demand above 1: clamped to 1
      {0.65, -0.2, 12.6, 0.15},       // demand below 0: clamped to 0, SPIN_MIN
      {0.0, 0.5, 11.34, 0.55},        // expo 0: lift * thrust / v = 0.5 -> 0.15 + 0.8 * 0.5
      {1.0, 0.25, 12.6, 0.55},        // expo 1: y^2 = 0.25 -> y = 0.5
      {-1.0, 0.75, 12.6, 0.55},       // expo -1: 2y - y^2 = 0.75 -> y = 0.5
  };
  for (const Case& c : cases) {
    ap::ArduPilotParams p = ardu3s();
    p.thst_expo = c.expo;
    EXPECT_NEAR(ardu::thrustToActuator(p, c.thrust, c.volts), c.actuator, 2e-7)
        << "expo " << c.expo << " thrust " << c.thrust << " at " << c.volts << " V";
  }
}

TEST(ArduPilotModel, OutputToPwmTruncatesAsTheInt16ReturnDoes) {
  const ap::ArduPilotParams p = ardu3s();
  EXPECT_EQ(ardu::outputToPwm(p, 0.6648225), 1664);  // 1664.82 -> 1664, not 1665
  EXPECT_EQ(ardu::outputToPwm(p, 0.15), 1150);
  // get_throttle() 0.4 of full thrust at 11.34 V: demand 0.4 / lift 0.8415 -> actuator 0.6479097
  EXPECT_EQ(ardu::pwmForThrust(p, 0.4, 11.34), 1647);
  // ... at 12.6 V (lift 1): actuator 0.5981187
  EXPECT_EQ(ardu::pwmForThrust(p, 0.4, 12.6), 1598);
}

TEST(ArduPilotModel, ThrustFractionIsZeroAtAndBelowSpinMinAndSaturatesAboveSpinMax) {
  const ap::ArduPilotParams p = ardu3s();
  EXPECT_EQ(ardu::thrustFraction(p, 1100, 12.6), 0.0);  // actuator 0.10 < SPIN_MIN 0.15
  EXPECT_EQ(ardu::thrustFraction(p, 1150, 12.6), 0.0);
  // 1600 us at 11.34 V: t = 0.45 / 0.8 = 0.5625, y = 0.50625, e y^2 + (1 - e) y = 0.3437754
  EXPECT_NEAR(ardu::thrustFraction(p, 1600, 11.34), 0.3437754, 1e-7);
  // above SPIN_MAX: lift_max (0.8415 at 11.34 V), however high the PWM
  EXPECT_NEAR(ardu::thrustFraction(p, 1980, 11.34), 0.8415, 1e-9);
  EXPECT_NEAR(ardu::thrustFraction(p, 2000, 11.34), 0.8415, 1e-9);
}

TEST(ArduPilotModel, ItsOwnActuatorToThrustTurnsPositiveAgainFarBelowSpinMinAtHighExpo) {
  // remove_thrust_curve_and_volt_scaling at expo 0.95, actuator 0.10 (1100 us), v = 1:
  // t = -0.0625, ((t 2e) - (e - 1))^2 - (1 - e)^2 = 0.0047266 - 0.0025, / (4 e) = 0.000586
  ap::ArduPilotParams p;
  p.thst_expo = 0.95;
  EXPECT_NEAR(ardu::actuatorToThrust(p, 0.10, NAN), 0.000586, 1e-6);
  EXPECT_EQ(ardu::thrustFraction(p, 1100, NAN), 0.0);  // the model used for fitting says 0 there
}

TEST(ArduPilotModel, PwmForThrustAndThrustFractionAreInversesWithinTheTruncation) {
  const ap::ArduPilotParams p = ardu3s();
  for (double volts : {10.0, 11.1, 12.6})
    for (double frac : {0.1, 0.3, 0.5}) {
      const int pwm = ardu::pwmForThrust(p, frac, volts);
      // one microsecond of truncation is at most ~0.2 % of full thrust here
      EXPECT_LE(ardu::thrustFraction(p, pwm, volts), frac + 1e-9);
      EXPECT_GT(ardu::thrustFraction(p, pwm + 1, volts), frac - 1e-9) << frac << " at " << volts;
    }
}

// ---- PX4: FunctionMotors, output_limit_calc_single, Battery::computeScale --------------------

ap::Px4Params px4Set(double fac) {
  ap::Px4Params p;
  p.thr_mdl_fac = fac;
  p.pwm_min_us = 1100;
  p.pwm_max_us = 1900;
  return p;
}

TEST(Px4Model, ThrustToPwmSolvesTheQuadraticThenMapsMinToMax) {
  struct Case {
    double fac, thrust;
    int pwm;
  };
  // x = -b/(2a) + sqrt(b^2/(4a^2) + T/a), a = f, b = 1 - f; pwm = MIN + x (MAX - MIN), rounded
  const Case cases[] = {
      {0.3, 0.5, 1559},   // x = 0.5733844 -> 1558.71
      {0.3, 0.0, 1100},   // zero thrust: MIN
      {0.3, 1.5, 1900},   // x = 1.355 -> clamped to MAX
      {0.3, -0.2, 1000},  // negative: NaN -> the disarmed value
      {0.0, 0.5, 1500},   // f = 0: linear
      {1.5, 0.5, 1500},   // f outside (FLT_EPSILON, 1]: left linear
      {1.0, 0.25, 1500},  // f = 1: x = sqrt(T)
  };
  for (const Case& c : cases)
    EXPECT_EQ(px4::pwmForThrust(px4Set(c.fac), c.thrust, 12.0), c.pwm) << c.fac << " " << c.thrust;
  // MIN > MAX is swapped by updateParams
  ap::Px4Params swapped = px4Set(0.0);
  std::swap(swapped.pwm_min_us, swapped.pwm_max_us);
  EXPECT_EQ(px4::pwmForThrust(swapped, 0.5, 12.0), 1500);
}

TEST(Px4Model, BatteryScaleIsChargedOverCellVoltageWithinOneAndOnePointThree) {
  ap::Px4Params p = px4Set(0.3);
  p.bat_scale_en = true;
  p.bat_n_cells = 3;
  EXPECT_NEAR(px4::batteryScale(p, 11.1), 4.05 / 3.7, 1e-12);  // 1.0945946
  EXPECT_EQ(px4::batteryScale(p, 12.6), 1.0);                  // 4.2 V per cell: 0.964 -> 1
  EXPECT_EQ(px4::batteryScale(p, 9.0), 1.3);                   // 3.0 V per cell: 1.35 -> 1.3
  EXPECT_EQ(px4::batteryScale(p, NAN), 1.0);
  // thrust 0.5 at 11.1 V: 0.5 * 1.0945946 = 0.5472973, x = 0.6181122 -> 1594.49
  EXPECT_EQ(px4::pwmForThrust(p, 0.5, 11.1), 1594);
  // the model: (0.3 * 0.25 + 0.7 * 0.5) / 1.0945946 at 1500 us
  EXPECT_NEAR(px4::thrustFraction(p, 1500, 11.1), 0.3882716, 1e-7);
  p.bat_scale_en = false;
  EXPECT_NEAR(px4::thrustFraction(p, 1500, 11.1), 0.425, 1e-12);
  EXPECT_EQ(px4::thrustFraction(p, 1050, 11.1), 0.0);  // below MIN
  EXPECT_EQ(px4::thrustFraction(p, 1950, 11.1), 1.0);  // above MAX
}

// ---- Betaflight: pidApplyThrustLinearization, motor endpoints, sag compensation ---------------

TEST(BetaflightModel, ThrustLinearizationIsTheSecondOrderExpansionFromPidC) {
  // c(x) = x (1 + e (1 - x) (1 + e (1 - 2x))), e = 0.4 (the float 40 / 100.0f: 0.4 + 6e-9)
  EXPECT_NEAR(bf::applyThrustLinearization(40, 0.5), 0.6, 1e-8);
  EXPECT_NEAR(bf::applyThrustLinearization(40, 0.25), 0.34, 1e-8);
  EXPECT_NEAR(bf::applyThrustLinearization(40, 0.8), 0.84864, 1e-8);
  EXPECT_EQ(bf::applyThrustLinearization(40, 0.0), 0.0);
  EXPECT_NEAR(bf::applyThrustLinearization(40, 1.0), 1.0, 1e-12);
  EXPECT_NEAR(bf::applyThrustLinearization(0, 0.37), 0.37, 1e-12);
  // pidCompensateThrustLinearization: 0.5 (1 - 0.4 * 0.5)
  EXPECT_NEAR(bf::compensateThrustLinearization(40, 0.5), 0.4, 1e-8);
  EXPECT_NEAR(bf::removeThrustLinearization(40, 0.6), 0.5, 1e-8);
}

TEST(BetaflightModel, AboveThrustLinear129TheCurveFallsWhileTheDemandRises) {
  // slope 5/6 - e^2/2 at x = 0.5 + 1/(6e): +0.0013 at 1.29, -0.0117 at 1.30
  EXPECT_GT(bf::applyThrustLinearization(129, 0.6293), bf::applyThrustLinearization(129, 0.6292));
  EXPECT_LT(bf::applyThrustLinearization(150, 0.65), bf::applyThrustLinearization(150, 0.55));  // 0.8377 < 0.8656
}

TEST(BetaflightModel, EndpointsForPwmAndDshotFollowMotorIdleAndOutputLimit) {
  ap::BetaflightParams p;  // motor_idle 550
  p.protocol = ap::BfProtocol::kPwm;
  EXPECT_NEAR(bf::endpoints(p).low, 1055, 1e-9);  // min_command + 550 * 0.1
  EXPECT_NEAR(bf::endpoints(p).high, 2000, 1e-9);
  p.motor_output_limit = 80;  // max_throttle - (max_throttle - 1055) * 0.2
  EXPECT_NEAR(bf::endpoints(p).high, 1811, 1e-9);
  p.protocol = ap::BfProtocol::kDshot;
  EXPECT_NEAR(bf::endpoints(p).low, 157.945, 1e-9);  // 48 + 0.055 * 1999
  EXPECT_NEAR(bf::endpoints(p).high, 1647.2, 1e-9);  // 2047 - 1999 * 0.2
  EXPECT_NEAR(bf::toPulseUs(p, 157.945), 1055.0, 1e-9);
  EXPECT_NEAR(bf::fromPulseUs(p, 1055.0), 157.945, 1e-9);
}

TEST(BetaflightModel, SagCompensationLowersTheTopWithTheIntegerCellVoltage) {
  ap::BetaflightParams p;
  p.protocol = ap::BfProtocol::kPwm;
  p.vbat_sag_compensation = 100;
  p.cells = 4;
  struct Case {
    double volts, top;
  };
  // factor = (70 / 420) * goodness, goodness = 1 - clamp((420 - cell_cv) / 70, 0, 1)
  const Case cases[] = {
      {16.8, 1842.5},   // 420 cV per cell: goodness 1, top - (1/6) * 945
      {15.43, 1921.25}, // 1543 / 4 = 385 (integer): goodness 0.5
      {15.4, 1921.25},
      {14.0, 2000},     // 350 cV = the warning voltage: no compensation
      {13.5, 2000},
  };
  for (const Case& c : cases) EXPECT_NEAR(bf::rangeMax(p, c.volts), c.top, 1e-9) << c.volts;
  p.cells = 0;  // cell count unknown: getBatterySagCellVoltage() is 0, no compensation
  EXPECT_NEAR(bf::rangeMax(p, 16.8), 2000, 1e-9);
}

TEST(BetaflightModel, MotorOutputAndThrustFractionInvertEachOther) {
  ap::BetaflightParams p;
  p.protocol = ap::BfProtocol::kPwm;
  p.thrust_linear = 40;
  EXPECT_NEAR(bf::motorOutput(p, 0.5, 12.0), 1622.0, 1e-5);  // 1055 + 945 * 0.6
  EXPECT_NEAR(bf::thrustFraction(p, 1622.0, 12.0), 0.5, 1e-8);
  EXPECT_EQ(bf::thrustFraction(p, 1040.0, 12.0), 0.0);  // below motor_idle
  EXPECT_EQ(bf::thrustFraction(p, 2000.0, 12.0), 1.0);
  EXPECT_NEAR(bf::motorOutput(p, 1.3, 12.0), 2000.0, 1e-9);  // constrained to the range
}

}  // namespace
