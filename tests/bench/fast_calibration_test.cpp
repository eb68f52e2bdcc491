// Issue 26 item 2 on the real gather_store image (THRUSTCAL_AVR_BUILD_DIR) in simavr, one motor:
// the fast calibration (`step 15`, `settle 150` on a slot with `dyn`) against gather_store's
// default sweep (settle auto), in simulated time. Benchmark 4 runs the same on four motors.
// Skipped when the AVR tree has not been built.
#include <gtest/gtest.h>

#include <filesystem>

#include "bench/sections.hpp"
#include "thrustcal/sweep_rules.hpp"

TEST(BenchFastCalibration, CorrectedFastSweepIsTwoAndAHalfTimesShorterThanSettleAutoAndMeetsTheAccuracyTarget) {
  bench::AvrPaths paths;
  paths.avr_build = THRUSTCAL_AVR_BUILD_DIR;
  if (!std::filesystem::exists(paths.elf("gather_store"))) GTEST_SKIP() << "no gather_store in " << THRUSTCAL_AVR_BUILD_DIR;
  // when: one motor calibrated with settle auto, then dyn cell + dyn and the fast sweep
  const nlohmann::json j = bench::fastCalibrationCheck(paths, {11});
  SCOPED_TRACE(j.dump());
  const nlohmann::json& fast = j["fast"];
  const nlohmann::json& settle_auto = j["settle_auto"];
  // then: the sweeps ran as asked (fixed settle at the fast setting; settle auto)
  EXPECT_EQ(fast["step_us"].get<int>(), tc::kFastSweepStepUs);
  EXPECT_EQ(fast["settle_ms"].get<int>(), tc::kFastSweepSettleMs);
  EXPECT_FALSE(fast["settle_auto"].get<bool>());
  EXPECT_TRUE(settle_auto["settle_auto"].get<bool>());
  // and: the fast first sweep is at least 2.5x shorter in simulated time, yet no shorter than
  // its steps' settle times (54 x 150 ms): the time is the board's, not skipped
  const double fast_s = fast["sweep_simulated_s_max"], auto_s = settle_auto["sweep_simulated_s_max"];
  EXPECT_GE(auto_s / fast_s, 2.5);
  EXPECT_GT(fast_s, 54 * 0.150);
  EXPECT_DOUBLE_EQ(j["speedup_over_settle_auto"].get<double>(), auto_s / fast_s);
  // and: model v2 from the fast sweeps is within issue 26's target over 100-450 g
  EXPECT_LE(fast["curve_error_rms_pct_100_450g"].get<double>(), 0.35);
  EXPECT_LE(fast["curve_error_max_pct_100_450g"].get<double>(), 1.2);
  EXPECT_TRUE(j["met"].get<bool>());
}
