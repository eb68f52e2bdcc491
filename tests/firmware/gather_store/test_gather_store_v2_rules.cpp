// gather_store's model v2 commands against the fake HAL and plant.hpp: records that cannot be
// right are named by the rule they break, v1 -> v2 switches stay power-fail-safe (the thesis
// record loadable until model v2 is whole), and the divider setting (the fixture:
// gather_store_v2_fixture.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "gather_store_v2_fixture.hpp"
#include "text_match.hpp"

namespace {

using gs_test::FakeStorage;
using gs_test::GatherStoreV2;
using gs_test::kOneSweepTolerancePct;
using gs_test::startsWith;

// ---- records that cannot be right, power-fail-safe switches, the divider ---------------------

TEST_F(GatherStoreV2, ShowSaysWhichRuleAStoredRecordBreaks) {
  // given: a thesis record that puts 1 g at 2500 us (right CRC) in slot 0, a v2 model with
  // every drive knot 0xFFFF in slot 1 (issue 8's examples)
  hal::fake::advanceMs(gs::kArmMs);
  sweepAt(12.6);
  command("store 1");
  tc::MotorCalibration cal;
  ASSERT_EQ(tc::readRecord<FakeStorage>(0, cal), tc::DecodeStatus::kOk);
  cal.first.pwm_at_1g_us = 2500;
  tc::writeRecord<FakeStorage>(0, cal);
  command("store v2");  // slot 0 again: model v2, then spoil a copy of it into slot 1
  tc::ModelV2 m;
  ASSERT_EQ(tc::readModelV2<FakeStorage>(0, m).status, tc::DecodeStatus::kOk);
  for (uint8_t k = 0; k < m.knots; ++k) m.drive_512usmv[k] = 0xFFFF;
  uint8_t image[tc::kRecordV2Bytes];
  tc::serializeModelV2(m, 1, image);
  std::copy(image, image + sizeof image, hal::fake::eeprom() + tc::copyAddressV2(1, 0));
  tc::writeRecord<FakeStorage>(2, cal);
  // when / then
  command("motor 1");
  EXPECT_EQ(command("show").lines.at(0),
            "motor 1 (EEPROM 1024..2047): not calibrated: v2 record, both copies bad (copy A implausible "
            "values, copy B erased (never calibrated)): implausible: flat curve (force without drive) (0 %; at least 25 %)");
  command("motor 2");
  EXPECT_EQ(command("show").lines.at(0),
            "motor 2 (EEPROM 2048..3071): not calibrated: implausible: pulse outside the ESC range (curve 1: "
            "2500 us; allowed 1000..2000 us)");
}

TEST_F(GatherStoreV2, StoreV2OverAThesisRecordKeepsItLoadableUntilModelV2IsWhole) {
  // given: motor 0 holds the thesis record; slot 1 is free
  hal::fake::advanceMs(gs::kArmMs);
  sweepAt(12.6);
  command("store 1");
  // when
  const Response out = command("store v2");
  // then: the store says how it stayed power-fail safe and counts every byte it wrote
  ASSERT_EQ(out.lines.size(), 3u) << out.text();
  EXPECT_TRUE(startsWith(out.lines[0], "stored model v2 of motor 0 (EEPROM 0..1023, copy A, sequence 1)"))
      << out.lines[0];
  EXPECT_NE(out.lines[0].find("; replaced the thesis record"), std::string::npos);
  EXPECT_EQ(out.lines[1], "# power-fail safe: the old calibration stayed loadable (a copy in motor 1's "
                          "slot) until the new one was complete");
  EXPECT_EQ(wroteBytes(out), static_cast<int>(out.physical_writes));
  tc::ModelV2 v2;
  const tc::SlotLoad slot = load(0, v2);
  EXPECT_EQ(slot.layout, tc::SlotLayout::kModelV2);
  EXPECT_EQ(slot.v2.copy, 0) << "the spare in slot 1 is erased";
}

TEST_F(GatherStoreV2, StoreV2OverAThesisRecordWithNoSlotToSpareSaysItWasUnprotected) {
  // given: thesis records in all four slots
  hal::fake::advanceMs(gs::kArmMs);
  sweepAt(12.6);
  command("store 1");
  tc::MotorCalibration cal;
  ASSERT_EQ(tc::readRecord<FakeStorage>(0, cal), tc::DecodeStatus::kOk);
  for (uint8_t s = 1; s < 4; ++s) tc::writeRecord<FakeStorage>(s, cal);
  // when
  const Response out = command("store v2");
  // then
  ASSERT_GE(out.lines.size(), 2u);
  EXPECT_TRUE(startsWith(out.lines[0], "stored model v2 of motor 0")) << out.lines[0];
  EXPECT_EQ(out.lines[1], "warning: motor 0 was switched in place: the other three slots hold thesis records, "
                          "so no slot could keep the old calibration meanwhile (a power cut then leaves the "
                          "motor not calibrated, never flown wrong)");
}

TEST_F(GatherStoreV2, TheDividerSettingScalesTheMonitorAndDropsASweepMeasuredWithTheOldOne) {
  // given
  hal::fake::advanceMs(gs::kArmMs);
  sweepAt(12.6);
  const auto banner_lines = gs_test::splitLines(banner_);
  EXPECT_TRUE(std::any_of(banner_lines.begin(), banner_lines.end(), [](const std::string& l) {
    return startsWith(l, "battery monitor: divider 100000/47000 ohm");
  })) << banner_;
  // when
  const Response set = command("divider 100000 22000");
  // then: stored, and the last sweep (volts through 100k/47k) is gone
  ASSERT_EQ(set.lines.size(), 2u) << set.text();
  EXPECT_EQ(set.lines[0], "divider 100000/22000 ohm, full scale 27.727 V, stored (motor 3's slot, copy A)");
  EXPECT_EQ(set.lines[1], "note: the last sweep was measured with the old divider and is dropped: sweep again "
                          "before store");
  EXPECT_EQ(command("store v2").lines.at(0), "error: nothing to store: run a complete sweep first");
  // the plant's A1 still carries the pack through 100k/47k: read through 100k/22k every volt
  // reads 27.727 / 15.638 = 1.77 V
  const Response status = command("status");
  tc::test::Groups m;
  const std::string text = status.text();
  ASSERT_TRUE(tc::test::Pattern(R"(battery (\d+\.\d+) V)").foundIn(text, &m)) << text;
  EXPECT_NEAR(std::stod(m[1]), plant_.vbat_v * 27727.0 / 15638.0, 1.5) << text;
  // a new app (a reboot) reads it back
  app_ = std::make_unique<gs::GatherStoreApp>();
  app_->begin();
  EXPECT_NE(hal::fake::takeOutput().find("battery monitor: divider 100000/22000 ohm, full scale 27.727 V"),
            std::string::npos);
}

}  // namespace
