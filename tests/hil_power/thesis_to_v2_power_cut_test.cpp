// Power loss while gather_store's `store v2` replaces a thesis (v1) record, on the REAL images
// in simavr: every physical EEPROM write of the store recorded, read_run booted on the image cut
// after each one (power_cut_support.hpp).
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "power_cut_support.hpp"

namespace {

using namespace power_cut;

//
// The thesis (v1) record fills its slot and its CRC covers every byte, so the first byte model
// v2 writes into the slot destroys it. gather_store (tc::storeModelV2) writes the model first
// into a spare copy in another slot (slot 1, erased here), then into slot 0's copy A, then
// erases the spare. For EVERY cut point read_run must boot flying the thesis record or model
// v2, whole: the start-up line is one of the two, and the PWM it sends is that model's.

struct ThesisToV2Recording {
  std::vector<uint8_t> old_image;    // after `store 1`
  std::vector<uint8_t> final_image;  // after `store v2`
  std::vector<EepromWrite> writes;   // physical writes of `store v2`, in order
  std::vector<std::string> store_lines;
};

const ThesisToV2Recording& thesisToV2Recording() {
  static std::unique_ptr<ThesisToV2Recording> r;
  if (r) return *r;
  r = std::make_unique<ThesisToV2Recording>();
  const plant::BenchParams params = benchFor(kMotorSeed, 0.03);
  sim::BenchRig rig(imagePath("gather_store"), params, 0);
  sim::Console con(rig.board, "gs> ");
  calibrateAndSweep(rig, con, params);
  mustCommand(con, "store 1", 10);
  r->old_image = rig.board.eeprom();
  EepromWriteRecorder recorder(rig.board);
  recorder.recording = true;
  r->store_lines = mustCommand(con, "store v2", 10);
  recorder.recording = false;
  r->writes = recorder.writes;
  r->final_image = rig.board.eeprom();
  return *r;
}

StoreRecording asStoreRecording(const ThesisToV2Recording& rec) {
  StoreRecording s;
  s.old_image = rec.old_image;
  s.final_image = rec.final_image;
  s.writes = rec.writes;
  return s;
}

struct V1Status {
  int pwm_us = -1;
  int battery_mv = -1;  // compensated (v1) or filtered (v2)
  double pulse_us = -1;
};

// Boots read_run on `image`, commands `grams` to motor 0 and reads its status line.
std::pair<std::vector<std::string>, V1Status> bootAndCommand(const std::vector<uint8_t>& image, int grams) {
  sim::Board board(imagePath("read_run"));
  board.setAdcSource([](int ch) { return ch == 1 ? kBatteryPinMv : 0.0; });
  board.setEeprom(image);
  sim::Console con(board, "rr> ");
  std::pair<std::vector<std::string>, V1Status> out;
  out.first = con.waitPrompt(5.0);
  con.command(fmt::format("f 0 {}", grams), 2.0);
  for (int i = 0; i < 5; ++i) {
    con.send("");
    board.runFor(0.3);
  }
  static const tc::test::Pattern status_re(R"(^motor 0: \d+\.\d g, (\d+) us, battery (\d+)\.(\d{3}) V (filtered|compensated))");
  for (const auto& l : con.command("status", 2.0)) {
    tc::test::Groups m;
    if (status_re.foundIn(l, &m)) {
      out.second.pwm_us = std::stoi(m[1]);
      out.second.battery_mv = std::stoi(m[2]) * 1000 + std::stoi(m[3]);
    }
  }
  out.second.pulse_us = board.escPulseUs(0);
  return out;
}

std::string v1ReportFor(const tc::MotorCalibration& cal) {
  uint16_t grams = cal.first.maxGrams();
  if (cal.hasSecondCurve() && cal.second.maxGrams() < grams) grams = cal.second.maxGrams();
  return fmt::format("motor 0: ok, V1 {} V, V2 {}, max {} g, model v1 (thesis option 2.1)",
                     fixed(cal.first.start_mv, 3),
                     cal.hasSecondCurve() ? fixed(cal.second.start_mv, 3) + " V"
                                          : std::string("none (single curve, no voltage compensation)"),
                     grams);
}

TEST(ThesisToV2PowerCut, EveryCutLeavesReadRunFlyingTheThesisRecordOrModelV2Whole) {
  HIL_REQUIRE_IMAGE("gather_store");
  HIL_REQUIRE_IMAGE("read_run");
  // given: the recorded store and both calibrations as the codec decodes them
  const ThesisToV2Recording& rec = thesisToV2Recording();
  ASSERT_FALSE(rec.writes.empty());
  std::string stored;
  for (const auto& l : rec.store_lines)
    if (l.rfind("stored model v2", 0) == 0) stored = l;
  EXPECT_NE(stored.find("(EEPROM 0..1023, copy A, sequence 1)"), std::string::npos) << stored;
  EXPECT_NE(stored.find("; replaced the thesis record"), std::string::npos) << stored;
  EXPECT_NE(std::find(rec.store_lines.begin(), rec.store_lines.end(),
                      "# power-fail safe: the old calibration stayed loadable (a copy in motor 1's slot) "
                      "until the new one was complete"),
            rec.store_lines.end());
  const StoreRecording as_store = asStoreRecording(rec);
  EXPECT_EQ(cutImage(as_store, rec.writes.size()), rec.final_image);
  auto v1 = std::make_unique<tc::MotorCalibration>();
  {
    const tc::EepromImage::Use use(rec.old_image);
    ASSERT_EQ(tc::readRecord<tc::EepromImage>(0, *v1), tc::DecodeStatus::kOk);
  }
  tc::ModelV2 v2;
  ASSERT_EQ(readSlot0(rec.final_image, v2).copy, 0);
  const std::string old_report = v1ReportFor(*v1), new_report = reportFor(v2);
  // the writes: the spare in slot 1 first (its last byte a CRC byte), then slot 0, then the
  // spare's version byte
  const uint16_t spare = tc::spareAddressV2(0, 1);
  ASSERT_GE(rec.writes.size(), 3u);
  EXPECT_GE(rec.writes.front().addr, spare);
  EXPECT_LT(rec.writes.front().addr, spare + tc::kRecordV2Bytes);
  EXPECT_EQ(rec.writes.back().addr, spare);
  EXPECT_EQ(rec.writes.back().value, 0xFF);

  // when / then: every cut point
  constexpr int kGrams = 250;
  const std::size_t n = rec.writes.size();
  std::size_t first_new = n + 1;
  for (std::size_t k = 0; k <= n; ++k) {
    SCOPED_TRACE(fmt::format("cut after {} of {} writes", k, n));
    const auto [report, status] = bootAndCommand(cutImage(as_store, k), kGrams);
    std::string line;
    for (const auto& l : report)
      if (l.rfind("motor 0:", 0) == 0) line = l;
    const bool is_old = line == old_report;
    const bool is_new = line.rfind(new_report, 0) == 0;
    ASSERT_TRUE(is_old || is_new) << "read_run said: '" << line << "'\nold: '" << old_report << "'\nnew: '"
                                  << new_report << "'";
    EXPECT_NE(std::find(report.begin(), report.end(), "calibrated motors: 1 of 4"), report.end());
    ASSERT_GT(status.pwm_us, 0) << "no status line";
    tc::BusVoltageFilter bus;
    bus.reset(static_cast<uint16_t>(status.battery_mv));
    const int expected = is_new ? tc::forceToPwmV2(v2, kGrams * 10, bus).pwm_us
                                : tc::forceToPwm(*v1, kGrams, static_cast<uint16_t>(status.battery_mv)).pwm_us;
    EXPECT_NEAR(status.pwm_us, expected, is_new ? 1 : 0);
    EXPECT_NEAR(status.pulse_us, status.pwm_us + 0.5, 1.0);
    if (is_new && first_new > n) first_new = k;
    EXPECT_FALSE(first_new <= n && is_old) << "went back to the thesis record";
  }
  // the switch happens once, with the spare's last CRC byte, long before slot 0 is touched
  EXPECT_LE(first_new, tc::kRecordV2Bytes);
  RecordProperty("cut_points", std::to_string(n + 1));
  RecordProperty("switch_at_write", std::to_string(first_new));
  std::printf("v1 -> v2: %zu cut points, model v2 flies from write %zu on\n", n + 1, first_new);
}

}  // namespace
