// The noise floor on coloured noise (issue 26): where a log repeats a set point the floor is the
// pooled scatter within the set points' steady parts (pure error), corrected for samples that
// correlate; where it does not, the neighbours' contrasts are corrected for an AR(1) noise. And
// the lack-of-fit test of a model against the pure error.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <random>

#include "lab/dataset.hpp"
#include "lab/noise.hpp"
#include "lab/steps.hpp"
#include "lab_cli_run.hpp"

namespace {

// A ten-voltage sweep as a real bench logs it: at each voltage, set points every 50 us, 350
// samples each, the force settling from the previous set point over the first ~130 samples
// (time constant 30 samples), and noise sigma_g with lag-1 autocorrelation rho (AR(1)).
lab::Dataset tenVoltageSweep(double sigma_g, double rho, unsigned seed, std::size_t per_point = 350) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  lab::Dataset d;
  std::vector<double> pwm, force, vbat, t;
  double clock = 0, e = 0;
  const double innovation = sigma_g * std::sqrt(1 - rho * rho);
  for (int v = 0; v < 10; ++v) {
    const double volts = 10.0 + 0.25 * v;
    d.run_labels.push_back("sweep at " + std::to_string(volts) + " V");
    double settled = 0;
    for (double p = 1200; p <= 1600; p += 50) {
      const double target = 1e-3 * (p - 1080) * (p - 1080) * volts / 11.0 * 1.6;
      for (std::size_t k = 0; k < per_point; ++k) {
        e = rho * e + innovation * normal(rng);
        const double transient = (settled - target) * std::exp(-static_cast<double>(k) / 30.0);
        pwm.push_back(p);
        force.push_back(target + transient + e);
        vbat.push_back(volts);
        t.push_back(clock += 0.01);
        d.run.push_back(v);
      }
      settled = target;
    }
  }
  d.set("pwm_us", pwm), d.set("force_g", force), d.set("vbat_v", vbat), d.set("t_s", t);
  return d;
}

TEST(LabFloor, ARealTenVoltageSweepsFloorIsThePooledScatterWithinItsSetPoints) {
  // given a sweep whose noise correlates from sample to sample (6.55 g, lag-1 autocorrelation 0.4)
  const lab::Dataset d = tenVoltageSweep(6.55, 0.4, 1);
  // when the floor is estimated
  const lab::NoiseEstimate n = lab::estimateNoise(d);
  // then it is the pure error: 6.55 g within 5 %, with the correlation found, and the interval holds it
  ASSERT_TRUE(n.known()) << n.why_not;
  EXPECT_EQ(n.method, "pure_error");
  EXPECT_NEAR(n.sigma_g, 6.55, 0.05 * 6.55) << lab::describe(n);
  EXPECT_LE(n.lo_g, 6.55);
  EXPECT_GE(n.hi_g, 6.55);
  EXPECT_NEAR(n.lag1, 0.4, 0.05);
  EXPECT_EQ(n.setpoints, 90u);
  // the settling at the start of each set point is left out, most of the rest kept
  EXPECT_LT(n.steady_rows, n.setpoint_rows);
  EXPECT_GT(n.steady_rows, n.setpoint_rows / 2);
  // successive differences alone see less (sqrt(1 - r) of it), neighbours' contrasts less still
  EXPECT_NEAR(n.successive_g, 6.55 * std::sqrt(0.6), 0.06 * 6.55) << n.successive_g;
  EXPECT_LT(n.uncorrected_g, 0.8 * 6.55) << n.uncorrected_g;
  EXPECT_FALSE(n.assumption.empty());
}

TEST(LabFloor, WhiteNoiseGivesTheSameFloorEitherWay) {
  const lab::Dataset d = tenVoltageSweep(2.0, 0.0, 2);
  const lab::NoiseEstimate pure = lab::pureErrorNoise(d);
  const lab::NoiseEstimate neighbours = lab::neighbourNoise(d);
  ASSERT_TRUE(pure.known() && neighbours.known());
  EXPECT_NEAR(pure.sigma_g, 2.0, 0.1);
  EXPECT_NEAR(neighbours.sigma_g, 2.0, 0.1);
  EXPECT_LT(pure.lag1, 0.05);
  EXPECT_LT(neighbours.lag1, 0.05);
}

// A ramp-like log: every row its own PWM (no set point repeats), noise AR(1) with lag-1 r = 0.5, 3 g.
lab::Dataset correlatedRamp() {
  std::mt19937 rng(3);
  std::normal_distribution<double> normal(0.0, 1.0);
  lab::Dataset d;
  d.run_labels = {"ramp"};
  std::vector<double> pwm, force;
  double e = 0;
  for (int k = 0; k < 4000; ++k) {
    const double p = 1100 + 0.2 * k;
    e = 0.5 * e + 3.0 * std::sqrt(1 - 0.25) * normal(rng);
    pwm.push_back(p);
    force.push_back(1e-3 * (p - 1080) * (p - 1080) + e);
    d.run.push_back(0);
  }
  d.set("pwm_us", pwm), d.set("force_g", force);
  return d;
}

TEST(LabFloor, WithoutRepeatedSetPointsTheNeighboursAreCorrectedForCorrelatedSamples) {
  // given a ramp-like log: every row its own PWM (no set point repeats), noise AR(1) with r = 0.5
  const lab::Dataset d = correlatedRamp();
  const lab::NoiseEstimate n = lab::estimateNoise(d);
  ASSERT_TRUE(n.known()) << n.why_not;
  EXPECT_EQ(n.method, "neighbours");
  EXPECT_NEAR(n.lag1, 0.5, 0.08);
  EXPECT_NEAR(n.sigma_g, 3.0, 0.25) << lab::describe(n);
  EXPECT_LT(n.uncorrected_g, 0.75 * 3.0);  // as if independent: well below
  EXPECT_LE(n.lo_g, 3.0);
  EXPECT_GE(n.hi_g, 3.0);
}

TEST(LabFloor, LackOfFitIsSignificantOnlyWhenTheSetPointsMeansMissTheModel) {
  const lab::Dataset d = tenVoltageSweep(6.55, 0.4, 4);
  const lab::NoiseEstimate n = lab::estimateNoise(d);
  ASSERT_EQ(n.method, "pure_error");
  // given a model that predicts each set point's level exactly (its residual is the noise and the
  // settling), and one that misses each set point by +-3 g in turn
  const auto& f = d.col("force_g");
  std::vector<double> exact(d.rows()), biased(d.rows());
  for (const auto& block : lab::setpointBlocks(d)) {
    double tail = 0;  // the level: the mean of the block's second half
    for (std::size_t k = block.size() / 2; k < block.size(); ++k) tail += f[block[k]];
    tail /= static_cast<double>(block.size() - block.size() / 2);
    const double miss = (block.front() / 350) % 2 ? 3.0 : -3.0;
    for (std::size_t i : block) exact[i] = f[i] - tail, biased[i] = f[i] - tail + miss;
  }
  const lab::LackOfFit ok = lab::lackOfFit(n, exact, 12);
  const lab::LackOfFit off = lab::lackOfFit(n, biased, 12);
  ASSERT_TRUE(ok.tested && off.tested) << ok.why_not;
  EXPECT_FALSE(ok.significant) << ok.text;
  EXPECT_TRUE(off.significant) << off.text;
  EXPECT_NEAR(off.excess_g, 3.0, 0.5) << off.text;
  EXPECT_EQ(off.dof1, 90 - 12);
}

TEST(LabFloor, TheReportAndTheJsonStateWhatTheNoRepeatFloorAssumes) {
  // given the correlated ramp as a CSV file
  namespace fs = std::filesystem;
  const std::string dir = std::string(THRUSTCAL_LAB_TMP_DIR) + "/floor_assumption";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir + "/ramp.csv") << lab::toCsv(correlatedRamp(), {});
  // when it is diagnosed with a report
  const auto r = labtest::runLabCli({"lab", "diagnose", dir + "/ramp.csv", "--model", "curve", "--json", "--report",
                                     dir + "/report"});
  ASSERT_EQ(r.rc, 0) << r.err;
  // then the JSON names the estimator and its assumption (AR(1), the measured correlation) ...
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["noise"]["estimator"], "neighbours");
  const std::string assumption = j["noise"]["assumption"];
  EXPECT_NE(assumption.find("AR(1)"), std::string::npos) << assumption;
  EXPECT_NEAR(j["noise"]["lag1"].get<double>(), 0.5, 0.08);
  EXPECT_NE(assumption.find(fmt::format("lag-1 autocorrelation {:.2f}", j["noise"]["lag1"].get<double>())),
            std::string::npos)
      << assumption;
  EXPECT_FALSE(j["noise"]["lack_of_fit"]["tested"].get<bool>());  // no set points: nothing to test against
  // ... and the report says it in words
  std::ifstream page(dir + "/report/report.md");
  const std::string md((std::istreambuf_iterator<char>(page)), std::istreambuf_iterator<char>());
  EXPECT_NE(md.find("What the floor assumes: " + assumption), std::string::npos) << md.substr(0, 3000);
}

}  // namespace
