// The `current_limit` effect on generated data: on a current-limited bench (vbat_v read at the
// supply) it earns its parameters, finds the limit in amperes and brings the ladder to the noise
// floor; without a limit it gets no credit; without current_a the cap is fitted in grams; it
// predicts runs it was not fitted on; a record cannot hold it.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "lab/analysis.hpp"
#include "lab/export.hpp"
#include "lab/generate.hpp"
#include "lab/model.hpp"
#include "lab/noise.hpp"

namespace {

constexpr double kNoiseG = 0.5;

lab::Dataset generated(const char* hidden) {
  lab::GenerateOptions o;
  o.hidden = hidden;
  o.noise_g = kNoiseG;
  lab::Dataset d = lab::generate(o);
  lab::addDerivedColumns(d);
  return d;
}

double param(const lab::FitResult& f, const char* name) {
  for (const auto& p : f.params)
    if (p.name == name) return p.value;
  return NAN;
}

TEST(LabCurrentLimit, EarnsItsParameterFindsTheLimitAndTheLadderReachesTheNoiseFloor) {
  // given the thesis's supply (6.32 A) at four set voltages, vbat_v the set voltage
  const lab::Dataset d = generated("current_limit");
  // when the ladder adds current_limit, then sag (the leads: vbat_v is read at the supply)
  const auto steps = lab::ladder(d, lab::parseSpec("curve+deadband+voltage"), {"current_limit", "sag"},
                                 lab::Holdout::kNone);
  ASSERT_EQ(steps.size(), 3u);
  // then the limit earns its parameters by far, at the supply's 6.32 A
  EXPECT_TRUE(steps[1].earns) << steps[1].verdict;
  EXPECT_LT(steps[1].delta_bic, -100);
  EXPECT_GT(steps[0].fit.rmse_g / steps[1].fit.rmse_g, 20.0);
  EXPECT_NEAR(param(steps[1].fit, "i_limit_a"), 6.32, 0.02);
  // and the error ends at the noise floor estimated from the data
  const lab::NoiseEstimate n = lab::estimateNoise(d);
  ASSERT_TRUE(n.known());
  EXPECT_LE(steps[2].fit.rmse_g, n.hi_g) << "noise " << lab::describe(n);
  EXPECT_LE(steps[2].fit.rmse_g, 1.2 * kNoiseG);
}

TEST(LabCurrentLimit, GetsNoCreditWhereThereIsNoLimit) {
  for (const char* hidden : {"none", "sag"}) {
    // given sweeps whose current never stops rising
    const lab::Dataset d = generated(hidden);
    const auto steps = lab::ladder(d, lab::parseSpec("curve+deadband+voltage"), {"current_limit"},
                                   lab::Holdout::kNone);
    // then the effect changes nothing and the criterion says so
    EXPECT_FALSE(steps[1].earns) << hidden << ": " << steps[1].verdict;
    EXPECT_GT(steps[1].delta_bic, 0.0) << hidden;
    EXPECT_LE(steps[1].fit.rmse_g, steps[0].fit.rmse_g + 1e-9) << hidden << ": a nested fit never fits worse";
  }
}

TEST(LabCurrentLimit, WithoutCurrentTheCapIsFittedInGramsOnTheRunsWhoseForceFalls) {
  // given the same bench with no current column
  const lab::Dataset full = generated("current_limit");
  lab::Dataset d;
  d.run = full.run, d.run_labels = full.run_labels;
  for (const char* c : {"t_s", "pwm_us", "force_g", "vbat_v", "dir"}) d.set(c, full.col(c));
  const auto steps = lab::ladder(d, lab::parseSpec("curve+deadband+voltage"), {"current_limit"},
                                 lab::Holdout::kNone);
  EXPECT_TRUE(steps[1].earns) << steps[1].verdict;
  EXPECT_GT(steps[0].fit.rmse_g / steps[1].fit.rmse_g, 10.0)
      << steps[0].fit.rmse_g << " -> " << steps[1].fit.rmse_g;
  EXPECT_TRUE(std::isnan(param(steps[1].fit, "i_limit_a"))) << "amperes cannot be told from grams";
  EXPECT_GT(param(steps[1].fit, "cap_top_g"), 300);
}

TEST(LabCurrentLimit, PredictsARunItWasNotFittedOn) {
  const lab::Dataset d = generated("current_limit");
  const double with = lab::holdoutRmse(d, lab::parseSpec("curve+deadband+voltage+current_limit"), lab::Holdout::kRuns);
  const double without = lab::holdoutRmse(d, lab::parseSpec("curve+deadband+voltage"), lab::Holdout::kRuns);
  EXPECT_LT(with, 3.0);
  EXPECT_GT(without / with, 5.0);
}

TEST(LabCurrentLimit, ARecordCannotHoldItAndTheRefusalSaysWhatToDo) {
  try {
    lab::checkExportable(lab::parseSpec("curve+deadband+voltage+current_limit"), false);
    FAIL() << "exported a current limit";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--where 'pwm_us < P'"), std::string::npos) << e.what();
  }
}

}  // namespace
