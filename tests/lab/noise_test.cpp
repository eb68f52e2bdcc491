// The noise floor: the measurement noise estimated from the data alone (noise.hpp) finds the
// generator's load-cell noise within its interval, is not fooled by conditions that change
// from point to point or by readings a logger held, and says when it cannot tell.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "lab/generate.hpp"
#include "lab/model.hpp"
#include "lab/noise.hpp"

namespace {

lab::Dataset generated(const char* hidden, double noise_g, double log_hz = 0, uint64_t seed = 1) {
  lab::GenerateOptions o;
  o.hidden = hidden;
  o.noise_g = noise_g;
  o.seed = seed;
  o.log_hz = log_hz;
  if (log_hz > 0) o.settle_s = 0.3;
  lab::Dataset d = lab::generate(o);
  lab::addDerivedColumns(d);
  return d;
}

TEST(LabNoise, ChiSquareQuantilesMatchTheTablesWithinOnePercent) {
  // given the published quantiles (chi-square tables): p, dof, value
  const double table[][3] = {{0.975, 10, 20.483}, {0.025, 10, 3.247}, {0.975, 100, 129.561},
                             {0.025, 100, 74.222}, {0.5, 30, 29.336}, {0.975, 5, 12.833}};
  for (const auto& row : table)
    EXPECT_NEAR(lab::chiSquareQuantile(row[0], row[1]), row[2], 0.01 * row[2]) << row[0] << " " << row[1];
}

TEST(LabNoise, FindsTheGeneratorsNoiseWithinItsInterval) {
  for (double noise_g : {0.5, 2.0}) {
    // given sweeps with nothing hidden and a load cell of known noise
    const lab::Dataset d = generated("none", noise_g);
    // when the noise is estimated from the data alone
    const lab::NoiseEstimate n = lab::estimateNoise(d);
    // then the interval holds the true value and the estimate is within 15 % of it
    ASSERT_TRUE(n.known()) << n.why_not;
    EXPECT_LE(n.lo_g, noise_g) << lab::describe(n);
    EXPECT_GE(n.hi_g, noise_g) << lab::describe(n);
    EXPECT_NEAR(n.sigma_g, noise_g, 0.15 * noise_g);
    EXPECT_LT(n.lo_g, n.sigma_g);
    EXPECT_GT(n.hi_g, n.sigma_g);
    EXPECT_GT(n.contrasts, 200u);  // four runs, up and down: every window of four neighbours
  }
}

TEST(LabNoise, AConditionThatChangesFromPointToPointIsNotTakenForNoise) {
  // given a pack that also feeds other motors (0-8 A changing point by point: the force moves
  // by tens of grams between neighbours) and the current logged
  const lab::Dataset d = generated("sag", 0.5);
  const lab::NoiseEstimate n = lab::estimateNoise(d);
  // then the current's contrasts are regressed out and the load cell's noise remains
  ASSERT_TRUE(n.known()) << n.why_not;
  EXPECT_LE(n.lo_g, 0.5);
  EXPECT_GE(n.hi_g, 0.5) << lab::describe(n);
  EXPECT_NE(std::find(n.conditions.begin(), n.conditions.end(), "current_a"), n.conditions.end());
}

TEST(LabNoise, RowsLoggedWhileAPointSettlesUseTimeAtOneSetPoint) {
  // given rows logged at 20 Hz while each point settles (a transient inside each set point)
  const lab::Dataset d = generated("none", 1.0, 20.0);
  const lab::NoiseEstimate n = lab::estimateNoise(d);
  ASSERT_TRUE(n.known()) << n.why_not;
  EXPECT_NEAR(n.sigma_g, 1.0, 0.15) << lab::describe(n);
}

TEST(LabNoise, AReadingHeldOverSeveralRowsCountsOnce) {
  // given each reading logged on five rows in a row (a logger faster than its load cell)
  const lab::Dataset d = generated("none", 1.0);
  lab::Dataset held;
  held.run_labels = d.run_labels;
  std::vector<double> pwm, force, t;
  for (std::size_t i = 0; i < d.rows(); ++i)
    for (int k = 0; k < 5; ++k) {
      pwm.push_back(d.col("pwm_us")[i]);
      force.push_back(d.col("force_g")[i]);
      t.push_back(d.col("t_s")[i] + 0.01 * k);
      held.run.push_back(d.run[i]);
    }
  held.set("pwm_us", pwm), held.set("force_g", force), held.set("t_s", t);
  const lab::NoiseEstimate n = lab::estimateNoise(held);
  // then the repeats are not five noiseless samples: the noise is the readings'
  ASSERT_TRUE(n.known()) << n.why_not;
  EXPECT_FALSE(n.note.empty());
  EXPECT_NEAR(n.sigma_g, 1.0, 0.2) << lab::describe(n);
}

TEST(LabNoise, TooFewRowsSayWhyInsteadOfAGuess) {
  lab::Dataset d;
  d.run_labels = {"short"};
  d.run.assign(6, 0);
  d.set("pwm_us", {1100, 1200, 1300, 1400, 1500, 1600});
  d.set("force_g", {10, 40, 90, 160, 250, 360});
  const lab::NoiseEstimate n = lab::estimateNoise(d);
  EXPECT_FALSE(n.known());
  EXPECT_NE(n.why_not.find("too few"), std::string::npos) << n.why_not;
  EXPECT_NE(lab::describe(n).find("not estimated"), std::string::npos);
}

}  // namespace
