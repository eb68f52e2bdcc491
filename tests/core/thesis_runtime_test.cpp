// The thesis model as read_run flies it (thesis_runtime.hpp: checkpoints in SRAM, steps read
// from the EEPROM on demand) gives the PWM of tc::forceToPwm on the decoded record, bit for
// bit, for every gram 0..510, every battery reading (all 1024 ADC counts through the monitor)
// and the sag offsets of last pulses across the ESC range.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>

#include "thrustcal/battery_monitor.hpp"
#include "thrustcal/curve_builder.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/thesis_runtime.hpp"

namespace {

std::array<uint8_t, 4096> g_eeprom;

struct RamStorage {
  static uint8_t readByte(uint16_t addr) { return g_eeprom[addr]; }
  static void updateByte(uint16_t addr, uint8_t value) { g_eeprom[addr] = value; }
  static void readBlock(uint16_t addr, void* dst, uint16_t length) {
    std::memcpy(dst, g_eeprom.data() + addr, length);
  }
};

// A curve from a sweep of force = k * (pwm - start)^exponent, built like gather_store builds it.
void sweepCurve(tc::ThesisCurve& curve, uint16_t start_mv, double start_us, double k, double exponent,
                uint16_t step_us) {
  static tc::CurveBuilder<161> builder;
  builder.reset();
  for (uint16_t pwm = 1000; pwm <= 1800; pwm = static_cast<uint16_t>(pwm + step_us)) {
    const double f = pwm > start_us ? k * std::pow(pwm - start_us, exponent) : 0.0;
    builder.add(pwm, static_cast<int16_t>(std::lround(f * 10.0)));
  }
  ASSERT_EQ(builder.build(curve).status, tc::BuildStatus::kOk);
  curve.start_mv = start_mv;
}

struct RecordCase {
  const char* what;
  double k2;           // second curve's gain; 0 = no second curve
  uint16_t v2_mv;
  double exponent;
  uint16_t step_us;
  int16_t sag_scale;   // sag offsets: bin * scale mV (record range: -1280..1270)
};

class ThesisRuntime : public ::testing::TestWithParam<RecordCase> {};

tc::MotorCalibration g_decoded;

// The case's record written to slot 2 of the EEPROM image, decoded into g_decoded and loaded
// into `run` as read_run and fly load it.
void storeAndLoad(const RecordCase& c, tc::ThesisRun& run) {
  g_eeprom.fill(0xFF);
  static tc::MotorCalibration cal;
  cal.clear();
  sweepCurve(cal.first, 12400, 1090.0, 0.004, c.exponent, c.step_us);
  if (c.k2 > 0) sweepCurve(cal.second, c.v2_mv, 1095.0, c.k2, c.exponent, c.step_us);
  cal.sag.base_pwm_us = 1000;
  for (uint8_t i = 0; i < tc::kSagBins; ++i)
    cal.sag.offset_mv[i] = static_cast<int16_t>(i == 0 ? 0 : i * c.sag_scale);
  const uint8_t slot = 2;
  tc::writeRecord<RamStorage>(slot, cal);
  ASSERT_EQ(tc::readRecord<RamStorage>(slot, g_decoded), tc::DecodeStatus::kOk);
  ASSERT_TRUE(run.load<RamStorage>(g_decoded, slot));
  ASSERT_TRUE(run.isFast()) << "a record the codec passes is on the 16-bit path";
}

// The voltages of the decigram sweeps: both curves' own, between, beyond them on both sides
// (extrapolated), the sane range's ends and just outside them (first curve alone).
const uint16_t kSweepMv[] = {5999, 6000, 9000, 10500, 11000, 11350, 12400, 13000, 14800, 17500, 17501};

TEST_P(ThesisRuntime, GivesOption21sPwmForEveryGramAndBatteryReading) {
  // given: a v1 record written to the EEPROM image and decoded as read_run decodes it
  tc::ThesisRun run;
  ASSERT_NO_FATAL_FAILURE(storeAndLoad(GetParam(), run));
  const tc::MotorCalibration& decoded = g_decoded;

  // when / then: every gram, every ADC count of the monitor, and the sag offsets of the last
  // pulses 900..2100 us (read_run adds the offset of the motor's last pulse to the reading)
  const tc::BatteryMonitor monitor;
  long compared = 0;
  for (uint16_t pwm_last = 900; pwm_last <= 2100; pwm_last = static_cast<uint16_t>(pwm_last + 37)) {
    for (uint16_t counts = 0; counts <= 1023; ++counts) {
      const uint16_t mv = monitor.compensatedMillivolts(monitor.millivoltsFromCounts(counts), pwm_last, run.sag);
      ASSERT_EQ(mv, monitor.compensatedMillivolts(monitor.millivoltsFromCounts(counts), pwm_last, decoded.sag));
      if (pwm_last != 900 && counts % 16 != 0) continue;  // every gram at every 16th reading
      for (uint16_t g = 0; g <= 510; ++g) {
        const tc::ForcePwmResult want = tc::forceToPwm(decoded, g, mv);
        const tc::ForcePwmResult got = tc::forceToPwm<RamStorage>(run, g, mv);
        ASSERT_EQ(got.pwm_us, want.pwm_us) << g << " g at " << mv << " mV";
        ASSERT_EQ(got.flags, want.flags) << g << " g at " << mv << " mV";
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 1500000);

  // and: grams in a scattered order (each curve keeps the sums of the block it last looked up:
  // a jump to another block, back, and a neighbour in the same block)
  const uint16_t mv = monitor.millivoltsFromCounts(800);
  uint32_t x = 12345;
  for (int i = 0; i < 20000; ++i) {
    x = x * 1103515245u + 12345u;
    const uint16_t g = static_cast<uint16_t>((x >> 16) % 520);
    ASSERT_EQ(tc::forceToPwm<RamStorage>(run, g, mv).pwm_us, tc::forceToPwm(decoded, g, mv).pwm_us) << g << " g";
  }
}

TEST_P(ThesisRuntime, GivesOption21sPwmForEveryDecigramInAnyOrder) {
  // given
  tc::ThesisRun run;
  ASSERT_NO_FATAL_FAILURE(storeAndLoad(GetParam(), run));
  const tc::MotorCalibration& decoded = g_decoded;
  const auto check = [&](uint16_t dg, uint16_t mv) {
    const tc::ForcePwmResult want = tc::forceToPwmDg(decoded, dg, mv);
    const tc::ForcePwmResult got = tc::forceToPwmDg<RamStorage>(run, dg, mv);
    ASSERT_EQ(got.pwm_us, want.pwm_us) << dg << " dg at " << mv << " mV";
    ASSERT_EQ(got.flags, want.flags) << dg << " dg at " << mv << " mV";
  };

  // when / then: every decigram 0..520 g, up and down (the walk from the last gram, both ways),
  // at each voltage
  for (const uint16_t mv : kSweepMv) {
    for (uint16_t dg = 0; dg <= 5200; ++dg) ASSERT_NO_FATAL_FAILURE(check(dg, mv));
    for (uint16_t dg = 5200; dg > 0; --dg) ASSERT_NO_FATAL_FAILURE(check(dg, mv));
  }
  // and: a force wandering a few grams a call, up and down across the whole curve (the byte by
  // byte walk of 1..kThesisNearGrams grams from the last gram, and just beyond it), at each voltage
  for (const uint16_t mv : kSweepMv) {
    uint32_t y = 4242;
    int32_t dg = 0;
    for (int i = 0; i < 6000; ++i) {
      y = y * 1103515245u + 12345u;
      const int32_t move_dg = static_cast<int32_t>((y >> 16) % 81) - 40;  // -4.0..+4.0 g
      dg += (i / 1500) % 2 == 0 ? move_dg + 4 : move_dg - 4;  // drift up, then down, twice
      dg = dg < 0 ? 0 : (dg > 5300 ? 5300 : dg);
      ASSERT_NO_FATAL_FAILURE(check(static_cast<uint16_t>(dg), mv));
    }
  }
  // and: jumps of any size in a scattered order (the walk from the nearest checkpoint), at
  // scattered readings across the sane range
  uint32_t x = 777;
  for (int i = 0; i < 200000; ++i) {
    x = x * 1103515245u + 12345u;
    const uint16_t dg = static_cast<uint16_t>((x >> 8) % 5300);
    const uint16_t mv = static_cast<uint16_t>(5900 + (x >> 20) % 11700);
    ASSERT_NO_FATAL_FAILURE(check(dg, mv));
  }
  // and: the voltage term's division by the reciprocal is floor division over its whole range
  if (run.hasSecondCurve()) {
    const uint32_t d = run.spanX10();
    for (uint32_t m = 0; m < (1ul << 24); m += 61) ASSERT_EQ(run.spanQuotient(m), m / d) << m;
    for (uint32_t q = 0; q * d < (1ul << 24); ++q) {
      for (const uint32_t m : {q * d, q * d + d - 1}) {
        if (m < (1ul << 24)) {
          ASSERT_EQ(run.spanQuotient(m), m / d) << m;
        }
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(
    Records, ThesisRuntime,
    ::testing::Values(RecordCase{"two curves, thesis sweep", 0.0035, 10500, 1.8, 10, 12},
                      RecordCase{"single curve", 0.0, 0, 1.8, 10, 12},
                      RecordCase{"steep curve, coarse sweep, negative sag (a rise under load, within kMaxSagRiseMv)", 0.006, 11000, 2.0, 20, -12},
                      RecordCase{"sag offsets at the record's limits", 0.0035, 13000, 1.6, 5, 105}),
    [](const ::testing::TestParamInfo<RecordCase>& info) { return std::string("case") + std::to_string(info.index); });

TEST(ThesisRun, KeepsTheFourSlotsInAQuarterOfTheThesisRecordsSram) {
  EXPECT_LT(sizeof(tc::ThesisRun) * 4, sizeof(tc::MotorCalibration));
}

TEST(ThesisRun, RefusesAnEepromThatNoLongerHoldsTheDecodedSteps) {
  // given: a decoded record, then one step byte changed in the EEPROM behind it
  g_eeprom.fill(0xFF);
  static tc::MotorCalibration cal;
  cal.clear();
  sweepCurve(cal.first, 12400, 1090.0, 0.004, 1.8, 10);
  tc::writeRecord<RamStorage>(0, cal);
  static tc::MotorCalibration decoded;
  ASSERT_EQ(tc::readRecord<RamStorage>(0, decoded), tc::DecodeStatus::kOk);
  g_eeprom[tc::kRecordFirstStepsOffset + 40] ^= 0x01;

  // when
  tc::ThesisRun run;
  const bool loaded = run.load<RamStorage>(decoded, 0);

  // then: not flown
  EXPECT_FALSE(loaded);
  EXPECT_FALSE(run.isCalibrated());
}

}  // namespace
