// The thesis records read_run and fly fly (tc::ThesisRun, its 16-bit path) against option 2.1 on
// the decoded record (tc::forceToPwmDg on tc::MotorCalibration, the 32-bit reference), on the
// bench's four gathered records (bench::benchRecords: each motor swept on the simulated bench
// as gather_store sweeps it, stored as gather_store stores it): the same pulse and flags for
// every decigram up to past each curve's end, at readings across the sane range, in the orders
// a flight asks for them (up, down, jumps), with the sag offset of the pulse last sent added to
// the reading as the firmware adds it.
#include <gtest/gtest.h>

#include <vector>

#include "bench/records.hpp"
#include "thrustcal/battery_monitor.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/thesis_runtime.hpp"

namespace {

const std::vector<uint8_t>* g_image = nullptr;

struct ImageStorage {
  static uint8_t readByte(uint16_t addr) { return (*g_image)[addr]; }
  static void readBlock(uint16_t addr, void* dst, uint16_t length) {
    uint8_t* out = static_cast<uint8_t*>(dst);
    for (uint16_t i = 0; i < length; ++i) out[i] = (*g_image)[addr + i];
  }
};

TEST(ThesisFastPath, EqualsOption21OnTheBenchsGatheredRecordsForEveryDecigram) {
  // given: the four slots of the bench's v1 EEPROM image, decoded and loaded as the firmware does
  const bench::BenchRecords& records = bench::benchRecords();
  g_image = &records.v1;
  const tc::BatteryMonitor monitor;
  long compared = 0;
  for (uint8_t slot = 0; slot < 4; ++slot) {
    SCOPED_TRACE(static_cast<int>(slot));
    static tc::MotorCalibration decoded;
    ASSERT_EQ(tc::readRecord<ImageStorage>(slot, decoded), tc::DecodeStatus::kOk);
    ASSERT_TRUE(decoded.hasSecondCurve()) << "the bench's records have both curves";
    tc::ThesisRun run;
    ASSERT_TRUE(run.load<ImageStorage>(decoded, slot));
    ASSERT_TRUE(run.isFast());
    const uint16_t top_dg = static_cast<uint16_t>(10u * decoded.first.maxGrams() + 30u);

    // when / then: up and down through every decigram at readings from below the sane range
    // to above it (each with the sag offset of the last pulse), then scattered jumps
    uint16_t last_pwm_us = tc::kStopPwmUs;
    const auto check = [&](uint16_t dg, uint16_t reading_mv) {
      const uint16_t mv = monitor.compensatedMillivolts(reading_mv, last_pwm_us, run.sag);
      const tc::ForcePwmResult want = tc::forceToPwmDg(decoded, dg, mv);
      const tc::ForcePwmResult got = tc::forceToPwmDg<ImageStorage>(run, dg, mv);
      ASSERT_EQ(got.pwm_us, want.pwm_us) << dg << " dg at " << mv << " mV";
      ASSERT_EQ(got.flags, want.flags) << dg << " dg at " << mv << " mV";
      last_pwm_us = got.pwm_us;
      ++compared;
    };
    for (uint16_t reading_mv = 5800; reading_mv <= 17800; reading_mv = static_cast<uint16_t>(reading_mv + 400)) {
      for (uint16_t dg = 0; dg <= top_dg; ++dg) ASSERT_NO_FATAL_FAILURE(check(dg, reading_mv));
      for (uint16_t dg = top_dg; dg > 0; --dg) ASSERT_NO_FATAL_FAILURE(check(dg, reading_mv));
    }
    uint32_t x = 2024u + slot;
    for (int i = 0; i < 50000; ++i) {
      x = x * 1103515245u + 12345u;
      ASSERT_NO_FATAL_FAILURE(check(static_cast<uint16_t>((x >> 8) % (top_dg + 1u)),
                                    static_cast<uint16_t>(9000u + (x >> 20) % 4500u)));
    }
  }
  EXPECT_GT(compared, 1000000);
}

}  // namespace
