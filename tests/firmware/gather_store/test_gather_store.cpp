// gather_store console against the fake HAL and a simple plant (plant.hpp): the thesis
// workflow (cal, tare, sweep, store 1, store 2, show), the CSV stream and the settings; the
// aborts and the rejection of bad input are in test_gather_store_aborts.cpp.
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
// Start-up

TEST_F(GatherStore, StartArmsAllFourEscsAtOneThousandAndShowsThePrompt) {
  for (uint8_t ch = 0; ch < hal::kEscChannels; ++ch) EXPECT_EQ(hal::fake::pulseUs(ch), 1000u);
  EXPECT_NE(banner_.find("gather_store"), std::string::npos);
  EXPECT_NE(banner_.find("help"), std::string::npos);
  EXPECT_EQ(banner_.substr(banner_.size() - 4), "gs> ");
}

TEST_F(GatherStore, HelpListsEveryCommandWithItsArgumentsAndRanges) {
  const auto lines = responseLines(run("help"));
  for (const char* usage :
       {"help ", "motor N ", "plate G ", "weigh ", "tare ", "cal W ", "span W ", "range MIN MAX ",
        "step US ", "settle MS ", "settle auto ", "sweep ", "store 1 ", "store 2 ", "store v2 ",
        "show ", "erase ", "status ", "eeprom crc|dump ", "divider  ", "divider R1 R2 ",
        "strict on|off "}) {
    EXPECT_EQ(std::count_if(lines.begin(), lines.end(),
                            [&](const std::string& l) { return startsWith(l, usage); }),
              1)
        << usage;
  }
  // The ranges come from the table's argument specs (the ones the parser checks).
  const std::string out = run("help");
  for (const char* range : {"(N 0..3)", "(G 0..500)", "(W 1..950)", "(MIN 1000..1999, MAX 1001..2000)",
                            "(US 1..100)", "(MS 0..10000)", "at most 48 characters"}) {
    EXPECT_NE(out.find(range), std::string::npos) << range;
  }
}

// ------------------------------------------------------------------------------------------
// The thesis workflow

TEST_F(GatherStore, WeighReportsTheMotorWeightAfterCalibration) {
  // given: thesis phase 1 with the known motor + propeller weight
  run("cal 95");
  // when
  const std::string out = run("weigh");
  // then: the same counts read as the known weight, force 0 after the automatic zerolize
  EXPECT_NE(out.find("weight 95 g"), std::string::npos) << out;
  EXPECT_NE(out.find("force 0.0 g"), std::string::npos) << out;
}

TEST_F(GatherStore, SweepWithoutTareIsRefusedAndTheMotorStaysStopped) {
  const std::string out = run("sweep");
  const auto lines = responseLines(out);
  ASSERT_EQ(lines.size(), 1u) << out;
  EXPECT_TRUE(startsWith(lines[0], "error: a sweep needs a tare first")) << out;
  EXPECT_EQ(hal::fake::pulseUs(0), 1000u);
  EXPECT_FALSE(app_->lastSweep().valid);
}

TEST_F(GatherStore, SweepRightAfterStartWaitsForTheEscToArm) {
  // given: tared at once, well within the 2 s arming time
  run("tare");
  std::vector<std::pair<uint32_t, uint16_t>> first_pulse;  // first tick above 1000 us
  hal::fake::setTickHook([&](uint32_t now) {
    plant_.tick();
    if (first_pulse.empty() && hal::Esc::pulseUs(0) > 1000) first_pulse.push_back({now, 0});
  });
  // when
  const std::string out = sweep();
  // then
  EXPECT_NE(out.find("# arming the ESC"), std::string::npos);
  ASSERT_EQ(first_pulse.size(), 1u);
  EXPECT_GE(first_pulse[0].first, static_cast<uint32_t>(gs::kArmMs));
}

TEST_F(GatherStore, SweepStreamsAValidCsvWithCommentsOnly) {
  // given
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  // when
  const std::string out = sweep();
  // then: after the echoed command, every line is the header, a CSV row or a "# " comment
  std::vector<std::string> lines = responseLines(out);
  const tc::test::Pattern row(R"(^(\d+),(-?\d+\.\d),(\d+\.\d{3}),(\d+\.\d{3}),0,1$)");
  int headers = 0;
  std::vector<int> pwms;
  std::vector<double> times;
  for (const auto& line : lines) {
    tc::test::Groups m;
    if (line == "pwm_us,force_g,vbat_v,t_s,motor,dir") {
      ++headers;
      EXPECT_TRUE(pwms.empty()) << "header after data";
    } else if (row.matches(line, &m)) {
      pwms.push_back(std::stoi(m[1]));
      times.push_back(std::stod(m[4]));
    } else {
      EXPECT_TRUE(startsWith(line, "# ")) << "not CSV, not a comment: '" << line << "'";
    }
  }
  EXPECT_EQ(headers, 1);
  ASSERT_EQ(pwms.size(), 81u);  // 1000..1800 step 10
  for (size_t i = 0; i < pwms.size(); ++i) EXPECT_EQ(pwms[i], 1000 + 10 * static_cast<int>(i));
  // the default settles by measurement: at least three force medians kSettleProbeMs apart
  for (size_t i = 1; i < times.size(); ++i)
    EXPECT_GE(times[i] - times[i - 1], 3 * gs::kSettleProbeMs / 1000.0 - 1e-9);
  EXPECT_GE(countLinesStartingWith(out, "# "), 8);  // start, progress, summary
  EXPECT_NE(out.find("# done: 81 samples"), std::string::npos);
  EXPECT_NE(out.find("violations 0"), std::string::npos);
  EXPECT_EQ(hal::fake::pulseUs(0), 1000u);  // motor stopped at the end
}

TEST_F(GatherStore, SweepRowsFollowThePlant) {
  // given
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  // when
  const std::string out = sweep();
  // then: force within 1.5 g of the plant's steady state (0.75 g per count, the median
  // rejects the spikes), battery within 25 mV of what the plant's monitor reads (one count
  // is 15.3 mV; the thesis map() truncates, the pin voltage rounds)
  const tc::test::Pattern row(R"(^(\d+),(-?\d+\.\d),(\d+\.\d{3}),.*$)");
  int rows = 0;
  for (const auto& line : splitLines(out)) {
    tc::test::Groups m;
    if (!row.matches(line, &m)) continue;
    ++rows;
    const double pwm = std::stod(m[1]);
    const double thrust = plant_.steadyThrust(pwm);
    EXPECT_NEAR(std::stod(m[2]), thrust, 1.5) << line;
    const double vbat = plant_.vbat_v - plant_.sag_v_at_full * thrust / plant_.full_g;
    EXPECT_NEAR(std::stod(m[3]), vbat, 0.025) << line;
  }
  EXPECT_EQ(rows, 81);
}

TEST_F(GatherStore, WholeWorkflowStoresTwoCurvesThatDecodeAndMatchThePlant) {
  // given: motor 2, first sweep on a full pack
  hal::fake::advanceMs(gs::kArmMs);
  plant_.slot = 2;
  run("motor 2");
  calibrateAndTare();
  ASSERT_NE(sweep().find("# next: store 1"), std::string::npos);
  // when: store 1, then a second sweep at 11.1 V, store 2
  const std::string stored1 = run("store 1");
  tc::MotorCalibration after_first;
  ASSERT_EQ(tc::readRecord<FakeStorage>(2, after_first), tc::DecodeStatus::kOk);
  EXPECT_FALSE(after_first.hasSecondCurve());
  const gs_test::Plant full_pack = plant_;

  plant_.vbat_v = 11.1;
  hal::fake::advanceMs(2000);  // the propeller runs down while the user swaps the pack
  ASSERT_NE(run("tare").find("tared"), std::string::npos);
  ASSERT_NE(sweep().find("# done"), std::string::npos);
  const std::string stored2 = run("store 2");
  const std::string shown = run("show");

  // then
  EXPECT_TRUE(startsWith(responseLines(stored1)[0], "stored curve 1 of motor 2")) << stored1;
  EXPECT_TRUE(startsWith(responseLines(stored2)[0], "stored curve 2 of motor 2")) << stored2;
  tc::MotorCalibration cal;
  ASSERT_EQ(tc::readRecord<FakeStorage>(2, cal), tc::DecodeStatus::kOk);
  ASSERT_TRUE(cal.hasSecondCurve());
  // Start voltages: the first 40 us bin, motor not yet producing thrust: the open-circuit
  // voltage within two ADC counts (2 * 15.3 mV).
  EXPECT_NEAR(cal.first.start_mv, 12600, 31);
  EXPECT_NEAR(cal.second.start_mv, 11100, 31);
  // Curves: within 3 us of the plant's inverse from 10 g to 500 g (and to the second
  // curve's own maximum); measured worst 1.0 us (curve 1) and 1.5 us (curve 2), reported as
  // test properties. Error budget: half an ADC count (0.375 g) is up to 1.7 us where the
  // curve is steepest (10 g), linear interpolation between 10 us steps of a parabola < 1 us,
  // and the 200 ms settle leaves e^-6.7 of the 30 ms lag.
  EXPECT_EQ(cal.first.maxGrams(), 500u);
  double worst_us[2] = {0, 0};
  for (uint16_t g = 10; g <= 500; g += 5) {
    EXPECT_NEAR(cal.first.pwmForGrams(g), full_pack.pwmFor(g), 3.0) << g << " g, curve 1";
    worst_us[0] = std::max(worst_us[0], std::abs(cal.first.pwmForGrams(g) - full_pack.pwmFor(g)));
  }
  EXPECT_GE(cal.second.maxGrams(), 460u);  // 600 g * (11.1 / 12.6)^2 = 466 g at 1800 us
  for (uint16_t g = 10; g <= cal.second.maxGrams(); g += 5) {
    EXPECT_NEAR(cal.second.pwmForGrams(g), plant_.pwmFor(g), 3.0) << g << " g, curve 2";
    worst_us[1] = std::max(worst_us[1], std::abs(cal.second.pwmForGrams(g) - plant_.pwmFor(g)));
  }
  RecordProperty("curve1_worst_error_us", std::to_string(worst_us[0]));
  RecordProperty("curve2_worst_error_us", std::to_string(worst_us[1]));
  // Sag offsets: bin 0 is 0 and they grow with the PWM, as the plant's sag does.
  EXPECT_EQ(cal.sag.base_pwm_us, 1000u);
  EXPECT_EQ(cal.sag.offset_mv[0], 0);
  for (uint8_t i = 1; i < tc::kSagBins; ++i) EXPECT_GE(cal.sag.offset_mv[i], cal.sag.offset_mv[i - 1]);
  // Bin 12 holds 1480..1519 us only (samples beyond the table are left out): the mean plant
  // sag of the samples 1480, 1490, 1500, 1510 us is 0.5 V * mean(x^2) = 166 mV.
  EXPECT_NEAR(cal.sag.offset_mv[12], 166, 30);
  // show reports both curves
  EXPECT_NE(shown.find("calibrated, two curves"), std::string::npos) << shown;
  EXPECT_NE(shown.find("curve 1: start 12.5"), std::string::npos) << shown;
  EXPECT_NE(shown.find("curve 2: start 11.0"), std::string::npos) << shown;
  EXPECT_NE(shown.find("sag offsets"), std::string::npos) << shown;
  // other slots untouched
  for (uint8_t slot : {0, 1, 3}) {
    tc::MotorCalibration other;
    EXPECT_EQ(tc::readRecord<FakeStorage>(slot, other), tc::DecodeStatus::kErased) << int(slot);
  }
}

TEST_F(GatherStore, StoreOneAgainKeepsTheSecondCurve) {
  // given: both curves stored
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  sweep();
  run("store 1");
  plant_.vbat_v = 11.1;
  hal::fake::advanceMs(2000);  // the propeller runs down while the user swaps the pack
  run("tare");
  sweep();
  run("store 2");
  tc::MotorCalibration before;
  ASSERT_EQ(tc::readRecord<FakeStorage>(0, before), tc::DecodeStatus::kOk);
  // when: a new first curve on a fresh pack
  plant_.vbat_v = 12.4;
  hal::fake::advanceMs(2000);
  run("tare");
  sweep();
  const std::string out = run("store 1");
  // then
  EXPECT_NE(out.find("curve 2 kept"), std::string::npos) << out;
  tc::MotorCalibration after;
  ASSERT_EQ(tc::readRecord<FakeStorage>(0, after), tc::DecodeStatus::kOk);
  EXPECT_EQ(after.second.start_mv, before.second.start_mv);
  EXPECT_EQ(after.second.pwm_at_1g_us, before.second.pwm_at_1g_us);
  EXPECT_NEAR(after.first.start_mv, 12400, 31);
}

TEST_F(GatherStore, ShowOfAnErasedSlotSaysNotCalibrated) {
  const auto lines = responseLines(run("show"));
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0], "motor 0 (EEPROM 0..1023): not calibrated: erased (never calibrated)");
}

TEST_F(GatherStore, EraseMarksTheSlotNotCalibratedAndSaysSo) {
  // given
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  sweep();
  run("store 1");
  // when
  const auto lines = responseLines(run("erase"));
  // then
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_TRUE(startsWith(lines[0], "erased motor 0 (EEPROM 0..1023): not calibrated")) << lines[0];
  tc::MotorCalibration cal;
  EXPECT_EQ(tc::readRecord<FakeStorage>(0, cal), tc::DecodeStatus::kErased);
}

TEST_F(GatherStore, StatusShowsSettingsLiveReadingsAndTheLastSweep) {
  run("motor 1");
  run("step 20");
  const std::string out = run("status");
  EXPECT_NE(out.find("motor 1 (ESC D7"), std::string::npos) << out;
  EXPECT_NE(out.find("range 1000..1800 us, step 20 us, settle auto (cap 500 ms)"), std::string::npos) << out;
  EXPECT_NE(out.find("not tared"), std::string::npos) << out;
  EXPECT_NE(out.find("battery 12.5"), std::string::npos) << out;
  EXPECT_NE(out.find("last sweep: none kept"), std::string::npos) << out;
}

TEST_F(GatherStore, SettingsChangeTheSweep) {
  // given
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  run("range 1100 1700");
  run("step 20");
  run("settle 50");
  // when
  const uint32_t t0 = hal::fake::nowMs();
  const std::string out = sweep();
  const uint32_t took = hal::fake::nowMs() - t0;
  // then: 31 rows 1100..1700, about 31 * 50 ms of settling
  EXPECT_NE(out.find("\r\n1100,"), std::string::npos);
  EXPECT_NE(out.find("\r\n1700,"), std::string::npos);
  EXPECT_EQ(out.find("\r\n1720,"), std::string::npos);
  EXPECT_NE(out.find("# done: 31 samples"), std::string::npos) << out;
  EXPECT_GE(took, 31u * 50u);
  EXPECT_LT(took, 31u * 50u + 200u);
}

TEST_F(GatherStore, SettleAutoStepsOnOnceTheForceStopsChanging) {
  // given: the plant settles with a 30 ms time constant, far within a 200 ms cap
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  run("settle 200");
  const auto said = responseLines(run("settle auto"));
  ASSERT_EQ(said.size(), 1u);
  EXPECT_TRUE(startsWith(said[0], "settle auto: next step once 3 force medians 20 ms apart "
                                  "agree within 0 counts, at most 200 ms per step"))
      << said[0];
  EXPECT_NE(run("status").find("settle auto (cap 200 ms)"), std::string::npos);
  // when
  const uint32_t t0 = hal::fake::nowMs();
  const std::string out = sweep();
  const uint32_t took = hal::fake::nowMs() - t0;
  // then: every row still within 1.5 g of the plant's steady state, in well under 81 * 200 ms
  EXPECT_NE(out.find("# sweep motor 0: 1000..1800 us, step 10 us, settle auto (cap 200 ms)"),
            std::string::npos)
      << out;
  const tc::test::Pattern row(R"(^(\d+),(-?\d+\.\d),.*$)");
  int rows = 0;
  for (const auto& line : splitLines(out)) {
    tc::test::Groups m;
    if (!row.matches(line, &m)) continue;
    ++rows;
    EXPECT_NEAR(std::stod(m[2]), plant_.steadyThrust(std::stod(m[1])), 1.5) << line;
  }
  EXPECT_EQ(rows, 81);
  EXPECT_LT(took, 81u * 200u * 2u / 3u);
  RecordProperty("settle_auto_sweep_ms", std::to_string(took));
  // and settle MS turns it off again
  EXPECT_NE(run("settle 150").find("settle 150 ms per step"), std::string::npos);
  EXPECT_NE(run("status").find("settle 150 ms"), std::string::npos);
  EXPECT_FALSE(app_->sweepSettings().settle_auto);
}

TEST_F(GatherStore, DefaultSweepSettlesByMeasurementAndSettle200IsTheThesisTiming) {
  // given: a fresh console
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  // then: the default settles by measurement with a 500 ms cap
  EXPECT_TRUE(app_->sweepSettings().settle_auto);
  EXPECT_EQ(app_->sweepSettings().settle_ms, gs::kDefaultSettleCapMs);
  EXPECT_NE(run("status").find("settle auto (cap 500 ms)"), std::string::npos);
  // when: the thesis's fixed 200 ms
  EXPECT_NE(run("settle 200").find("settle 200 ms per step"), std::string::npos);
  run("range 1000 1100");
  const std::string out = sweep();
  // then: every step waits the 200 ms
  EXPECT_NE(out.find("# sweep motor 0: 1000..1100 us, step 10 us, settle 200 ms"), std::string::npos) << out;
  const tc::test::Pattern row(R"(^(\d+),(-?\d+\.\d),(\d+\.\d{3}),(\d+\.\d{3}),0,1$)");
  std::vector<double> times;
  for (const auto& line : splitLines(out)) {
    tc::test::Groups m;
    if (row.matches(line, &m)) times.push_back(std::stod(m[4]));
  }
  ASSERT_EQ(times.size(), 11u);
  for (size_t i = 1; i < times.size(); ++i) EXPECT_GE(times[i] - times[i - 1], 0.200 - 1e-9);
}

TEST_F(GatherStore, SettleAutoWaitsNoLongerThanTheCapWhenTheForceNeverSettles) {
  // given: an amplifier offset that jumps 3 counts every 20 ms (a vibrating bench)
  hal::fake::advanceMs(gs::kArmMs);
  calibrateAndTare();
  run("range 1000 1090");
  run("settle 100");
  run("settle auto");
  hal::fake::setTickHook([&](uint32_t now) {
    plant_.tick();
    plant_.base_counts = 100.0 + ((now / 20) % 2) * 3.0;
  });
  // when
  const uint32_t t0 = hal::fake::nowMs();
  const std::string out = sweep();
  const uint32_t took = hal::fake::nowMs() - t0;
  // then: 10 steps of the cap (100 ms, ending at the next 20 ms probe)
  EXPECT_NE(out.find("# done: 10 samples"), std::string::npos) << out;
  EXPECT_GE(took, 10u * 100u);
  EXPECT_LE(took, 10u * 120u + 50u);
}

TEST_F(GatherStore, SpanCalibratesTheGainFromAKnownWeight) {
  // given: an amplifier with 1.5 g per count instead of the thesis's 0.75
  plant_.g_per_count = 1.5;
  plant_.base_counts = 400.0;
  run("tare");
  plant_.extra_weight_g = 300.0;
  hal::fake::advanceMs(50);
  // when
  const std::string out = run("span 300");
  // then: 300 g lowered the reading by 200 counts
  EXPECT_NE(out.find("span: 1.500000 g per count"), std::string::npos) << out;
  EXPECT_EQ(app_->loadCell().config().slope_ug_per_count, 1500000);
  EXPECT_FALSE(app_->loadCell().isTared());  // "remove the weight, then tare"
}

TEST_F(GatherStore, SpanWithoutAWeightOnThePlateIsRefusedAndChangesNothing) {
  run("tare");
  const auto lines = responseLines(run("span 300"));
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_TRUE(startsWith(lines[0], "error: the reading moved from")) << lines[0];
  EXPECT_EQ(app_->loadCell().config().slope_ug_per_count, 750000);
  EXPECT_TRUE(app_->loadCell().isTared());
}

}  // namespace
