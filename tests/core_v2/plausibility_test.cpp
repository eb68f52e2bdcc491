// Plausibility of calibration records (thrustcal/plausibility.hpp): every rule of both
// layouts fails once, table-driven, with the reason the firmware prints; and records that
// cannot be right but carry a good CRC decode as "not calibrated" (kBadContent), never flown.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <set>
#include <string>

#include "synthetic_motor.hpp"
#include "test_records.hpp"
#include "thrustcal/curve_builder.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/plausibility.hpp"
#include "thrustcal/record_v2.hpp"

using tc_test::SyntheticMotor;

namespace {

struct RamEeprom {
  static uint8_t bytes[4096];
  static uint8_t readByte(uint16_t addr) { return bytes[addr]; }
  static void updateByte(uint16_t addr, uint8_t value) { bytes[addr] = value; }
  static void erase() { std::memset(bytes, 0xFF, sizeof bytes); }
};
uint8_t RamEeprom::bytes[4096];

// tc::printPlausibility into a string (what the firmware prints after "implausible: ").
struct StringOut {
  std::string s;
  void flash(const char* text) { s += text; }
  void fixed(int32_t value, uint8_t decimals) {
    if (decimals == 0) {
      s += std::to_string(value);
      return;
    }
    int32_t scale = 1;
    for (uint8_t i = 0; i < decimals; ++i) scale *= 10;
    const int32_t mag = value < 0 ? -value : value;
    std::string frac = std::to_string(mag % scale);
    while (frac.size() < decimals) frac = "0" + frac;
    s += (value < 0 ? "-" : "") + std::to_string(mag / scale) + "." + frac;
  }
};

std::string describe(const tc::Plausibility& p) {
  StringOut out;
  tc::printPlausibility(p, out);
  return out.s;
}

// The thesis record of a synthetic motor swept 1000..2000 us at 12.4 V (curve 1) and 10.9 V
// (curve 2), with a realistic sag table.
tc::MotorCalibration twoCurveThesisCalibration() { return tc_test::thesisRecord(SyntheticMotor(), 12.4, 10.9); }

tc::ModelV2 fittedModel() {
  SyntheticMotor motor;
  motor.source_r_ohm = 0.05;
  tc::ModelV2 m = tc_test::fittedModel(motor, 12.4);
  EXPECT_TRUE(m.isPresent());
  return m;
}

}  // namespace

TEST(Plausibility, MeasuredRecordsOfBothLayoutsCanBeRight) {
  tc::MotorCalibration cal = twoCurveThesisCalibration();
  const tc::Plausibility v1 = tc::checkCalibration(cal);
  EXPECT_TRUE(v1.ok()) << describe(v1);
  const tc::Plausibility v2 = tc::checkModelV2(fittedModel());
  EXPECT_TRUE(v2.ok()) << describe(v2);
}

struct V1Case {
  const char* name;
  void (*spoil)(tc::MotorCalibration&);
  tc::Implausible rule;
  const char* reason;  // what the firmware prints after "implausible: " ("" = not checked)
};

const V1Case kV1Cases[] = {
    {"no first curve", [](tc::MotorCalibration& c) { c.first.start_mv = 0; }, tc::Implausible::kNoCurve,
     "no first curve (curve 1)"},
    {"a step after the end marker",
     [](tc::MotorCalibration& c) {
       c.first.steps()[300] = tc::kUnreachable;
       c.first.steps()[302] = 1;
     },
     tc::Implausible::kMalformed, "malformed record (fields outside the layout) (curve 1)"},
    {"start voltage of a dead pack", [](tc::MotorCalibration& c) { c.first.start_mv = 2999; },
     tc::Implausible::kVoltage,
     "voltage outside the pack and monitor range (curve 1: 2.999 V; allowed 3.000..15.638 V)"},
    {"second curve above the monitor's full scale", [](tc::MotorCalibration& c) { c.second.start_mv = 16000; },
     tc::Implausible::kVoltage,
     "voltage outside the pack and monitor range (curve 2: 16.000 V; allowed 3.000..15.638 V)"},
    {"1 g at 2500 us (issue 8)", [](tc::MotorCalibration& c) { c.first.pwm_at_1g_us = 2500; },
     tc::Implausible::kPwmRange, "pulse outside the ESC range (curve 1: 2500 us; allowed 1000..2000 us)"},
    {"1 g below the ESC's stop pulse", [](tc::MotorCalibration& c) { c.second.pwm_at_1g_us = 990; },
     tc::Implausible::kPwmRange, "pulse outside the ESC range (curve 2: 990 us; allowed 1000..2000 us)"},
    {"heaviest gram beyond 2000 us",
     [](tc::MotorCalibration& c) {
       for (uint16_t i = 0; i < 100; ++i) c.first.steps()[i] = 10;
     },
     tc::Implausible::kPwmRange, ""},
    {"a curve of 4 g",
     [](tc::MotorCalibration& c) {
       for (uint16_t i = 3; i < c.first.stepCount(); ++i) c.first.steps()[i] = tc::kUnreachable;
     },
     tc::Implausible::kForceSpan, "largest force out of range (curve 1: 4 g; allowed 5..5000 g)"},
    {"flat curve: 500 g at the PWM of 1 g",
     [](tc::MotorCalibration& c) {
       for (uint16_t i = 0; i < c.first.stepCount(); ++i) c.first.steps()[i] = 0;
     },
     tc::Implausible::kFlat, "flat curve (force without drive) (curve 1: 0 us; allowed 50..1000 us)"},
    {"sag table below the ESC range", [](tc::MotorCalibration& c) { c.sag.base_pwm_us = 900; },
     tc::Implausible::kSagBase,
     "sag table base pulse outside the ESC range (900 us; allowed 1000..1999 us)"},
    {"sag offset of bin 0 not 0", [](tc::MotorCalibration& c) { c.sag.offset_mv[0] = 30; },
     tc::Implausible::kMalformed, ""},
    {"reading rises 0.5 V under load", [](tc::MotorCalibration& c) { c.sag.offset_mv[5] = -500; },
     tc::Implausible::kSag,
     "battery sag out of bounds (curve 1 sag bin 5: -0.500 V; allowed -0.300..6.200 V)"},
    {"sag of more than half the pack", [](tc::MotorCalibration& c) { c.sag.offset_mv[12] = 7000; },
     tc::Implausible::kSag, ""},
    {"second curve without a 1 g PWM", [](tc::MotorCalibration& c) { c.second.pwm_at_1g_us = 0; },
     tc::Implausible::kMalformed, ""},
};

TEST(Plausibility, EveryV1RuleRefusesItsRecordWithItsReason) {
  for (const V1Case& c : kV1Cases) {
    SCOPED_TRACE(c.name);
    // given: a good thesis record with one impossible value
    tc::MotorCalibration cal = twoCurveThesisCalibration();
    c.spoil(cal);
    // when
    const tc::Plausibility p = tc::checkCalibration(cal);
    // then
    EXPECT_EQ(p.rule, c.rule) << describe(p);
    if (c.reason[0]) {
      EXPECT_EQ(describe(p), c.reason);
    }
  }
}

TEST(Plausibility, ImplausibleV1RecordWithAGoodCrcDecodesAsNotCalibratedWithItsReason) {
  for (const V1Case& c : kV1Cases) {
    SCOPED_TRACE(c.name);
    // given: the record written with its (right) CRC
    RamEeprom::erase();
    tc::MotorCalibration cal = twoCurveThesisCalibration();
    c.spoil(cal);
    tc::writeRecord<RamEeprom>(1, cal);
    // when
    tc::MotorCalibration out;
    tc::Plausibility why;
    const tc::DecodeStatus status = tc::readRecord<RamEeprom>(1, out, tc::RecordLimits(), &why);
    // then: the codec stores sag offsets as int8 of 10 mV (saturating at 1.27 V), so the
    // "more than half the pack" offset never reaches the EEPROM; every other rule refuses
    if (c.spoil == kV1Cases[12].spoil) {
      EXPECT_EQ(status, tc::DecodeStatus::kOk);
      continue;
    }
    EXPECT_EQ(status, tc::DecodeStatus::kBadContent);
    EXPECT_EQ(why.rule, c.rule) << describe(why);
    EXPECT_FALSE(out.isCalibrated());
    EXPECT_FALSE(out.hasSecondCurve());
  }
}

struct V2Case {
  const char* name;
  void (*spoil)(tc::ModelV2&);
  tc::Implausible rule;
  const char* reason;
};

const V2Case kV2Cases[] = {
    {"40 knots", [](tc::ModelV2& m) { m.knots = 40; }, tc::Implausible::kMalformed,
     "malformed record (fields outside the layout)"},
    {"ESC start at 850 us", [](tc::ModelV2& m) { m.start_q4_us = 850 * 16; }, tc::Implausible::kStartRange,
     "ESC start threshold out of range (850 us; allowed 900..1500 us)"},
    {"ESC start at 1600 us", [](tc::ModelV2& m) { m.start_q4_us = 1600 * 16; }, tc::Implausible::kStartRange,
     ""},
    {"rests at 2.9 V", [](tc::ModelV2& m) { m.rest_mv = 2900; }, tc::Implausible::kVoltage,
     "voltage outside the pack and monitor range (2.900 V; allowed 3.000..15.638 V)"},
    {"refined at 24 V with the thesis divider", [](tc::ModelV2& m) { m.second_mv = 24000; },
     tc::Implausible::kVoltage, ""},
    {"first knot at drive 0", [](tc::ModelV2& m) { m.drive_512usmv[0] = 0; }, tc::Implausible::kFlat,
     "flat curve (force without drive) (knot 1: 0 %; at least 25 %)"},
    {"all drive knots 0xFFFF (issue 8)",
     [](tc::ModelV2& m) {
       for (uint8_t k = 0; k < m.knots; ++k) m.drive_512usmv[k] = 0xFFFF;
     },
     tc::Implausible::kFlat, "flat curve (force without drive) (0 %; at least 25 %)"},
    {"knot 6 below knot 5", [](tc::ModelV2& m) { m.drive_512usmv[5] = static_cast<uint16_t>(m.drive_512usmv[4] - 1); },
     tc::Implausible::kNotMonotone, "curve not monotone (force falls as drive rises) (knot 6)"},
    {"largest force 6.4 kg",
     [](tc::ModelV2& m) {
       m.step_dg = 1000;
       m.coarse_step_dg = 3000;
     },
     tc::Implausible::kForceSpan, "largest force out of range (6400.0 g; allowed 5.0..5000.0 g)"},
    {"a 4-decigram curve",
     [](tc::ModelV2& m) {
       m.knots = 2;
       m.fine_knots = 2;
       m.step_dg = 2;
       m.coarse_step_dg = 0;
     },
     tc::Implausible::kForceSpan, "largest force out of range (0.4 g; allowed 5.0..5000.0 g)"},
    {"1S pack sagging 2.55 V", [](tc::ModelV2& m) {
       m.rest_mv = 4200;
       m.sag_10mv[31] = 255;
     },
     tc::Implausible::kSag, "battery sag out of bounds (knot 32: 2.550 V; allowed 0.000..2.100 V)"},
    {"last knot needs more than 2000 us",
     [](tc::ModelV2& m) {
       for (uint8_t k = 0; k < m.knots; ++k) m.drive_512usmv[k] = static_cast<uint16_t>(m.drive_512usmv[k] * 3 / 2);
     },
     tc::Implausible::kPwmRange, ""},
    {"measured dynamics with a 3 ms spin-up",
     [](tc::ModelV2& m) {
       m.dynamics = tc_test::withDynamics(m).dynamics;
       m.dynamics.up_lo_01ms = 30;
     },
     tc::Implausible::kDynamics, "motor dynamics out of range (3.0 ms; allowed 5.0..2000.0 ms)"},
};

TEST(Plausibility, EveryV2RuleRefusesItsModelWithItsReason) {
  const tc::ModelV2 good = fittedModel();
  for (const V2Case& c : kV2Cases) {
    SCOPED_TRACE(c.name);
    tc::ModelV2 m = good;
    c.spoil(m);
    const tc::Plausibility p = tc::checkModelV2(m);
    EXPECT_EQ(p.rule, c.rule) << describe(p);
    if (c.reason[0]) {
      EXPECT_EQ(describe(p), c.reason);
    }
  }
}

TEST(Plausibility, ImplausibleV2CopyWithAGoodCrcIsBadContentAndNeverLoaded) {
  const tc::ModelV2 good = fittedModel();
  for (const V2Case& c : kV2Cases) {
    SCOPED_TRACE(c.name);
    // given: the spoiled model serialized with a right CRC into copy A of slot 2
    tc::ModelV2 m = good;
    c.spoil(m);
    RamEeprom::erase();
    uint8_t image[tc::kRecordV2MaxBytes];
    tc::serializeModelV2(m, 1, image);
    std::memcpy(RamEeprom::bytes + tc::copyAddressV2(2, 0), image, tc::recordV2Length(image[5]));
    // when
    tc::ModelV2 v2;
    tc::MotorCalibration v1;
    const tc::SlotLoad load = tc::loadSlot<RamEeprom>(2, v2, v1);
    // then
    EXPECT_EQ(load.layout, tc::SlotLayout::kModelV2);
    EXPECT_EQ(load.status, tc::DecodeStatus::kBadContent);
    EXPECT_EQ(load.why.rule, c.rule) << describe(load.why);
    EXPECT_FALSE(v2.isPresent());
    // and the writer refuses it: nothing reaches the EEPROM
    RamEeprom::erase();
    const tc::RecordV2Write w = tc::writeModelV2<RamEeprom>(2, m);
    EXPECT_TRUE(w.status == tc::WriteV2Status::kImplausible || w.status == tc::WriteV2Status::kInvalidModel)
        << tc::writeV2StatusText(w.status);
    EXPECT_EQ(RamEeprom::bytes[tc::copyAddressV2(2, 0)], 0xFF);
  }
}

TEST(Plausibility, EveryRuleIsExercisedByTheTables) {
  std::set<tc::Implausible> seen;
  for (const V1Case& c : kV1Cases) seen.insert(c.rule);
  for (const V2Case& c : kV2Cases) seen.insert(c.rule);
  for (uint8_t r = 1; r <= static_cast<uint8_t>(tc::kLastImplausible); ++r)
    EXPECT_TRUE(seen.count(static_cast<tc::Implausible>(r))) << tc::implausibleText(static_cast<tc::Implausible>(r));
  std::set<std::string> texts;
  for (uint8_t r = 0; r <= static_cast<uint8_t>(tc::kLastImplausible); ++r)
    texts.insert(tc::implausibleText(static_cast<tc::Implausible>(r)));
  EXPECT_EQ(texts.size(), static_cast<std::size_t>(tc::kLastImplausible) + 1);
  EXPECT_STREQ(tc::implausibleText(static_cast<tc::Implausible>(99)), "unknown rule");
}

TEST(Plausibility, TheMonitorsFullScaleBoundsTheVoltagesARecordMayHold) {
  // given: a 6S model (rests at 24.9 V)
  tc::ModelV2 m = fittedModel();
  m.rest_mv = 24900;
  for (uint8_t k = 0; k < m.knots; ++k) m.drive_512usmv[k] = static_cast<uint16_t>(m.drive_512usmv[k] * 2);
  // then: the thesis divider (15.638 V) cannot have measured it; 100k/22k (27.7 V) can
  tc::RecordLimits thesis;
  tc::RecordLimits six_s;
  six_s.monitor_full_scale_mv = 27727;
  EXPECT_EQ(tc::checkModelV2(m, thesis).rule, tc::Implausible::kVoltage);
  EXPECT_TRUE(tc::checkModelV2(m, six_s).ok()) << describe(tc::checkModelV2(m, six_s));
  // and no divider makes 26.5 V a pack voltage
  m.rest_mv = 26500;
  six_s.monitor_full_scale_mv = 40000;
  EXPECT_EQ(tc::checkModelV2(m, six_s).rule, tc::Implausible::kVoltage);
}
