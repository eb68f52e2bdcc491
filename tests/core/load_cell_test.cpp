#include <gtest/gtest.h>

#include "thrustcal/load_cell.hpp"

namespace {

using tc::LoadCell;
using tc::LoadCellConfig;
using tc::LoadCellStatus;

TEST(LoadCell, LineFollowsThesisEquation075CountsMinus156) {
  struct Row {
    uint16_t counts;
    int32_t line_mg;
  };
  const Row rows[] = {{0, -156000}, {1, -155250}, {208, 0}, {400, 144000}, {1023, 611250}};
  const LoadCell cell;
  for (const auto& r : rows) EXPECT_EQ(cell.lineMilligrams(r.counts), r.line_mg) << r.counts;
}

TEST(LoadCell, WeightIsNegativeLineMinusThePlate) {
  struct Row {
    uint16_t counts;
    int16_t weight_g;
  };
  // weight = -(0.75 c - 156) - 60
  const Row rows[] = {{0, 96}, {100, 21}, {128, 0}, {130, -2}, {400, -204}};
  const LoadCell cell;
  for (const auto& r : rows) EXPECT_EQ(cell.weightGrams(r.counts), r.weight_g) << r.counts;
}

TEST(LoadCell, PlateWeightIsConfigurable) {
  LoadCell cell;
  cell.setPlateGrams(0);
  EXPECT_EQ(cell.weightGrams(100), 81);
  EXPECT_EQ(cell.config().plate_g, 0);
}

TEST(LoadCell, CalibrateWeightMakesTheCurrentReadingTheKnownWeight) {
  // given the motor (150 g) resting on the plate reads 100 counts
  LoadCell cell;
  // when
  ASSERT_TRUE(cell.calibrateWeight(100, 150));
  // then
  EXPECT_EQ(cell.weightGrams(100), 150);
  EXPECT_EQ(cell.calibrationMilligrams(), 150000 + 60000 - 81000);  // thesis CALIBRATION_VALUE
  // and the slope is unchanged: 10 counts less is 7.5 g more (rounded half away from zero)
  EXPECT_EQ(cell.weightGrams(90), 158);
}

TEST(LoadCell, RecalibratingReplacesThePreviousCalibration) {
  LoadCell cell;
  ASSERT_TRUE(cell.calibrateWeight(100, 150));
  ASSERT_TRUE(cell.calibrateWeight(300, 40));
  EXPECT_EQ(cell.weightGrams(300), 40);
}

TEST(LoadCell, CalibrateWeightRejectsWeightsOutsideOneToOverload) {
  const int16_t bad_weights[] = {0, -5, 951, 32767};
  for (int16_t w : bad_weights) {
    // given
    LoadCell cell;
    // when
    const bool ok = cell.calibrateWeight(100, w);
    // then nothing changed
    EXPECT_FALSE(ok) << w;
    EXPECT_EQ(cell.calibrationMilligrams(), 0) << w;
    EXPECT_EQ(cell.weightGrams(100), 21) << w;
  }
}

TEST(LoadCell, TareZeroesTheForceAndThrustReadsPositive) {
  // given
  LoadCell cell;
  ASSERT_FALSE(cell.isTared());
  // when
  cell.tare(300);
  // then
  EXPECT_TRUE(cell.isTared());
  EXPECT_EQ(cell.forceMilligrams(300), 0);
  EXPECT_EQ(cell.forceGrams(300), 0);
  EXPECT_EQ(cell.forceMilligrams(310), 7500);  // thrust lifts the plate: reading rises
  EXPECT_EQ(cell.forceGrams(310), 8);
  EXPECT_EQ(cell.forceGrams(290), -8);
  EXPECT_EQ(cell.forceGrams(301), 1);  // 0.75 g rounds to 1 g
}

TEST(LoadCell, QuarterCountReadingsSitBetweenTheWholeCounts) {
  // given: a cell tared at a whole count and one tared a quarter count higher
  LoadCell whole;
  LoadCell quarter;
  whole.tare(300);
  quarter.tareQ4(300 * 16 + 4);
  // then: whole-count readings in 1/16 are the whole-count figures
  for (uint16_t c : {300, 301, 310, 600})
    EXPECT_EQ(whole.forceMilligramsQ4(static_cast<uint16_t>(c * 16)), whole.forceMilligrams(c)) << c;
  // and: a quarter count is 187.5 mg of the thesis's 0.75 g per count (rounded)
  EXPECT_EQ(whole.forceMilligramsQ4(300 * 16 + 4), 188);
  EXPECT_EQ(quarter.forceMilligramsQ4(300 * 16 + 4), 0);
  EXPECT_EQ(quarter.forceMilligrams(310), 7500 - 188);
  // and: on a spanned slope too
  LoadCell spanned;
  ASSERT_TRUE(spanned.calibrateSpan(400, 300, 100));  // 1 g per count
  spanned.tareQ4(300 * 16);
  EXPECT_EQ(spanned.forceMilligramsQ4(300 * 16 + 8), 500);
  EXPECT_EQ(spanned.forceMilligramsQ4(310 * 16), spanned.forceMilligrams(310));
}

TEST(LoadCell, ForceAfterTareDoesNotDependOnTheCalibrationShift) {
  // given two cells, one calibrated
  LoadCell plain;
  LoadCell calibrated;
  ASSERT_TRUE(calibrated.calibrateWeight(250, 120));
  // when both are tared at the same reading
  plain.tare(250);
  calibrated.tare(250);
  // then they measure the same force
  for (uint16_t c : {250, 260, 500, 1000}) EXPECT_EQ(plain.forceMilligrams(c), calibrated.forceMilligrams(c)) << c;
}

TEST(LoadCell, CalibrateSpanScalesTheSlopeAroundTheEmptyReading) {
  // given an empty plate at 500 counts and 200 g more at 300 counts: 1 g/count
  LoadCell cell;
  const int16_t empty_weight = cell.weightGrams(500);
  cell.tare(500);
  // when
  ASSERT_TRUE(cell.calibrateSpan(500, 300, 200));
  // then
  EXPECT_EQ(cell.config().slope_ug_per_count, 1000000);
  EXPECT_EQ(cell.weightGrams(500), empty_weight);
  EXPECT_EQ(cell.weightGrams(300), empty_weight + 200);
  EXPECT_FALSE(cell.isTared()) << "the old tare point no longer reads zero: tare again";
  EXPECT_EQ(cell.forceMilligrams(500), cell.lineMilligrams(500)) << "untared force is the plain line";
  cell.tare(500);
  EXPECT_EQ(cell.forceGrams(550), 50);
}

TEST(LoadCell, CalibrateSpanRejectsTooSmallWrongWayOrImplausibleChanges) {
  struct Row {
    uint16_t empty, loaded;
    int16_t known_g;
    const char* why;
  };
  const Row rows[] = {
      {500, 491, 10, "9 counts is under the 10-count minimum"},
      {500, 500, 10, "no change"},
      {300, 500, 200, "reading rose under a weight: wrong direction"},
      {500, 100, 50, "0.125 g/count is below 0.25"},
      {500, 480, 100, "5 g/count is above 3"},
      {500, 300, 0, "no known weight"},
      {500, 300, -200, "negative weight"},
  };
  for (const auto& r : rows) {
    // given
    LoadCell cell;
    cell.tare(400);
    // when
    const bool ok = cell.calibrateSpan(r.empty, r.loaded, r.known_g);
    // then nothing changed
    EXPECT_FALSE(ok) << r.why;
    EXPECT_EQ(cell.config().slope_ug_per_count, 750000) << r.why;
    EXPECT_EQ(cell.config().offset_mg, -156000) << r.why;
    EXPECT_TRUE(cell.isTared()) << r.why;
  }
}

TEST(LoadCell, SpanLimitsAreInclusiveAndSteepSlopesDoNotOverflow) {
  LoadCell steep;
  ASSERT_TRUE(steep.calibrateSpan(500, 400, 300));  // exactly 3 g/count
  EXPECT_EQ(steep.config().slope_ug_per_count, 3000000);
  // 3 g/count * 1023 counts = 3.07e9 ug would overflow a plain int32 product
  EXPECT_EQ(steep.lineMilligrams(1023) - steep.lineMilligrams(0), 3069000);
  LoadCell flat;
  ASSERT_TRUE(flat.calibrateSpan(500, 100, 100));  // exactly 0.25 g/count
  EXPECT_EQ(flat.config().slope_ug_per_count, 250000);
}

TEST(LoadCell, RailReadingsAreImplausible) {
  struct Row {
    uint16_t counts;
    LoadCellStatus status;
  };
  const Row rows[] = {{0, LoadCellStatus::kImplausible},    {1, LoadCellStatus::kImplausible},
                      {2, LoadCellStatus::kImplausible},    {3, LoadCellStatus::kOk},
                      {512, LoadCellStatus::kOk},           {1020, LoadCellStatus::kOk},
                      {1021, LoadCellStatus::kImplausible}, {1023, LoadCellStatus::kImplausible}};
  const LoadCell cell;
  for (const auto& r : rows) EXPECT_EQ(cell.check(r.counts), r.status) << r.counts;
}

TEST(LoadCell, WeightAbove950GramsIsOverload) {
  // given a calibration where 100 counts is 900 g on the plate
  LoadCell cell;
  ASSERT_TRUE(cell.calibrateWeight(100, 900));
  // then 50 counts (937.5 g) is fine and 30 counts (952.5 g) is overload
  EXPECT_EQ(cell.check(50), LoadCellStatus::kOk);
  EXPECT_EQ(cell.check(30), LoadCellStatus::kOverload);
}

TEST(LoadCell, ForceAbove950GramsSinceTareIsOverload) {
  // given a 1.5 g/count cell holding 840 g at tare
  LoadCellConfig config;
  config.slope_ug_per_count = 1500000;
  LoadCell cell(config);
  ASSERT_TRUE(cell.calibrateWeight(100, 840));
  cell.tare(100);
  // when thrust lifts 940 g (weight -100 g) or 1000.5 g (weight -160.5 g)
  // then only the force exceeds the limit, and that alone is overload
  EXPECT_EQ(cell.check(727), LoadCellStatus::kOk);
  EXPECT_EQ(cell.check(767), LoadCellStatus::kOverload);
  EXPECT_EQ(cell.weightGrams(767), -161);
}

TEST(LoadCell, GramsSaturateInsteadOfWrapping) {
  LoadCellConfig config;
  config.offset_mg = -2000000000;
  const LoadCell cell(config);
  EXPECT_EQ(cell.weightGrams(0), 32767);
  config.offset_mg = 2000000000;
  const LoadCell other(config);
  EXPECT_EQ(other.weightGrams(0), -32768);
}

}  // namespace
