// gather_store's model v2 commands against the fake HAL and plant.hpp: store v2 fits the
// sweep on the "board" and writes the two-copy record, a second sweep at another voltage
// refines it, show / erase / store 1 handle both layouts, and every store reports the EEPROM
// bytes it physically wrote (the fake HAL counts them independently).
//
// Accuracy is judged the way read_run flies a model: tc::loadSlot decodes the slot, and
// tc::forceToPwmV2 at the monitor reading the plant shows at that force gives a PWM whose
// steady plant thrust is compared with the command. The plant's thrust follows its
// open-circuit voltage while v2 sees the sagged monitor reading, so away from the sweep's
// voltage a small model error remains by construction (0.5 V sag at 600 g: ~0.3 % of force).
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


TEST_F(GatherStoreV2, StoreV2AfterOneSweepWritesARecordThatFliesThePlant) {
  // given
  hal::fake::advanceMs(gs::kArmMs);
  sweepAt(12.6);
  // when
  const Response out = command("store v2");
  // then: one line of success, decoded by read_run's loader as a v2 slot
  ASSERT_GE(out.lines.size(), 1u);
  EXPECT_TRUE(startsWith(out.lines[0], "stored model v2 of motor 0 (EEPROM 0..1023, copy A, "
                                       "sequence 1): fitted from one sweep at 12.5"))
      << out.text();
  tc::ModelV2 model;
  const tc::SlotLoad slot = load(0, model);
  ASSERT_EQ(slot.layout, tc::SlotLayout::kModelV2);
  ASSERT_EQ(slot.status, tc::DecodeStatus::kOk);
  EXPECT_EQ(model.flags & tc::kV2Refined, 0);
  EXPECT_EQ(model.second_mv, 0u);
  EXPECT_NEAR(model.rest_mv, 12600, 40);
  EXPECT_NEAR(model.start_q4_us / 16.0, gs_test::Plant::kStartUs, 4.0);
  EXPECT_GE(model.maxForceDg(), 5800u);  // the plant reaches 600 g at 1800 us
  const double worst = worstForceErrorPct(model, gramsUpTo(550));
  EXPECT_LE(worst, kOneSweepTolerancePct);
  RecordProperty("one_sweep_worst_force_error_pct", std::to_string(worst));
  // write count: what the fake HAL counted, at most one record copy
  EXPECT_EQ(wroteBytes(out), static_cast<int>(out.physical_writes)) << out.text();
  EXPECT_GT(out.physical_writes, 60u);
  EXPECT_LE(out.physical_writes, tc::kRecordV2Bytes);
  RecordProperty("first_store_v2_bytes", std::to_string(out.physical_writes));
}

TEST_F(GatherStoreV2, StoreV2AfterASweepAtAnotherVoltageRefinesTheStoredModel) {
  // given: the thesis workflow, v2 style: LiPo sweep, store v2, sweep at 11.1 V
  hal::fake::advanceMs(gs::kArmMs);
  sweepAt(12.6);
  command("store v2");
  tc::ModelV2 first;
  ASSERT_EQ(load(0, first).status, tc::DecodeStatus::kOk);
  sweepAt(11.1);
  // when
  const Response out = command("store v2");
  // then: the other copy holds the refined model, sequence 2
  ASSERT_GE(out.lines.size(), 1u);
  EXPECT_TRUE(startsWith(out.lines[0], "stored model v2 of motor 0 (EEPROM 0..1023, copy B, "
                                       "sequence 2): refined with this sweep at 11.0"))
      << out.text();
  EXPECT_NE(out.lines[0].find("(first sweep 12.5"), std::string::npos) << out.text();
  tc::ModelV2 refined;
  const tc::SlotLoad slot = load(0, refined);
  ASSERT_EQ(slot.status, tc::DecodeStatus::kOk);
  EXPECT_EQ(slot.v2.copy, 1);
  EXPECT_EQ(slot.v2.sequence, 2u);
  EXPECT_EQ(slot.v2.copy_status[0], tc::DecodeStatus::kOk);  // the old model stays as spare
  EXPECT_NE(refined.flags & tc::kV2Refined, 0);
  EXPECT_NEAR(refined.second_mv, 11100, 40);
  EXPECT_EQ(refined.rest_mv, first.rest_mv);
  // The direct start estimate (pA - s) VA = (pB - s) VB uses the monitor readings; this plant's
  // thrust follows its open-circuit voltage, d = 0.25 V lower at 300 g in both sweeps, which
  // moves s by about d * (pB - pA) / (VA - VB) = 0.25 * 45 / 1.5 = 7.5 us. The force error
  // below is what matters.
  EXPECT_NEAR(refined.start_q4_us / 16.0, gs_test::Plant::kStartUs, 10.0);
  // flies the plant at both sweep voltages and between and below them
  double worst = 0;
  for (double v : {12.6, 11.8, 11.1, 10.2}) {
    plant_.vbat_v = v;
    const double top = std::min(450.0, 0.9 * plant_.steadyThrust(1800));
    worst = std::max(worst, worstForceErrorPct(refined, gramsUpTo(top)));
  }
  EXPECT_LE(worst, kOneSweepTolerancePct);
  RecordProperty("refined_worst_force_error_pct", std::to_string(worst));
  EXPECT_EQ(wroteBytes(out), static_cast<int>(out.physical_writes));
  EXPECT_LE(out.physical_writes, tc::kRecordV2Bytes);
}

TEST_F(GatherStoreV2, ReStoringTheSameModelWritesNothing) {
  // given
  hal::fake::advanceMs(gs::kArmMs);
  sweepAt(12.6);
  command("store v2");
  const std::vector<uint8_t> before = eepromSnapshot();
  // when
  const Response again = command("store v2");
  // then
  ASSERT_EQ(again.lines.size(), 1u) << again.text();
  EXPECT_EQ(again.lines[0],
            "motor 0 already holds this model v2 (copy A, sequence 1): nothing to write; "
            "wrote 0 bytes");
  EXPECT_EQ(again.physical_writes, 0u);
  EXPECT_EQ(eepromSnapshot(), before);
}

TEST_F(GatherStoreV2, AFreshSweepAtTheFirstVoltageReplacesTheModelInTheOtherCopy) {
  // given: a stored model, then the plant's motor changes (a new propeller: 10 % more thrust)
  hal::fake::advanceMs(gs::kArmMs);
  sweepAt(12.6);
  command("store v2");
  plant_.full_g = 660.0;
  sweepAt(12.6);
  // when
  const Response out = command("store v2");
  // then: a new single-sweep model, written into copy B; copy A (the old model) untouched
  ASSERT_GE(out.lines.size(), 1u);
  EXPECT_TRUE(startsWith(out.lines[0], "stored model v2 of motor 0 (EEPROM 0..1023, copy B, "
                                       "sequence 2): fitted from one sweep at 12.5"))
      << out.text();
  EXPECT_NE(out.lines[0].find("; replaced the model of a sweep at 12.5"), std::string::npos);
  tc::ModelV2 model;
  ASSERT_EQ(load(0, model).status, tc::DecodeStatus::kOk);
  EXPECT_EQ(model.flags & tc::kV2Refined, 0);
  EXPECT_LE(worstForceErrorPct(model, gramsUpTo(600)), kOneSweepTolerancePct);
}

TEST_F(GatherStoreV2, ASecondRefineWithASweepAtTheSameVoltageIsRefusedAndWritesNothing) {
  // given: refined with an 11.1 V sweep
  hal::fake::advanceMs(gs::kArmMs);
  sweepAt(12.6);
  command("store v2");
  sweepAt(11.1);
  command("store v2");
  const std::vector<uint8_t> before = eepromSnapshot();
  // when: store v2 of the same sweep again (it would count that sweep twice)
  const Response out = command("store v2");
  // then
  ASSERT_EQ(out.lines.size(), 1u) << out.text();
  EXPECT_TRUE(startsWith(out.lines[0], "error: motor 0 already holds a model v2 refined by a "
                                       "sweep at 11.0"))
      << out.lines[0];
  EXPECT_NE(out.lines[0].find("erase and store v2 to start over; nothing changed"),
            std::string::npos);
  EXPECT_EQ(out.physical_writes, 0u);
  EXPECT_EQ(eepromSnapshot(), before);
}

TEST_F(GatherStoreV2, ShowDescribesAV2SlotAndItsPwmsMatchTheModel) {
  // given
  hal::fake::advanceMs(gs::kArmMs);
  sweepAt(12.6);
  command("store v2");
  // when
  const Response out = command("show");
  // then (the last line: dynamics, not measured)
  ASSERT_EQ(out.lines.size(), 4u) << out.text();
  EXPECT_EQ(out.lines[3], "dynamics: not measured (dyn measures them)");
  EXPECT_EQ(out.lines[0],
            "motor 0 (EEPROM 0..1023): calibrated, model v2 (copy A, sequence 1; other copy "
            "erased (never calibrated))");
  EXPECT_TRUE(startsWith(out.lines[1], "model v2: start 10")) << out.lines[1];
  EXPECT_NE(out.lines[1].find("single sweep"), std::string::npos) << out.lines[1];
  EXPECT_EQ(out.physical_writes, 0u);
  // "PWM from rest at 12.5xx V (bench sag predicted): 10 g P us, 100 g P us, ...": each
  // within 2 us of the plant's inverse (4 us at 10 g, where one us is 2 % of force)
  tc::ModelV2 model;
  ASSERT_EQ(load(0, model).status, tc::DecodeStatus::kOk);
  const tc::test::Pattern pair(R"((\d+) g (\d+) us)");
  int pairs = 0;
  for (const tc::test::Groups& m : pair.allIn(out.lines[2])) {
    ++pairs;
    const double grams = std::stod(m[1]);
    const double pwm = std::stod(m[2]);
    plant_.vbat_v = model.rest_mv / 1000.0;
    EXPECT_NEAR(pwm, plant_.pwmFor(grams), grams < 50 ? 4.0 : 2.0) << grams << " g";
  }
  EXPECT_GE(pairs, 6);  // 10, 100, ..., 500 g
}

TEST_F(GatherStoreV2, EraseMakesARefinedV2SlotNotCalibratedWithTwoWrites) {
  // given: both copies valid
  hal::fake::advanceMs(gs::kArmMs);
  sweepAt(12.6);
  command("store v2");
  sweepAt(11.1);
  command("store v2");
  // when
  const Response out = command("erase");
  // then: the two version bytes (copy B, copy A = the thesis record's) and nothing else
  ASSERT_EQ(out.lines.size(), 1u);
  EXPECT_TRUE(startsWith(out.lines[0], "erased motor 0 (EEPROM 0..1023): not calibrated now"))
      << out.lines[0];
  EXPECT_EQ(out.physical_writes, 2u);
  EXPECT_EQ(wroteBytes(out), 2);
  tc::ModelV2 model;
  const tc::SlotLoad slot = load(0, model);
  EXPECT_NE(slot.status, tc::DecodeStatus::kOk);
  EXPECT_EQ(slot.layout, tc::SlotLayout::kNone);
  const auto shown = command("show");
  EXPECT_EQ(shown.lines[0], "motor 0 (EEPROM 0..1023): not calibrated: erased (never calibrated)");
  // and erasing again writes nothing
  EXPECT_EQ(command("erase").physical_writes, 0u);
}

TEST_F(GatherStoreV2, StoreOneOntoAV2SlotReplacesItWithTheThesisRecordAndSaysSo) {
  // given
  hal::fake::advanceMs(gs::kArmMs);
  sweepAt(12.6);
  command("store v2");
  // when
  const Response out = command("store 1");
  // then: stored, and model v2 stayed loadable (a copy in slot 1) until the record was whole
  ASSERT_EQ(out.lines.size(), 2u);
  EXPECT_TRUE(startsWith(out.lines[0], "stored curve 1 of motor 0")) << out.lines[0];
  EXPECT_NE(out.lines[0].find("replaced model v2"), std::string::npos) << out.lines[0];
  EXPECT_EQ(out.lines[1], "# power-fail safe: the old calibration stayed loadable (a copy in motor 1's "
                          "slot) until the new one was complete");
  EXPECT_EQ(wroteBytes(out), static_cast<int>(out.physical_writes));
  tc::ModelV2 model;
  const tc::SlotLoad slot = load(0, model);
  EXPECT_EQ(slot.layout, tc::SlotLayout::kThesisV1);
  EXPECT_EQ(slot.status, tc::DecodeStatus::kOk);
}

TEST_F(GatherStoreV2, StoreTwoOntoAV2SlotIsRefusedWithWhatToDo) {
  hal::fake::advanceMs(gs::kArmMs);
  sweepAt(12.6);
  command("store v2");
  sweepAt(11.1);
  const std::vector<uint8_t> before = eepromSnapshot();
  const Response out = command("store 2");
  ASSERT_EQ(out.lines.size(), 1u);
  EXPECT_EQ(out.lines[0],
            "error: motor 0 holds model v2, not a thesis curve 1: store 1 first (it replaces "
            "model v2), or store v2; nothing changed");
  EXPECT_EQ(eepromSnapshot(), before);
}

TEST_F(GatherStoreV2, StoreV2OntoAThesisRecordReplacesIt) {
  hal::fake::advanceMs(gs::kArmMs);
  sweepAt(12.6);
  command("store 1");
  const Response out = command("store v2");
  ASSERT_GE(out.lines.size(), 1u);
  EXPECT_TRUE(startsWith(out.lines[0], "stored model v2 of motor 0 (EEPROM 0..1023, copy A, "
                                       "sequence 1)"))
      << out.text();
  EXPECT_NE(out.lines[0].find("; replaced the thesis record"), std::string::npos);
  tc::ModelV2 model;
  const tc::SlotLoad slot = load(0, model);
  EXPECT_EQ(slot.layout, tc::SlotLayout::kModelV2);
  EXPECT_EQ(slot.status, tc::DecodeStatus::kOk);
}

TEST_F(GatherStoreV2, ThesisStoresReportTheBytesTheyWrote) {
  hal::fake::advanceMs(gs::kArmMs);
  sweepAt(12.6);
  const Response first = command("store 1");
  EXPECT_EQ(wroteBytes(first), static_cast<int>(first.physical_writes));
  EXPECT_GT(first.physical_writes, 500u);
  const Response again = command("store 1");
  EXPECT_EQ(wroteBytes(again), 0);
  EXPECT_EQ(again.physical_writes, 0u);
}

TEST_F(GatherStoreV2, ASweepWithMoreStepsThanTheV2BufferIsRefusedByStoreV2Only) {
  // given: 161 steps (5 us over 1000..1800): the thesis buffer takes them, v2 keeps 128
  hal::fake::advanceMs(gs::kArmMs);
  run("cal 95");
  run("step 5");
  run("settle 20");
  const std::string swept = sweep();
  ASSERT_NE(swept.find("# done: 161 samples"), std::string::npos);
  EXPECT_NE(swept.find("# note: model v2 keeps at most 128 steps: store v2 will refuse this "
                       "sweep"),
            std::string::npos);
  const std::vector<uint8_t> before = eepromSnapshot();
  // when
  const Response out = command("store v2");
  // then: one clear error with the step that fits (800 us / 7 us + 1 = 115 steps)
  ASSERT_EQ(out.lines.size(), 1u);
  EXPECT_EQ(out.lines[0],
            "error: the last sweep has 161 steps, model v2 keeps at most 128 (SRAM): set a step "
            "of at least 7 us for this range and sweep again; nothing changed");
  EXPECT_EQ(eepromSnapshot(), before);
  // the thesis store still takes it
  EXPECT_TRUE(startsWith(command("store 1").lines[0], "stored curve 1 of motor 0"));
}

TEST_F(GatherStoreV2, ASweepOfExactlyTheV2CapacityIsStored) {
  // 1000..1635 us at 5 us: 128 steps, the most v2 keeps (the fit needs the start low enough)
  hal::fake::advanceMs(gs::kArmMs);
  run("cal 95");
  run("step 5");
  ASSERT_NE(run("range 1000 1635").find("128 steps"), std::string::npos);
  run("settle 20");
  ASSERT_NE(sweep().find("# done: 128 samples"), std::string::npos);
  const Response out = command("store v2");
  ASSERT_GE(out.lines.size(), 1u);
  EXPECT_TRUE(startsWith(out.lines[0], "stored model v2 of motor 0")) << out.text();
}

TEST_F(GatherStoreV2, StoreV2WithoutAForceIsRefusedWithTheReason) {
  // given: the motor never spins (ESC on another output than the plant listens to)
  plant_.slot = 3;
  hal::fake::advanceMs(gs::kArmMs);
  run("cal 95");
  sweep();
  const std::vector<uint8_t> before = eepromSnapshot();
  // when
  const Response out = command("store v2");
  // then
  ASSERT_EQ(out.lines.size(), 1u);
  EXPECT_EQ(out.lines[0],
            "error: model v2 cannot use the last sweep: the force never reached 5 g: motor "
            "not spinning or cell not tared?; nothing changed");
  EXPECT_EQ(eepromSnapshot(), before);
}

TEST_F(GatherStoreV2, StoreV2AfterAnAbortedSweepIsRefused) {
  hal::fake::advanceMs(gs::kArmMs);
  run("cal 95");
  hal::fake::feedInputAt(hal::fake::nowMs() + 4000, "x\r");
  sweep();
  const Response out = command("store v2");
  ASSERT_EQ(out.lines.size(), 1u);
  EXPECT_EQ(out.lines[0], "error: nothing to store: run a complete sweep first");
  EXPECT_EQ(out.physical_writes, 0u);
}

}  // namespace
