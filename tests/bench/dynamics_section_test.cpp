// Benchmark 9 (issue 26 item 1) on the real gather_store image (THRUSTCAL_AVR_BUILD_DIR) in
// simavr, quick: the KV900 part (the swap's most different motor) through `dyn cell` and `dyn`.
// One session, several assertions. Skipped when the AVR tree has not been built.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "bench/sections.hpp"

TEST(BenchDynamicsSection, EveryStepsTimeConstantIsWithinFivePercentOfThePlantsInAtMost40SimulatedSeconds) {
  bench::AvrPaths paths;
  paths.avr_build = THRUSTCAL_AVR_BUILD_DIR;
  if (!std::filesystem::exists(paths.elf("gather_store"))) GTEST_SKIP() << "no gather_store in " << THRUSTCAL_AVR_BUILD_DIR;
  // when: dyn cell, a calibration sweep, store v2 and dyn on the KV900 part
  const bench::Section s = bench::dynamicsSection(paths, true);
  // then: five operating points, each with both time constants beside the plant's own
  ASSERT_TRUE(s.json.contains("points")) << s.json.dump();
  const nlohmann::json& points = s.json["points"];
  ASSERT_EQ(points.size(), 5u) << s.json.dump();
  double last_force_g = 0;
  for (const nlohmann::json& p : points) {
    SCOPED_TRACE(p.dump());
    EXPECT_EQ(p["part"], "kv900_11x4.7");
    EXPECT_GT(p["force_g"].get<double>(), last_force_g);  // the points climb the motor's range
    last_force_g = p["force_g"].get<double>();
    for (const char* dir : {"up", "down"}) {
      const double tau = p[std::string("tau_") + dir + "_s"], truth = p[std::string("truth_") + dir + "_s"];
      EXPECT_GT(truth, 0.05);  // a real motor's, not a default
      EXPECT_LE(std::fabs(tau / truth - 1.0), 0.05) << dir;
    }
  }
  // and: the session fits the budget, the bench's response was identified, the targets say so
  EXPECT_LE(s.json["session_s_max"].get<double>(), 40.0);
  EXPECT_GT(s.json["session_s_max"].get<double>(), 10.0);
  EXPECT_EQ(s.json["bench"]["stages"].get<int>(), 3);
  EXPECT_EQ(s.json["sessions"][0]["stored_points"].get<int>(), 5);
  // and: no work in the session (the sweep's end, store v2, dyn's fits) ran half the watchdog's
  // time-out without a kick (docs/safety.md, "Watchdog headroom")
  EXPECT_GT(s.json["sessions"][0]["longest_kick_gap_ms"].get<double>(), 0.0);
  EXPECT_LE(s.json["longest_kick_gap_ms"].get<double>(), 32.0) << s.json["sessions"][0]["kick_gap_where"];
  ASSERT_EQ(s.targets.size(), 3u);
  for (const bench::TargetCheck& t : s.targets) EXPECT_TRUE(t.met) << t.what << ": " << t.figure;
}
