// Step logs as benches write them (issue 26): gather_store's `dyn` stream (the project's CSV with
// `# ` comment lines around each step, force to 0.1 g), an RCbenchmark / Tyto export with its
// time column, and a log read through the bench's own load-cell low-pass, which the `cell` stage
// separates from the motor's lag when the bench's response is known (--fix).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include <fmt/format.h>

#include "lab/analysis.hpp"
#include "lab/dataset.hpp"
#include "lab/generate.hpp"
#include "lab/model.hpp"
#include "lab/steps.hpp"

namespace {

lab::GenerateOptions stepOptions(bool bench_filter) {
  lab::GenerateOptions o;
  o.hidden = "lag";
  o.noise_g = 0.5;
  o.seed = 3;
  o.bench_filter = bench_filter;
  return o;
}

// Motor 0's rows of the plant's step log.
lab::Dataset motor0(const lab::Dataset& d) {
  std::vector<bool> keep(d.rows());
  for (std::size_t i = 0; i < d.rows(); ++i) keep[i] = d.col("motor")[i] == 0;
  return d.subset(keep);
}

// The rows as gather_store's `dyn` streams them (docs/gather_store.md, "The step log"): the header
// t_s,pwm_us,force_g,vbat_v,motor,dir once, a `# step` line before each step's rows and a `# fit`
// line after them, force and voltage rounded as the firmware prints them.
std::string asGatherStoreStream(const lab::Dataset& d) {
  std::string s = "# dyn motor 0: 5 points, steps up and down\nt_s,pwm_us,force_g,vbat_v,motor,dir\n";
  const auto &t = d.col("t_s"), &p = d.col("pwm_us"), &f = d.col("force_g"), &v = d.col("vbat_v");
  int dir = 0;  // the step's direction, on each of its rows
  for (std::size_t i = 0; i < d.rows(); ++i) {
    if (i > 0 && p[i] != p[i - 1]) {
      dir = p[i] > p[i - 1] ? 1 : -1;
      s += fmt::format("# fit done\n# step {} {:.0f} -> {:.0f} us at t_s {:.4f} (the ESC's edge); bus {:.2f} V\n",
                       dir > 0 ? "up" : "down", p[i - 1], p[i], t[i], v[i]);
    }
    s += fmt::format("{:.4f},{:.0f},{:.1f},{:.2f},0,{}\n", t[i], p[i], f[i], v[i], dir);
  }
  return s;
}

void expectPlantsTimeConstants(const lab::FitResult& fit, const lab::StepTruth& truth, const char* what) {
  const auto dyn = lab::dynamicsOf(fit);
  ASSERT_EQ(dyn.size(), 1u) << what;
  EXPECT_NEAR(dyn[0].tau_up_s, truth.tau_up_s, 0.05 * truth.tau_up_s) << what;
  EXPECT_NEAR(dyn[0].tau_down_s, truth.tau_down_s, 0.05 * truth.tau_down_s) << what;
  EXPECT_EQ(dyn[0].asymmetry, 1) << what << ": " << dyn[0].text;
}

TEST(LabStepLog, GatherStoresDynStreamIsAStepLogAndGivesThePlantsTimeConstants) {
  // given motor 0's plant step log streamed as gather_store's `dyn` prints it
  const lab::Dataset plant = motor0(lab::generate(stepOptions(false)));
  const lab::Dataset d = lab::parseText(asGatherStoreStream(plant), "dyn.log", lab::ReadOptions());
  // then every row is read (the comment lines are not rows), it is a step log, and curve+lag
  // gives the plant's time constants within 5 %, spin-down slower
  ASSERT_EQ(d.rows(), plant.rows());
  EXPECT_TRUE(lab::isStepLog(d));
  expectPlantsTimeConstants(lab::fitModel(d, lab::parseSpec("curve+lag")), lab::stepTruth(stepOptions(false))[0],
                            "gather_store stream");
}

TEST(LabStepLog, AStandsExportWithATimeColumnIsAStepLog) {
  // given the step log as an RCbenchmark 1585 export (Time (s), ESC signal (µs), Thrust (gf))
  const lab::Dataset plant = motor0(lab::generate(stepOptions(false)));
  lab::StandLayout l;
  l.thrust_unit = "gf";
  const lab::Dataset d = lab::parseText(lab::toStandCsv(plant, l), "stand.csv", lab::ReadOptions());
  // then its time is t_s on every row and it is a step log
  ASSERT_TRUE(d.has("t_s"));
  EXPECT_EQ(d.rows(), plant.rows());
  EXPECT_TRUE(lab::isStepLog(d));
}

TEST(LabStepLog, TheBenchsKnownFilterIsSeparatedFromTheMotorsLag) {
  // given motor 0's step log read through the plant's load-cell low-pass (three 30 ms stages)
  const lab::Dataset d = motor0(lab::generate(stepOptions(true)));
  const lab::StepTruth truth = lab::stepTruth(stepOptions(true))[0];
  // when the lag alone is fitted, it takes the cell's delay for the motor's: well above the plant's
  const auto alone = lab::dynamicsOf(lab::fitModel(d, lab::parseSpec("curve+lag")));
  ASSERT_EQ(alone.size(), 1u);
  EXPECT_GT(alone[0].tau_up_s, 1.2 * truth.tau_up_s) << alone[0].text;
  // when the bench's response is known (--fix tau_cell_s=0.03 --fix cell_stages=3)
  lab::ModelSpec spec = lab::parseSpec("curve+lag+cell");
  lab::fixParameter(spec, "tau_cell_s=0.03");
  lab::fixParameter(spec, "cell_stages=3");
  const lab::FitResult fit = lab::fitModel(d, spec);
  // then the motor's own time constants are the plant's within 5 %, and the held values are not fitted
  expectPlantsTimeConstants(fit, truth, "through the cell");
  for (const auto& p : fit.params)
    if (p.effect == "cell") EXPECT_TRUE(p.fixed) << p.name;
}

TEST(LabStepLog, AFixOfAParameterNoEffectHasSaysWhichThereAre) {
  lab::ModelSpec spec = lab::parseSpec("curve+lag");
  try {
    lab::fixParameter(spec, "tau_cel_s=0.03");
    FAIL() << "a misspelt name was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("tau_cell_s"), std::string::npos) << e.what();
  }
  EXPECT_THROW(lab::fixParameter(spec, "tau_cell_s"), std::invalid_argument);
  EXPECT_THROW(lab::fixParameter(spec, "tau_cell_s=fast"), std::invalid_argument);
}

}  // namespace
