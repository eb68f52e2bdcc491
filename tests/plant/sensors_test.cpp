// Load cell on A0 and battery monitor on A1, as the firmware sees them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "plant/plant.hpp"

namespace {

using namespace plant;

double thesisLine_g(int counts) { return 0.75 * counts - 156.0; }

LoadCellParams quietCell() {
  LoadCellParams p;
  p.noise_mv = 0.0;
  p.vibration_frac = 0.0;
  return p;
}

TEST(AdcConversion, MatchesSimavrsIntegerMillivoltScaling) {
  const struct { double mv; int counts; } rows[] = {
      {0.0, 0}, {4.0, 0}, {5.0, 1}, {1016.62, 208}, {2500.0, 511}, {4999.6, 1023},
      {6000.0, 1023}, {-20.0, 0}};
  for (const auto& r : rows) {
    SCOPED_TRACE(r.mv);
    EXPECT_EQ(adcCountsFromMillivolts(r.mv), r.counts);
  }
}

TEST(LoadCellSensor, ReproducesTheThesisLineWithinOneCount) {
  // given the default INA125P settings and no noise
  const LoadCellParams p = quietCell();
  const double downs[] = {-400.0, -200.0, -60.0, 0.0, 20.0, 60.0, 80.0};  // without the plate
  for (double down : downs) {
    LoadCellSensor cell(p);
    // when the load (plus the 60 g plate) settles on the cell
    cell.settle(down);
    const int counts = cell.readCounts();
    // then the thesis line gives minus the total downward load, within one count (0.75 g)
    SCOPED_TRACE(testing::Message() << "down " << down << " g, counts " << counts);
    EXPECT_NEAR(thesisLine_g(counts), -(down + p.plate_g), 0.75);
  }
}

TEST(LoadCellSensor, WeightLowersTheReadingAndThrustRaisesIt) {
  LoadCellSensor cell(quietCell());
  cell.settle(80.0);
  const int resting = cell.readCounts();
  cell.settle(80.0 + 50.0);
  EXPECT_LT(cell.readCounts(), resting);
  cell.settle(80.0 - 300.0);
  EXPECT_NEAR(cell.readCounts() - resting, 300.0 / 0.75, 1.0);
}

TEST(LoadCellSensor, SaturatesAtTheAmplifierLimitLikeTheThesis) {
  // thesis: "maximum readable values of 870 values and 650 grams"
  LoadCellSensor cell(quietCell());
  cell.settle(-2000.0);
  EXPECT_EQ(cell.readCounts(), 869);
  cell.settle(500.0);  // more than the offset can carry: the output clips at 0 V
  EXPECT_EQ(cell.readCounts(), 0);
}

TEST(LoadCellSensor, LowPassDelaysAStepByAboutTheSumOfItsTimeConstants) {
  LoadCellSensor cell(quietCell());
  cell.settle(80.0);
  const double v0 = cell.filteredMillivolts();
  const double v1 = cell.params().idealMillivolts(80.0 - 300.0 + cell.params().plate_g);
  double t = 0.0;
  while (std::fabs(cell.filteredMillivolts() - v0) < 0.5 * std::fabs(v1 - v0)) {
    cell.step(0.001, 80.0 - 300.0, 300.0);
    t += 0.001;
  }
  EXPECT_GT(t, 0.05);
  EXPECT_LT(t, 0.12);
  for (int i = 0; i < 600; ++i) cell.step(0.001, 80.0 - 300.0, 300.0);
  EXPECT_NEAR(cell.filteredMillivolts(), v1, 0.001 * std::fabs(v1 - v0));
}

TEST(LoadCellSensor, NoiseIsSeededAndTheMedianOfManyReadingsIsUnbiased) {
  LoadCellParams p;  // default noise
  LoadCellSensor a(p), b(p);
  a.settle(-220.0);
  b.settle(-220.0);
  std::vector<int> counts;
  for (int i = 0; i < 201; ++i) {
    const int ca = a.readCounts();
    EXPECT_EQ(ca, b.readCounts());
    counts.push_back(ca);
  }
  std::sort(counts.begin(), counts.end());
  EXPECT_NEAR(thesisLine_g(counts[100]), -(-220.0 + p.plate_g), 1.5);
  EXPECT_GT(counts.back() - counts.front(), 1);  // there is noise to filter
}

TEST(Bench, ACalibrationWeightLowersTheCountsByFourThirdsPerGram) {
  // given the thesis bench with the motor mounted (81 g on a 60 g plate: 20 counts, the thesis
  // offset leaves only ~15 g of headroom, which is why it calibrates with the motor itself)
  BenchParams bp = BenchParams::thesis();
  bp.load_cell = quietCell();
  Bench bench(bp);
  bench.run(0.5);
  const int empty = bench.readCounts(0);
  // when 12 g more are put on the plate
  bench.placeWeight_g(12.0);
  bench.run(1.0);
  // then the reading falls by 16 counts
  EXPECT_NEAR(empty - bench.readCounts(0), 16.0, 1.0);
  // and in phase 1 the thesis line reads the mount weight plus what was put on the plate
  EXPECT_NEAR(-thesisLine_g(bench.readCounts(0)) - bp.load_cell.plate_g,
              bp.actuator.mountWeight_g() + 12.0, 0.75);
  bench.removeWeights();
  bench.run(1.0);
  EXPECT_EQ(bench.readCounts(0), empty);
}

TEST(BatteryMonitor, ReadsTheRestingVoltageThroughTheThesisDivider) {
  BenchParams bp = BenchParams::thesis();
  bp.battery_sensor.noise_mv = 0.0;
  Bench bench(bp);
  bench.run(0.2);
  const int counts = bench.readCounts(1);
  EXPECT_NEAR(counts * 15.638 / 1023.0, 12.6, 0.02);
}

TEST(BatteryMonitor, ReadsAboutHalfAVoltLowAtHighThrottleLikeTheThesis) {
  // given a LiPo resting at 11.35 V on the thesis bench (fig. 6.1)
  BenchParams bp = BenchParams::thesis();
  bp.power.soc = socForCellOcv(11.35 / 3.0);
  bp.battery_sensor.noise_mv = 0.0;
  Bench bench(bp);
  ASSERT_NEAR(bench.restingVoltage_v(), 11.35, 1e-6);
  // when the motor runs at the top of the interesting band
  bench.actuator().holdPulse(1680.0);
  bench.run(1.5);
  const double read_v = bench.readCounts(1) * 15.638 / 1023.0;
  // then the monitor reads around 10.8 V (0.4..0.7 V low), while the thrust is ~500 g
  EXPECT_GT(11.35 - read_v, 0.4);
  EXPECT_LT(11.35 - read_v, 0.7);
  EXPECT_GT(bench.actuator().thrust_g(), 400.0);
}

}  // namespace
