// Benchmark 10, the attitude rigs against hand calculations (tools/bench/src/sections_rigs.cpp):
// every hand-vs-simulated figure in its JSON, within the section's 0.1 %, and the target says so.
// A rig whose physics drifted (a wrong inertia sum, a damping term twice, a lost gyroscopic
// term) moves one of these pairs apart and fails here.
#include <gtest/gtest.h>

#include <string>

#include "bench/sections.hpp"

namespace {

void expectClose(const nlohmann::json& pair, const std::string& what) {
  ASSERT_TRUE(pair.contains("hand") && pair.contains("simulated")) << what;
  const double hand = pair["hand"].get<double>(), simulated = pair["simulated"].get<double>();
  EXPECT_NE(hand, 0.0) << what;
  EXPECT_NEAR(simulated, hand, 1e-3 * std::abs(hand)) << what;
}

TEST(BenchRigsSection, EveryRigFigureIsWithinATenthOfAPercentOfItsHandValue) {
  const bench::Section s = bench::rigsSection();
  ASSERT_EQ(s.key, "rigs");
  const nlohmann::json& j = s.json;
  expectClose(j["seesaw"]["period_s"], "seesaw period");
  EXPECT_NEAR(j["seesaw"]["period_s"]["hand"].get<double>(), 1.8530, 5e-4);  // docs/sim.md's parts
  expectClose(j["seesaw"]["damping_ratio"], "seesaw damping ratio");
  expectClose(j["seesaw"]["stop"]["restitution"], "seesaw end stop");
  ASSERT_EQ(j["gimbal"]["torque_step"].size(), 3u);
  for (const auto& axis : j["gimbal"]["torque_step"])
    for (const char* key : {"alpha_rad_s2", "rate_dps", "angle_deg"})
      expectClose(axis[key], "gimbal torque step about " + axis["axis"].get<std::string>() + ": " + key);
  expectClose(j["gimbal"]["precession"]["half_period_s"], "gimbal precession");
  expectClose(j["gimbal"]["yaw"]["torque_nm"], "gimbal yaw torque");
  EXPECT_LT(j["gimbal"]["yaw"]["torque_nm"]["simulated"].get<double>(), 0.0);  // the CCW pair's drag wins
  ASSERT_EQ(s.targets.size(), 1u);
  EXPECT_TRUE(s.targets[0].met) << s.targets[0].figure;
  ASSERT_EQ(s.tables.size(), 1u);
}

}  // namespace
