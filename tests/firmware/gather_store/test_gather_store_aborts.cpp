// gather_store console against the fake HAL and a simple plant (plant.hpp): the aborts (a key
// during a sweep, overload, ADC rails, battery out of range) and the rejection of bad input
// (one error line, nothing changed; stores that cannot be right refused).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "gather_store_app.hpp"
#include "gather_store_fixture.hpp"
#include "hal/fake.hpp"
#include "hal/hal.hpp"
#include "plant.hpp"
#include "text_match.hpp"
#include "thrustcal/eeprom_codec.hpp"

namespace {

using gs_test::countLinesStartingWith;
using gs_test::FakeStorage;
using gs_test::GatherStore;
using gs_test::splitLines;
using gs_test::startsWith;


// ------------------------------------------------------------------------------------------
// Aborts

TEST_F(GatherStore, AnyKeyDuringTheSweepStopsTheMotorAtOnce) {
  // given: a sweep under way, a key arriving at a known time
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  const uint32_t key_at = hal::fake::nowMs() + 5000;  // mid-sweep (about 1240 us)
  hal::fake::feedInputAt(key_at, "x\r");  // a key, then Enter: nothing else is discarded
  std::vector<std::pair<uint32_t, uint16_t>> pulses;
  hal::fake::setTickHook([&](uint32_t now) {
    plant_.tick();
    pulses.push_back({now, hal::Esc::pulseUs(0)});
  });
  // when
  const std::string out = sweep();
  // then: the motor ran when the key arrived, and was stopped within that same millisecond
  // (no simulated time passed between the key and the 1000 us pulse)
  ASSERT_FALSE(pulses.empty());
  EXPECT_EQ(pulses.back().first, key_at);
  EXPECT_GT(pulses.back().second, 1000u);
  EXPECT_EQ(hal::fake::nowMs(), key_at);
  hal::fake::advanceMs(5);
  for (size_t i = pulses.size() - 5; i < pulses.size(); ++i) EXPECT_EQ(pulses[i].second, 1000u);
  EXPECT_EQ(hal::fake::pulseUs(0), 1000u);
  EXPECT_NE(out.find("# aborted: key pressed; motor stopped (1000 us)"), std::string::npos) << out;
  EXPECT_EQ(out.find("unknown command"), std::string::npos);  // the key is not a command
  EXPECT_EQ(app_->lastSweepEnd(), gs::SweepEnd::kKey);
  EXPECT_FALSE(app_->lastSweep().valid);
  // nothing to store
  EXPECT_TRUE(startsWith(responseLines(run("store 1"))[0], "error: nothing to store"));
}

TEST_F(GatherStore, CrLfLineEndsDoNotAbortTheSweepTheyStart) {
  // given: a terminal that sends CR LF
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  // when
  hal::fake::takeOutput();
  hal::fake::feedInput("sweep\r\n");
  while (!app_->poll()) hal::Clock::sleepUntilInterrupt();
  const std::string out = hal::fake::takeOutput();
  // then
  EXPECT_EQ(out.find("# aborted"), std::string::npos) << out;
  EXPECT_NE(out.find("# done: 81 samples"), std::string::npos) << out;
}

TEST_F(GatherStore, CrLfLineEndArrivingALittleLaterStillDoesNotAbort) {
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  hal::fake::feedInputAt(hal::fake::nowMs() + 2, "\n");  // a slow link: LF 2 ms after CR
  const std::string out = sweep();
  EXPECT_EQ(out.find("# aborted"), std::string::npos) << out;
  EXPECT_TRUE(app_->lastSweep().valid);
}

TEST_F(GatherStore, AKeyRightAfterSweepAbortsBeforeTheMotorStarts) {
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  hal::fake::setTickHook([&](uint32_t) {
    plant_.tick();
    EXPECT_EQ(hal::Esc::pulseUs(0), 1000u);
  });
  const std::string out = run("sweep\rx");
  EXPECT_NE(out.find("# aborted: key pressed"), std::string::npos) << out;
  EXPECT_EQ(out.find("pwm_us,"), std::string::npos) << out;
}

TEST_F(GatherStore, TheLineThatAbortedTheSweepIsDiscardedUpToItsEndWithOneError) {
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  hal::fake::feedInputAt(hal::fake::nowMs() + 3000, "tare");
  sweep();
  // when: the line goes on and ends ("tarestatus": the "t" aborted the sweep)
  const auto rest = responseLines(run("status"));
  // then: neither "tare" nor "status" ran; one error says so; the next line runs again
  ASSERT_FALSE(rest.empty());
  EXPECT_EQ(rest[0], "error: ignored the rest of the line whose first key aborted (9 characters), "
                     "ignored; nothing changed");
  const auto lines = responseLines(run("status"));
  ASSERT_FALSE(lines.empty());
  EXPECT_TRUE(startsWith(lines[0], "motor 0")) << lines[0];
}

TEST_F(GatherStore, EraseTypedDuringASweepErasesNothing) {
  // given: slot 0 holds a curve; a sweep runs
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  sweep();
  run("store 1");
  const std::vector<uint8_t> before(hal::fake::eeprom(), hal::fake::eeprom() + hal::Eeprom::kSize);
  hal::fake::feedInputAt(hal::fake::nowMs() + 3000, "x");
  hal::fake::feedInputAt(hal::fake::nowMs() + 3002, "erase\r");  // typed after the key
  // when
  std::string out = sweep();
  for (int ms = 0; ms < 100; ++ms) {  // the main loop goes on
    app_->poll();
    hal::Clock::sleepUntilInterrupt();
  }
  out += hal::fake::takeOutput();
  // then
  EXPECT_NE(out.find("# aborted: key pressed"), std::string::npos) << out;
  EXPECT_EQ(out.find("erased motor"), std::string::npos) << out;
  EXPECT_NE(out.find("error: ignored the rest of the line whose first key aborted (5"),
            std::string::npos)
      << out;
  EXPECT_EQ(std::vector<uint8_t>(hal::fake::eeprom(), hal::fake::eeprom() + hal::Eeprom::kSize),
            before);
}

TEST_F(GatherStore, LoadCellOverloadAbortsTheSweep) {
  // given: a cell spanned to 1.5 g per count and a motor pulling up to 1200 g
  plant_.g_per_count = 1.5;
  plant_.full_g = 1200.0;
  plant_.base_counts = 250.0;
  hal::fake::advanceMs(gs::kArmMs);
  run("tare");
  plant_.extra_weight_g = 150.0;
  ASSERT_NE(run("span 150").find("span: 1.500000 g per count"), std::string::npos);
  plant_.extra_weight_g = 0.0;
  calibrateAndTare();
  // when
  const std::string out = sweep();
  // then: stopped near the PWM where the thrust crosses 950 g (plant: 1721 us)
  EXPECT_EQ(app_->lastSweepEnd(), gs::SweepEnd::kOverload);
  EXPECT_EQ(hal::fake::pulseUs(0), 1000u);
  EXPECT_NE(out.find("# aborted: load cell overload, force 9"), std::string::npos) << out;
  EXPECT_NE(out.find("\r\n1720,"), std::string::npos);
  EXPECT_EQ(out.find("\r\n1730,"), std::string::npos);
  EXPECT_FALSE(app_->lastSweep().valid);
}

TEST_F(GatherStore, ReadingAtTheAdcRailAbortsTheSweep) {
  // given: an amplifier offset that saturates A0 once the thrust passes about 470 g
  plant_.base_counts = 400.0;
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  // when
  const std::string out = sweep();
  // then
  EXPECT_EQ(app_->lastSweepEnd(), gs::SweepEnd::kImplausible);
  EXPECT_EQ(hal::fake::pulseUs(0), 1000u);
  EXPECT_NE(out.find("# aborted: load cell reads 10"), std::string::npos) << out;
  EXPECT_NE(out.find("(ADC rail)"), std::string::npos) << out;
  EXPECT_FALSE(app_->lastSweep().valid);
}

TEST_F(GatherStore, TareAtTheAdcRailIsRefused) {
  plant_.base_counts = 0.0;
  plant_.spike_counts = 0;
  const auto lines = responseLines(run("tare"));
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_TRUE(startsWith(lines[0], "error: load cell reads 0 counts (ADC rail)")) << lines[0];
  EXPECT_FALSE(app_->loadCell().isTared());
}

TEST_F(GatherStore, BatteryReadingOutsideTheSaneRangeAbortsTheSweep) {
  struct Row {
    double vbat_v;
    const char* message;
  };
  const Row rows[] = {
      {2.5, "# aborted: battery reads 2.506 V, outside 3.000 V..15.637 V"},    // below one cell
      {17.0, "# aborted: battery reads 15.638 V, outside 3.000 V..15.637 V"},  // the ADC's rail
  };
  for (const Row& r : rows) {
    SCOPED_TRACE(r.vbat_v);
    SetUp();
    plant_.vbat_v = r.vbat_v;  // divider unplugged, a flat pack, or a pack above the divider
    hal::fake::advanceMs(gs::kArmMs);
    calibrateAndTare();
    const std::string out = sweep();
    EXPECT_EQ(app_->lastSweepEnd(), gs::SweepEnd::kBattery);
    EXPECT_NE(out.find(r.message), std::string::npos) << out;
    EXPECT_EQ(hal::fake::pulseUs(0), 1000u);
  }
}

TEST_F(GatherStore, AbortLinesKeepTheCapturedLogACsvWithComments) {
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  hal::fake::feedInputAt(hal::fake::nowMs() + 2000, "q");
  for (const auto& line : responseLines(sweep())) {
    const bool csv = tc::test::Pattern(R"(^[0-9a-z_,.\-]+$)").matches(line);
    EXPECT_TRUE(csv || startsWith(line, "# ")) << line;
  }
}

// ------------------------------------------------------------------------------------------
// Bad input: one "error: " line, nothing changes

struct BadInputRow {
  const char* input;
  const char* error_start;
};

TEST_F(GatherStore, BadInputGetsOneErrorLineAndChangesNothing) {
  const std::string too_long(fw::kLineMax + 1, 'm');
  const BadInputRow rows[] = {
      {"foo", "error: unknown command \"foo\"; type help for the list"},
      {"Sweep", "error: unknown command \"Sweep\""},
      {"motor", "error: usage: motor N"},
      {"motor 4", "error: N must be a whole number 0..3, got \"4\""},
      {"motor -1", "error: N must be a whole number 0..3, got \"-1\""},
      {"motor one", "error: N must be a whole number 0..3, got \"one\""},
      {"motor 1 2", "error: usage: motor N"},
      {"plate 501", "error: G must be a whole number 0..500"},
      {"cal 0", "error: W must be a whole number 1..950"},
      {"cal 951", "error: W must be a whole number 1..950"},
      {"span 2000", "error: W must be a whole number 1..950"},
      {"range 900 1800", "error: MIN must be a whole number 1000..1999, got \"900\""},
      {"range 1000 2001", "error: MAX must be a whole number 1001..2000, got \"2001\""},
      {"range 1500 1200", "error: range MAX must be above MIN (1500 us), got 1200"},
      {"range 1500 1500", "error: range MAX must be above MIN (1500 us), got 1500"},
      {"range 1000", "error: usage: range MIN MAX"},
      {"step 0", "error: US must be a whole number 1..100"},
      {"step 4", "error: a step of 4 us makes 201 steps, at most 161 fit"},
      {"step 2.5", "error: US must be a whole number 1..100, got \"2.5\""},
      {"settle -1", "error: usage: settle MS | settle auto"},
      {"settle 10001", "error: usage: settle MS | settle auto"},
      {"settle 200 auto", "error: usage: settle MS | settle auto"},
      {"store", "error: usage: store 1 | store 2 | store v2"},
      {"store 3", "error: usage: store 1 | store 2 | store v2"},
      {"store 1", "error: nothing to store: run a complete sweep first"},
      {"sweep now", "error: usage: sweep"},
      {"erase all", "error: usage: erase"},
      {"weigh 1", "error: usage: weigh"},
      {"status x", "error: usage: status"},
      {"divider 100000", "error: usage: divider | divider R1 R2"},
      {"divider 1 20000000", "error: R2 must be a whole number 0..10000000"},
      {"eeprom", "error: usage: eeprom crc|dump"},
      {"eeprom crc x", "error: usage: eeprom crc|dump"},
      {"strict maybe", "error: expected on|off, got \"maybe\""},
      {too_long.c_str(), "error: line longer than 48 characters, ignored; nothing changed"},
  };
  for (const auto& row : rows) {
    const gs::SweepSettings before = app_->sweepSettings();
    const std::vector<uint8_t> eeprom_before = eepromSnapshot();
    const uint16_t pulse_before = hal::fake::pulseUs(before.slot);
    const std::string out = run(row.input);
    const auto lines = responseLines(out);
    ASSERT_EQ(lines.size(), 1u) << row.input << " -> " << out;
    EXPECT_TRUE(startsWith(lines[0], row.error_start)) << row.input << " -> " << lines[0];
    const gs::SweepSettings after = app_->sweepSettings();
    EXPECT_EQ(after.slot, before.slot) << row.input;
    EXPECT_EQ(after.plate_g, before.plate_g) << row.input;
    EXPECT_EQ(after.pwm_min_us, before.pwm_min_us) << row.input;
    EXPECT_EQ(after.pwm_max_us, before.pwm_max_us) << row.input;
    EXPECT_EQ(after.step_us, before.step_us) << row.input;
    EXPECT_EQ(after.settle_ms, before.settle_ms) << row.input;
    EXPECT_EQ(eepromSnapshot(), eeprom_before) << row.input;
    EXPECT_EQ(hal::fake::pulseUs(before.slot), pulse_before) << row.input;
  }
}

TEST_F(GatherStore, RangeThatNeedsMoreSamplesThanTheBufferIsRefusedWithTheStepThatFits) {
  // given: step 5 fits the default range exactly (161 samples)
  ASSERT_NE(run("step 5").find("161 steps"), std::string::npos);
  // when: a range of 1000 us at 5 us would be 201 samples
  const auto lines = responseLines(run("range 1000 2000"));
  // then
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0], "error: that range is 201 steps of 5 us, at most 161 fit: set a step of "
                      "at least 7 us first; nothing changed");
  EXPECT_EQ(app_->sweepSettings().pwm_max_us, 1800u);
  // and the suggested step does fit
  run("step 7");
  EXPECT_NE(run("range 1000 2000").find("range 1000..2000 us, 143 steps"), std::string::npos);
}

TEST_F(GatherStore, ErrorsInsideACommandLeaveTheLoadCellAlone) {
  // given: tared
  run("tare");
  const int32_t calibration_before = app_->loadCell().calibrationMilligrams();
  // when: a rejected calibration
  run("cal 0");
  // then
  EXPECT_EQ(app_->loadCell().calibrationMilligrams(), calibration_before);
  EXPECT_TRUE(app_->loadCell().isTared());
}

TEST_F(GatherStore, StoreTwoIntoAnUncalibratedSlotIsRefused) {
  // given: a good sweep but nothing stored yet
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  sweep();
  hal::fake::resetEepromWrites();
  // when
  const auto lines = responseLines(run("store 2"));
  // then
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0],
            "error: motor 0 has no first curve (erased (never calibrated)): store 1 first; "
            "nothing changed");
  EXPECT_EQ(hal::fake::eepromWrites(), 0u);
}

TEST_F(GatherStore, StoreTwoAtTheSameVoltageAsCurveOneIsRefused) {
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  sweep();
  run("store 1");
  sweep();  // same pack, same voltage
  const std::vector<uint8_t> before = eepromSnapshot();
  const auto lines = responseLines(run("store 2"));
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_TRUE(startsWith(lines[0], "error: this sweep started at 12.5")) << lines[0];
  EXPECT_NE(lines[0].find("sweep again at another battery voltage"), std::string::npos);
  EXPECT_EQ(eepromSnapshot(), before);
}

TEST_F(GatherStore, StoreIntoAnotherSlotThanTheSweptOneIsRefused) {
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  sweep();
  run("motor 3");
  const auto lines = responseLines(run("store 1"));
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0],
            "error: the last sweep was on motor 0 but motor 3 is selected: type motor 0 or "
            "sweep again; nothing changed");
  EXPECT_EQ(hal::fake::eepromWrites(), 0u);
}

TEST_F(GatherStore, StoreOverwritesOnlyTheChangedBytes) {
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  sweep();
  run("store 1");
  const uint32_t first_writes = hal::fake::eepromWrites();
  hal::fake::resetEepromWrites();
  run("store 1");  // the same sweep again
  EXPECT_GT(first_writes, 500u);
  EXPECT_EQ(hal::fake::eepromWrites(), 0u);
}

TEST_F(GatherStore, EmptyLinesOnlyRepeatThePrompt) {
  const std::string out = run("");
  EXPECT_EQ(out, "\r\ngs> ");
}

TEST_F(GatherStore, EepromCrcAndDumpAnswerAtThePromptAndHelpListsThem) {
  // given: a stored curve, so the slot differs from the erased ones
  calibrateAndTare();
  sweep();
  run("store 1");
  // when
  const auto crc = responseLines(run("eeprom crc"));
  const std::string dump = run("eeprom dump");
  // then
  ASSERT_EQ(crc.size(), 1u);
  EXPECT_EQ(crc[0].rfind("eeprom crc slot0 ", 0), 0u) << crc[0];
  EXPECT_NE(dump.find(":00000001FF\r\ngs> "), std::string::npos);
  EXPECT_EQ(countLinesStartingWith(dump, ":10"), 256);
  EXPECT_NE(run("help").find("eeprom crc|dump"), std::string::npos);
}

}  // namespace
