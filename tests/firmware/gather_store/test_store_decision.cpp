// The store decision of gather_store (firmware/gather_store/store_decision.hpp) without a
// console or an EEPROM: which sweep may be stored, what store 1 / store 2 put into the record,
// and model v2's fit-or-refine rule with its refusals, at the edges of each rule.
#include <gtest/gtest.h>

#include "gather_store_app.hpp"
#include "store_decision.hpp"
#include "thrustcal/limits.hpp"

namespace {

using gs::StoreRefusal;
using gs::V2Action;

constexpr uint16_t kMinSpanMv = 1000;  // store 2's start-voltage span in these tests

// A complete sweep on slot 1 with a thesis curve starting at `start_mv`.
gs::SweepResult sweepAt(uint16_t start_mv) {
  gs::SweepResult sweep;
  sweep.complete = true;
  sweep.valid = true;
  sweep.slot = 1;
  sweep.samples = 81;
  sweep.curve.start_mv = start_mv;
  sweep.sag.base_pwm_us = 1040;
  sweep.sag.offset_mv[3] = 120;
  return sweep;
}

// A slot record holding curve 1 at `first_mv` (and curve 2 at `second_mv` unless 0).
tc::MotorCalibration recordWith(uint16_t first_mv, uint16_t second_mv) {
  tc::MotorCalibration record;
  record.clear();
  record.first.start_mv = first_mv;
  record.sag.base_pwm_us = 1000;
  record.second.start_mv = second_mv;
  return record;
}

TEST(StoreDecision, OnlyACompleteSweepOnTheSelectedSlotMayBeStored) {
  gs::SweepResult sweep = sweepAt(12000);
  EXPECT_EQ(gs::checkStoreSource(sweep, 1), StoreRefusal::kNone);
  EXPECT_EQ(gs::checkStoreSource(sweep, 0), StoreRefusal::kOtherSlot);
  sweep.complete = false;  // aborted
  EXPECT_EQ(gs::checkStoreSource(sweep, 1), StoreRefusal::kNoSweep);
  EXPECT_EQ(gs::checkStoreSource(gs::SweepResult(), 0), StoreRefusal::kNoSweep);
}

TEST(StoreDecision, StoreOneTakesCurveAndSagOffsetsAndKeepsASecondCurve) {
  const gs::SweepResult sweep = sweepAt(12400);
  // given: a slot with both curves
  tc::MotorCalibration record = recordWith(11000, 9000);
  EXPECT_EQ(gs::planStoreV1(1, sweep, false, tc::DecodeStatus::kOk, kMinSpanMv, record),
            StoreRefusal::kNone);
  EXPECT_EQ(record.first.start_mv, 12400);
  EXPECT_EQ(record.sag.base_pwm_us, 1040);
  EXPECT_EQ(record.sag.offset_mv[3], 120);
  EXPECT_EQ(record.second.start_mv, 9000);  // kept
}

TEST(StoreDecision, StoreOneOntoAnUnreadableSlotStartsAFreshRecord) {
  const gs::SweepResult sweep = sweepAt(12400);
  // given: whatever readRecord left in the buffer of a bad slot, or a v2 slot
  tc::MotorCalibration record = recordWith(11000, 9000);
  EXPECT_EQ(gs::planStoreV1(1, sweep, true, tc::DecodeStatus::kBadCrc, kMinSpanMv, record),
            StoreRefusal::kNone);
  EXPECT_EQ(record.first.start_mv, 12400);
  EXPECT_FALSE(record.hasSecondCurve());
}

struct StoreTwoRow {
  const char* what;
  bool slot_holds_v2;
  tc::DecodeStatus before;
  uint16_t curve1_mv;
  uint16_t sweep_mv;
  StoreRefusal expected;
};

TEST(StoreDecision, StoreTwoNeedsCurveOneAndAnotherBatteryVoltage) {
  const StoreTwoRow rows[] = {
      {"slot holds model v2", true, tc::DecodeStatus::kOk, 12400, 10000, StoreRefusal::kSlotHoldsV2},
      {"slot erased", false, tc::DecodeStatus::kErased, 0, 10000, StoreRefusal::kNoFirstCurve},
      {"slot damaged", false, tc::DecodeStatus::kBadCrc, 12400, 10000, StoreRefusal::kNoFirstCurve},
      {"same voltage", false, tc::DecodeStatus::kOk, 12400, 12400, StoreRefusal::kVoltagesTooClose},
      {"1 mV short of the span, below", false, tc::DecodeStatus::kOk, 12400, 11401,
       StoreRefusal::kVoltagesTooClose},
      {"1 mV short of the span, above", false, tc::DecodeStatus::kOk, 12400, 13399,
       StoreRefusal::kVoltagesTooClose},
      {"exactly the span below", false, tc::DecodeStatus::kOk, 12400, 11400, StoreRefusal::kNone},
      {"exactly the span above", false, tc::DecodeStatus::kOk, 12400, 13400, StoreRefusal::kNone},
  };
  for (const StoreTwoRow& row : rows) {
    tc::MotorCalibration record = recordWith(row.curve1_mv, 0);
    const tc::MotorCalibration slot_before = record;
    const StoreRefusal got = gs::planStoreV1(2, sweepAt(row.sweep_mv), row.slot_holds_v2,
                                             row.before, kMinSpanMv, record);
    EXPECT_EQ(got, row.expected) << row.what;
    EXPECT_EQ(record.first.start_mv, slot_before.first.start_mv) << row.what;  // curve 1 kept
    EXPECT_EQ(record.second.start_mv, got == StoreRefusal::kNone ? row.sweep_mv : 0) << row.what;
  }
}

TEST(StoreDecision, ASweepWithoutAThesisCurveStoresNeitherCurve) {
  gs::SweepResult sweep = sweepAt(12400);
  sweep.valid = false;  // complete, but the curve builder refused it
  for (uint8_t which : {1, 2}) {
    tc::MotorCalibration record = recordWith(11000, 0);
    EXPECT_EQ(gs::planStoreV1(which, sweep, false, tc::DecodeStatus::kOk, kMinSpanMv, record),
              StoreRefusal::kNoThesisCurve);
    EXPECT_EQ(record.first.start_mv, 11000);
  }
}

struct V2Row {
  const char* what;
  bool has_v2;
  bool refined;
  uint16_t rest_mv;    // the slot model's first sweep
  uint16_t second_mv;  // its refining sweep (0: none)
  uint16_t sweep_mv;   // this sweep's resting voltage
  V2Action expected;
};

TEST(StoreDecision, StoreV2FitsRefinesOrRefusesByTheVoltageGap) {
  constexpr uint16_t gap = tc::kV2MinVoltageGapMv;
  const V2Row rows[] = {
      {"empty slot", false, false, 0, 0, 12400, V2Action::kFit},
      {"v2 from the same voltage: replaced", true, false, 12400, 0, 12400, V2Action::kFit},
      {"v2 just inside the gap: replaced", true, false, 12400, 0, 12400 - gap + 1, V2Action::kFit},
      {"v2 exactly the gap away: refined", true, false, 12400, 0, 12400 - gap, V2Action::kRefine},
      {"v2 from a higher voltage: refined", true, false, 12400, 0, 10500, V2Action::kRefine},
      {"v2 from a lower voltage: refined", true, false, 10500, 0, 12400, V2Action::kRefine},
      {"refined, this sweep near its second: refused", true, true, 12400, 10500, 10600,
       V2Action::kRefuse},
      {"refined, this sweep near its first: replaced", true, true, 12400, 10500, 12300,
       V2Action::kFit},
      {"refined, this sweep at a third voltage: refined again", true, true, 12400, 10500, 11400,
       V2Action::kRefine},
      {"no valid v2 (garbage in the buffer) is never refused", false, true, 12400, 10500, 10500,
       V2Action::kFit},
  };
  for (const V2Row& row : rows) {
    gs::SlotContents slot;
    slot.has_v2 = row.has_v2;
    slot.refined = row.refined;
    slot.rest_mv = row.rest_mv;
    slot.second_mv = row.second_mv;
    EXPECT_EQ(gs::decideV2(slot, row.sweep_mv, gap), row.expected) << row.what;
  }
}

TEST(StoreDecision, OnlyProblemsOfTheSweepItselfRuleModelV2Out) {
  EXPECT_TRUE(gs::fitRulesOutSweep(tc::FitV2Status::kTooFewSamples));
  EXPECT_TRUE(gs::fitRulesOutSweep(tc::FitV2Status::kNoForce));
  EXPECT_TRUE(gs::fitRulesOutSweep(tc::FitV2Status::kBadVoltage));
  EXPECT_FALSE(gs::fitRulesOutSweep(tc::FitV2Status::kOk));
  EXPECT_FALSE(gs::fitRulesOutSweep(tc::FitV2Status::kStartNotFound));
  EXPECT_FALSE(gs::fitRulesOutSweep(tc::FitV2Status::kVoltagesTooClose));
  EXPECT_FALSE(gs::fitRulesOutSweep(tc::FitV2Status::kNoModel));
}

TEST(StoreDecision, TheSmallestStepThatFitsRoundsUp) {
  EXPECT_EQ(gs::smallestStepUs(800, gs::kMaxSweepSamples), 5);  // 161 samples: 800 / 160
  EXPECT_EQ(gs::smallestStepUs(1000, gs::kMaxSweepSamples), 7);  // 6.25 -> 7
  EXPECT_EQ(gs::smallestStepUs(800, gs::kMaxV2Samples), 7);     // 6.3 -> 7
  EXPECT_EQ(gs::smallestStepUs(127, gs::kMaxV2Samples), 1);
  EXPECT_EQ(gs::smallestStepUs(128, gs::kMaxV2Samples), 2);
}

}  // namespace
