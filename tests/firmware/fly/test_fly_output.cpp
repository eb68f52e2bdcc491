// fly's output stage alone (firmware/fly/output_stage.hpp, linking fly_output, the force API and
// the fake HAL): ArduPilot's thrust curve against the lab's implementation of ArduPilot's source
// (double precision), and the pwm mode's pulses at the decigram every mode takes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "ardupilot_curve.hpp"
#include "hal/fake.hpp"
#include "lab/autopilot.hpp"
#include "output_stage.hpp"

namespace {

using namespace fly;

lab::autopilot::ArduPilotParams labParams(const ArduPilotParams& p) {
  lab::autopilot::ArduPilotParams l;
  l.thst_expo = p.expo;
  l.spin_min = p.spin_min;
  l.spin_max = p.spin_max;
  l.pwm_min_us = p.pwm_min_us;
  l.pwm_max_us = p.pwm_max_us;
  l.bat_volt_max_v = p.bat_volt_max_v;
  l.bat_volt_min_v = p.bat_volt_min_v;
  return l;
}

// The parameters `lab export --to ardupilot` fitted in docs/autopilot.md's walkthrough.
ArduPilotParams walkthroughParams() {
  ArduPilotParams p;
  p.expo = 0.6913f;
  p.spin_min = 0.1581f;
  p.spin_max = 0.95f;
  p.bat_volt_max_v = 12.6f;
  p.bat_volt_min_v = 9.9f;
  p.full_thrust_g = 1315.1f;
  return p;
}

TEST(ArduPilotCurve, PulsesAreWhatArduPilotSendsWithinOneMicrosecondAtEveryForceAndVoltage) {
  const ArduPilotParams fitted = walkthroughParams();
  ArduPilotParams linear = fitted;
  linear.expo = 0.0f;
  ArduPilotParams negative = fitted;
  negative.expo = -0.3f;
  negative.pwm_min_us = 1100;
  negative.pwm_max_us = 1900;
  ArduPilotParams no_volts = fitted;
  no_volts.bat_volt_max_v = 0;
  int compared = 0;
  for (const ArduPilotParams& p : {fitted, linear, negative, no_volts}) {
    for (uint16_t mv : {7000, 9500, 10500, 11100, 12000, 12600, 13500}) {
      ArduPilotCurve curve;
      curve.setParams(p);
      curve.updateBattery(mv, 0.01f);  // the first reading sets the filter
      for (int f = 0; f <= 1400; f += 10) {
        const int want =
            lab::autopilot::ardupilot::pwmForThrust(labParams(p), f / p.full_thrust_g, mv / 1000.0);
        ASSERT_NEAR(curve.pulseUs(static_cast<float>(f)), want, 1)
            << "expo " << p.expo << " at " << mv << " mV, " << f << " g";
        ++compared;
      }
      EXPECT_NEAR(curve.liftMax(), lab::autopilot::ardupilot::liftMax(labParams(p), mv / 1000.0), 1e-5);
    }
  }
  EXPECT_EQ(compared, 4 * 7 * 141);
}

// The frame path: the integer table (pulseUsDg) against the same reference, same tolerance.
TEST(ArduPilotCurve, TheTablesPulsesAreWhatArduPilotSendsWithinOneMicrosecond) {
  const ArduPilotParams fitted = walkthroughParams();
  ArduPilotParams negative = fitted;
  negative.expo = -0.3f;
  negative.pwm_min_us = 1100;
  negative.pwm_max_us = 1900;
  ArduPilotParams low_min = fitted;  // V_MIN raised to 0.6 V_MAX: the largest 1 / v
  low_min.bat_volt_min_v = 5.0f;
  ArduPilotParams steep = fitted;
  steep.expo = ArduPilotCurve::kTableMaxExpo;
  for (const ArduPilotParams& p : {fitted, negative, low_min, steep}) {
    for (uint16_t mv : {7000, 7560, 9500, 11100, 12600, 13500}) {
      ArduPilotCurve curve;
      curve.setParams(p);
      ASSERT_TRUE(curve.usesTable()) << "expo " << p.expo;
      curve.updateBattery(mv, 0.01f);
      for (int dg = 0; dg <= 1400 * 10; dg += 7) {
        const int want =
            lab::autopilot::ardupilot::pwmForThrust(labParams(p), dg / 10.0 / p.full_thrust_g, mv / 1000.0);
        ASSERT_NEAR(curve.pulseUsDg(dg), want, 1) << "expo " << p.expo << " at " << mv << " mV, " << dg << " dg";
      }
    }
  }
}

// The frame path keeps each motor's table segment as a hint (output_stage.cpp): whatever the
// hint holds, the pulse is the bisection's. A force wandering a few decigrams a frame (the hint
// or a neighbour holds), jumps across the table (the bisection runs), every stale hint, the
// ends of the table and a force beyond full thrust.
TEST(ArduPilotCurve, ASegmentHintGivesTheSamePulseAsTheBisectionWhateverItHolds) {
  ArduPilotParams negative = walkthroughParams();
  negative.expo = -0.3f;
  for (const ArduPilotParams& p : {walkthroughParams(), negative}) {
    ArduPilotCurve curve;
    curve.setParams(p);
    curve.updateBattery(11100, 0.01f);
    ASSERT_TRUE(curve.usesTable());
    const int top_dg = static_cast<int>(p.full_thrust_g * 10) + 50;
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> wander(-40, 40), anywhere(-20, top_dg);
    uint8_t hint = 0;
    int dg = 3000;
    int checked = 0;
    for (int frame = 0; frame < 20000; ++frame) {
      dg = frame % 500 == 0 ? anywhere(rng) : std::clamp(dg + wander(rng), -20, top_dg);
      ASSERT_EQ(curve.pulseUsDg(dg, hint), curve.pulseUsDg(dg)) << "expo " << p.expo << ", " << dg << " dg";
      ASSERT_LT(hint, ArduPilotCurve::kTableSegments);
      ++checked;
    }
    for (int dg2 : {0, 1, top_dg - 50, top_dg, 123, 9999}) {
      for (uint8_t stale = 0; stale < ArduPilotCurve::kTableSegments; ++stale) {
        uint8_t h = stale;
        ASSERT_EQ(curve.pulseUsDg(dg2, h), curve.pulseUsDg(dg2)) << dg2 << " dg, hint " << int(stale);
        uint8_t again = h;
        curve.pulseUsDg(dg2, again);
        EXPECT_EQ(again, h) << "a force in its own segment keeps its hint";
      }
    }
    EXPECT_EQ(checked, 20000);
  }
}

// The table's interpolation error, swept over the expo at the lowest voltage ratio (0.6): within
// kTableMaxErrorUs up to kTableMaxExpo; beyond it pulseUsDg flies the float arithmetic.
TEST(ArduPilotCurve, TheTableIsWithinHalfAMicrosecondUpToItsExpoLimitAndFloatBeyond) {
  ArduPilotParams p;
  p.bat_volt_max_v = 12.6f;
  p.bat_volt_min_v = 7.56f;
  p.full_thrust_g = 1300;
  float worst = 0;
  for (int e100 = -100; e100 <= 100; ++e100) {
    p.expo = e100 / 100.0f;
    ArduPilotCurve curve;
    curve.setParams(p);
    const bool inside = std::fabs(p.expo) <= ArduPilotCurve::kTableMaxExpo;
    EXPECT_EQ(curve.usesTable(), inside) << "expo " << p.expo;
    if (!inside) {
      curve.updateBattery(9000, 0.01f);
      for (int dg = 0; dg <= 1300 * 10; dg += 100) EXPECT_EQ(curve.pulseUsDg(dg), curve.pulseUs(dg / 10.0f));
      continue;
    }
    const float error = curve.tableErrorUs();
    EXPECT_LT(error, ArduPilotCurve::kTableMaxErrorUs) << "expo " << p.expo;
    worst = std::max(worst, error);
  }
  RecordProperty("worst_table_error_us", std::to_string(worst));
}

TEST(ArduPilotCurve, TheVoltageFollowsArduPilotsHalfHertzFilter) {
  ArduPilotParams p;
  p.bat_volt_max_v = 12.6f;
  p.bat_volt_min_v = 9.9f;
  p.full_thrust_g = 1300;
  ArduPilotCurve curve;
  curve.setParams(p);
  curve.updateBattery(12600, 0.01f);
  EXPECT_FLOAT_EQ(curve.voltageRatio(), 1.0f);
  // a step to 11.34 V (ratio 0.9): after one time constant 1 / (2 pi 0.5 Hz) = 0.318 s, 63 %
  for (int k = 0; k < 32; ++k) curve.updateBattery(11340, 0.01f);
  EXPECT_NEAR(curve.voltageRatio(), 1.0 - 0.1 * (1 - std::exp(-1.0)), 0.003);
  for (int k = 0; k < 400; ++k) curve.updateBattery(11340, 0.01f);
  EXPECT_NEAR(curve.voltageRatio(), 0.9, 1e-4);
  EXPECT_NEAR(curve.maxForceG(), 1300 * (0.9 * (1 - 0.65) + 0.65 * 0.81), 0.05);
}

TEST(ArduPilotCurve, WithoutAFullThrustTheModeIsNotReady) {
  ArduPilotCurve curve;
  EXPECT_FALSE(curve.ready());
  ArduPilotParams p;
  p.full_thrust_g = 1000;
  curve.setParams(p);
  EXPECT_TRUE(curve.ready());
}

// pwm mode: 1000 us + F / slope, from decigrams: a tenth of a gram moves the pulse as the line says.
TEST(OutputStage, PwmModeIsTheStraightLineThroughTheHoverPointAtTheDecigram) {
  hal::fake::reset();
  fw::ForceActuators motors;
  OutputStage out(motors);
  ASSERT_TRUE(out.setMode(OutputMode::kPwm, 0));
  EXPECT_FALSE(out.settingsReady()) << "no hover point yet";
  out.setPwmParams({1480, 1.44f});
  EXPECT_TRUE(out.settingsReady());
  const ForceLimits l = out.forceLimits(1200, 0x0F, 4);
  EXPECT_EQ(l.collective, forceDgOf(480 * 1.44f)) << "the hover pulse's force, not the thrust";
  EXPECT_EQ(l.min, 0);
  EXPECT_EQ(l.max, forceDgOf(1000 * 1.44f));
  Forces f;
  f.dg[0] = l.collective;                 // hover
  f.dg[1] = l.collective + 144;           // 14.4 g more: 10 us
  f.dg[2] = l.collective + 7;             // 0.7 g more: half a microsecond, rounded up
  f.dg[3] = l.max + 50;                   // beyond the line's top
  out.write(f, 0x0F);
  EXPECT_EQ(out.pulseUs(0), 1480);
  EXPECT_EQ(out.pulseUs(1), 1490);
  EXPECT_EQ(out.pulseUs(2), 1480) << "0.7 g is 0.49 us";
  EXPECT_EQ(out.pulseUs(3), tc::kThrottleMaxUs);
  f.dg[2] = l.collective + 8;  // 0.8 g: 0.56 us
  out.write(f, 0x0B);
  EXPECT_EQ(out.pulseUs(2), tc::kStopPwmUs) << "outside the mask: stopped";
  out.write(f, 0x0F);
  EXPECT_EQ(out.pulseUs(2), 1481);
  for (uint8_t i = 0; i < 4; ++i) EXPECT_EQ(hal::fake::pulseUs(i), out.pulseUs(i)) << i;
}

TEST(OutputStage, GenericModeNeedsACalibratedSlotAndPwmNeedsNone) {
  hal::fake::reset();
  fw::ForceActuators motors;  // nothing loaded: no slot is calibrated
  OutputStage out(motors);
  EXPECT_FALSE(out.setMode(OutputMode::kGeneric, 0));
  EXPECT_EQ(out.mode(), OutputMode::kForce) << "unchanged";
  EXPECT_FALSE(out.motorsReady(0x0F));
  ASSERT_TRUE(out.setMode(OutputMode::kPwm, 0));
  EXPECT_TRUE(out.motorsReady(0x0F));
  EXPECT_EQ(out.thesisMotors(0x0F), 0);
}

}  // namespace
