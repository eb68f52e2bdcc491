#include <gtest/gtest.h>

#include "thrustcal/battery_monitor.hpp"

namespace {

using tc::BatteryMonitor;
using tc::SagBuilder;
using tc::SagTable;

TEST(BatteryMonitor, CountsMapToMillivoltsLikeThesisMap) {
  struct Row {
    uint16_t counts;
    uint16_t mv;
  };
  // map(x, 0, 1023, 0, 15638), truncating
  const Row rows[] = {{0, 0}, {1, 15}, {512, 7826}, {700, 10700}, {1022, 15622}, {1023, 15638}, {2000, 15638}};
  const BatteryMonitor monitor;
  for (const auto& r : rows) EXPECT_EQ(monitor.millivoltsFromCounts(r.counts), r.mv) << r.counts;
}

TEST(BatteryMonitor, ZeroAdcMaxReadsZeroInsteadOfDividingByZero) {
  tc::BatteryConfig config;
  config.adc_max_counts = 0;
  EXPECT_EQ(BatteryMonitor(config).millivoltsFromCounts(500), 0);
}

TEST(BatteryMonitor, DividerFullScaleOf100kOver47kIs15638Millivolts) {
  struct Row {
    uint32_t r1, r2;
    uint16_t vref_mv;
    uint16_t full_scale_mv;
  };
  const Row rows[] = {
      {100000, 47000, 5000, 15638},
      {10000000, 4700000, 5000, 15638},  // same ratio in megaohms
      {10000, 10000, 5000, 10000},
      {0, 1000, 5000, 5000},             // no top resistor: the pin sees the battery
      {100000, 47000, 3300, 10321},
      {1000000, 1000, 5000, 65535},      // saturates
      {100000, 0, 5000, 0},              // no bottom resistor: not a divider
      {4000000000u, 4000000000u, 65535, 65535},
  };
  for (const auto& r : rows)
    EXPECT_EQ(tc::dividerFullScaleMillivolts(r.r1, r.r2, r.vref_mv), r.full_scale_mv) << r.r1 << "/" << r.r2;
  EXPECT_EQ(tc::dividerFullScaleMillivolts(100000, 47000), tc::BatteryConfig().full_scale_mv);
}

TEST(BatteryMonitor, SaneRangeIsInclusive) {
  const BatteryMonitor monitor;
  EXPECT_FALSE(monitor.isSane(5999));
  EXPECT_TRUE(monitor.isSane(6000));
  EXPECT_TRUE(monitor.isSane(17500));
  EXPECT_FALSE(monitor.isSane(17501));
}

TEST(SagTable, BinIsFortyMicrosecondsWideAndClampedToThirteenBins) {
  struct Row {
    uint16_t pwm_us, base_us;
    uint8_t bin;
  };
  const Row rows[] = {{0, 1000, 0},     {900, 1000, 0},   {1000, 1000, 0},  {1039, 1000, 0},
                      {1040, 1000, 1},  {1479, 1000, 11}, {1480, 1000, 12}, {1519, 1000, 12},
                      {2000, 1000, 12}, {65535, 1000, 12}, {1119, 1080, 0}, {1120, 1080, 1}};
  for (const auto& r : rows) EXPECT_EQ(SagTable::binFor(r.pwm_us, r.base_us), r.bin) << r.pwm_us << " base " << r.base_us;
}

TEST(BatteryMonitor, CompensationAddsTheOffsetOfTheLastPwmSent) {
  // given the thesis's sag: 11.35 V true read as 10.8 V at full sweep
  SagTable sag;
  sag.offset_mv[12] = 550;
  sag.offset_mv[5] = 200;
  const BatteryMonitor monitor;
  // then
  EXPECT_EQ(monitor.compensatedMillivolts(10800, 1600, sag), 11350);
  EXPECT_EQ(monitor.compensatedMillivolts(11000, 1220, sag), 11200);  // centre of bin 5
  EXPECT_EQ(monitor.compensatedMillivolts(11400, 1000, sag), 11400);
}

TEST(BatteryMonitor, CompensationSaturatesAtBothEnds) {
  SagTable sag;
  sag.offset_mv[0] = -100;
  sag.offset_mv[1] = 100;
  const BatteryMonitor monitor;
  EXPECT_EQ(monitor.compensatedMillivolts(50, 1000, sag), 0);
  EXPECT_EQ(monitor.compensatedMillivolts(65500, 1060, sag), 65535);
}

TEST(SagBuilder, AveragesPerBinAndOffsetsAreDropsFromTheStartVoltage) {
  // given a thesis sweep 1000..1519 us, the reading dropping 50 mV per 40 us bin
  SagBuilder builder;
  builder.reset(1000);
  for (uint16_t pwm = 1000; pwm < 1520; ++pwm) {
    const uint16_t bin = static_cast<uint16_t>((pwm - 1000) / 40);
    const uint16_t jitter = (pwm % 2) ? 4 : 0;  // average of each bin is +2 mV
    builder.add(pwm, static_cast<uint16_t>(12000 - 50 * bin + jitter));
  }
  // when
  SagTable sag;
  uint16_t start_mv = 0;
  ASSERT_TRUE(builder.build(sag, start_mv));
  // then
  EXPECT_EQ(start_mv, 12002);  // Average[0]
  EXPECT_EQ(sag.base_pwm_us, 1000);
  for (uint8_t i = 0; i < tc::kSagBins; ++i) {
    EXPECT_EQ(builder.samples(i), 40) << int(i);
    EXPECT_EQ(sag.offset_mv[i], 50 * i) << int(i);
  }
  EXPECT_EQ(builder.samples(tc::kSagBins), 0);
}

TEST(SagBuilder, EmptyBinsBorrowTheNearestVisitedBinLowerOnTies) {
  // given only bins 0, 3 and 12 visited
  SagBuilder builder;
  builder.reset(1000);
  builder.add(1000, 12000);
  builder.add(1120, 11700);  // bin 3: offset 300
  builder.add(1480, 11000);  // bin 12: offset 1000
  // when
  SagTable sag;
  uint16_t start_mv = 0;
  ASSERT_TRUE(builder.build(sag, start_mv));
  // then
  const int16_t expected[tc::kSagBins] = {0, 0, 300, 300, 300, 300, 300, 300, 1000, 1000, 1000, 1000, 1000};
  for (uint8_t i = 0; i < tc::kSagBins; ++i) EXPECT_EQ(sag.offset_mv[i], expected[i]) << int(i);
  // and with bins 0 and 2 visited, bin 1 is a tie: the lower bin wins
  builder.reset(1000);
  builder.add(1000, 12000);
  builder.add(1080, 11800);
  ASSERT_TRUE(builder.build(sag, start_mv));
  EXPECT_EQ(sag.offset_mv[1], 0);
  EXPECT_EQ(sag.offset_mv[12], 200);
}

TEST(SagBuilder, SamplesBelowBaseGoToBinZeroAndSamplesAboveTheLastBinAreLeftOut) {
  SagBuilder builder;
  builder.reset(1080);
  builder.add(1000, 12000);  // below base: bin 0
  builder.add(1599, 11600);  // last us of bin 12 (1080 + 13 * 40 = 1600)
  builder.add(1600, 11000);  // beyond the table: left out
  builder.add(1999, 10500);  // far above: left out
  EXPECT_EQ(builder.samples(0), 1);
  EXPECT_EQ(builder.samples(12), 1);
  SagTable sag;
  uint16_t start_mv = 0;
  ASSERT_TRUE(builder.build(sag, start_mv));
  EXPECT_EQ(sag.base_pwm_us, 1080);
  EXPECT_EQ(sag.offset_mv[12], 400) << "bin 12 is the average of its own 40 us only";
}

TEST(SagTable, OffsetIsInterpolatedBetweenBinCentresAndFlatBeyondTheEnds) {
  // given offsets rising 40 mV per bin from base 1000 (centres at 1020, 1060, ..., 1500)
  SagTable sag;
  sag.base_pwm_us = 1000;
  for (uint8_t i = 0; i < tc::kSagBins; ++i) sag.offset_mv[i] = static_cast<int16_t>(40 * i);
  struct Row {
    uint16_t pwm_us;
    int16_t offset_mv;
  };
  const Row rows[] = {{0, 0},      {1000, 0},   {1020, 0},   {1021, 1},   {1040, 20},
                      {1059, 39},  {1060, 40},  {1479, 459}, {1480, 460}, {1500, 480},
                      {1519, 480}, {2000, 480}, {65535, 480}};
  for (const auto& r : rows) EXPECT_EQ(sag.offsetFor(r.pwm_us), r.offset_mv) << r.pwm_us;
  // and a falling pair rounds to the nearest mV too
  sag.offset_mv[1] = -40;
  EXPECT_EQ(sag.offsetFor(1030), -10);
  EXPECT_EQ(sag.offsetFor(1041), -21);
}

TEST(SagBuilder, AverageRoundsToNearestMillivolt) {
  SagBuilder builder;
  builder.reset(1000);
  builder.add(1000, 11000);
  builder.add(1001, 11001);
  SagTable sag;
  uint16_t start_mv = 0;
  ASSERT_TRUE(builder.build(sag, start_mv));
  EXPECT_EQ(start_mv, 11001);
}

TEST(SagBuilder, WithoutAStartVoltageBuildFailsAndLeavesOutputUntouched) {
  // given samples only above bin 0
  SagBuilder builder;
  builder.reset(1000);
  builder.add(1200, 11000);
  SagTable sag;
  sag.offset_mv[3] = 77;
  uint16_t start_mv = 1234;
  // when / then
  EXPECT_FALSE(builder.build(sag, start_mv));
  EXPECT_EQ(sag.offset_mv[3], 77);
  EXPECT_EQ(start_mv, 1234);
}

TEST(SagBuilder, ResetForgetsPreviousSweep) {
  SagBuilder builder;
  builder.reset(1000);
  builder.add(1000, 11000);
  builder.reset(1000);
  EXPECT_EQ(builder.samples(0), 0);
  SagTable sag;
  uint16_t start_mv = 0;
  EXPECT_FALSE(builder.build(sag, start_mv));
}

// offsetFor divides by 40 with a multiplication: the same offset as the division it replaces,
// for every pulse width and offsets up to the int16 limits.
int16_t offsetByDivision(const SagTable& sag, uint16_t pwm_us) {
  const uint16_t first_centre_us = static_cast<uint16_t>(sag.base_pwm_us + 20);
  if (pwm_us <= first_centre_us) return sag.offset_mv[0];
  const uint16_t from_centre_us = static_cast<uint16_t>(pwm_us - first_centre_us);
  const uint16_t bin = static_cast<uint16_t>(from_centre_us / 40);
  if (bin >= tc::kSagBins - 1) return sag.offset_mv[tc::kSagBins - 1];
  const int16_t fraction_us = static_cast<int16_t>(from_centre_us - bin * 40);
  const int32_t delta = static_cast<int32_t>(sag.offset_mv[bin + 1] - sag.offset_mv[bin]) * fraction_us;
  const int32_t step = (delta >= 0 ? delta + 20 : delta - 20) / 40;
  return static_cast<int16_t>(sag.offset_mv[bin] + step);
}

TEST(SagTable, OffsetWithoutDivisionEqualsTheDivisionForEveryPulse) {
  const int16_t patterns[][tc::kSagBins] = {
      {0, 10, 30, 60, 100, 150, 210, 280, 360, 450, 550, 660, 780},
      {0, -1280, 1270, -1280, 1270, -1280, 1270, -1280, 1270, -1280, 1270, -1280, 1270},
      {0, 32767, -32768, 32767, -32768, 12345, -23456, 32767, 0, -1, 1, -32768, 32767},
      {0, 7, 13, 19, 23, 29, 31, 37, 41, 43, 47, 53, 59},
  };
  for (const auto& pattern : patterns) {
    for (const uint16_t base : {uint16_t{0}, uint16_t{1000}, uint16_t{1234}, uint16_t{65000}}) {
      SagTable sag;
      sag.base_pwm_us = base;
      for (uint8_t i = 0; i < tc::kSagBins; ++i) sag.offset_mv[i] = pattern[i];
      for (uint32_t pwm = 0; pwm <= 0xFFFF; ++pwm)
        ASSERT_EQ(sag.offsetFor(static_cast<uint16_t>(pwm)), offsetByDivision(sag, static_cast<uint16_t>(pwm)))
            << "pwm " << pwm << " base " << base;
    }
  }
}

TEST(BatteryMonitor, TwoReadingsMapAtHalfCountResolutionWithoutDividing) {
  // given: the thesis divider and others; when: every sum of two readings; then: the division
  struct Config {
    uint16_t full_scale_mv, adc_max;
  };
  const Config configs[] = {{15638, 1023}, {5000, 1023}, {25000, 1023}, {65535, 1023}, {15638, 511},
                            {3000, 4095}, {65535, 32}};
  for (const Config& c : configs) {
    tc::BatteryConfig config;
    config.full_scale_mv = c.full_scale_mv;
    config.adc_max_counts = c.adc_max;
    const BatteryMonitor monitor(config);
    for (uint32_t sum = 0; sum <= 2u * c.adc_max + 3u; ++sum) {
      const uint32_t den = 2u * c.adc_max;
      const uint16_t want = sum >= den ? c.full_scale_mv : static_cast<uint16_t>(sum * c.full_scale_mv / den);
      ASSERT_EQ(monitor.millivoltsFromTwoCounts(static_cast<uint16_t>(sum)), want)
          << c.full_scale_mv << " mV / " << c.adc_max << ", sum " << sum;
    }
  }
  // equal readings: exactly map() of the reading
  const BatteryMonitor thesis;
  for (uint16_t counts = 0; counts <= 1023; ++counts)
    ASSERT_EQ(thesis.millivoltsFromTwoCounts(static_cast<uint16_t>(2 * counts)), thesis.millivoltsFromCounts(counts));
}

}  // namespace
