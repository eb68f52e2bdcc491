// The verdict against the noise floor, where the residual is, and the walk that follows the
// advice to the end, on generated data: clean data are at the floor with no suspect; a large
// residual no logged variable explains is unexplained, not noise; the regions say where it is;
// the walk drops a clipped reading and adds what the diagnosis names until the floor.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "lab/analysis.hpp"
#include "lab/generate.hpp"
#include "lab/model.hpp"

namespace {

lab::Dataset generated(const char* hidden) {
  lab::GenerateOptions o;
  o.hidden = hidden;
  o.noise_g = 0.5;
  lab::Dataset d = lab::generate(o);
  lab::addDerivedColumns(d);
  return d;
}

lab::Dataset without(const lab::Dataset& d, const std::string& column) {
  lab::Dataset out;
  out.run = d.run, out.run_labels = d.run_labels;
  for (std::size_t c = 0; c < d.names.size(); ++c)
    if (d.names[c] != column) out.set(d.names[c], d.columns[c]);
  return out;
}

TEST(LabVerdict, ALogWithNoHiddenEffectIsAtTheNoiseFloorWithNoSuspect) {
  const lab::Diagnosis d = lab::diagnose(generated("none"), lab::parseSpec("curve+deadband+voltage"), lab::Holdout::kNone);
  EXPECT_EQ(d.verdict, lab::Verdict::kAtNoiseFloor) << d.verdict_text;
  EXPECT_STREQ(lab::verdictName(d.verdict), "at_noise_floor");
  for (const auto& s : d.variables) EXPECT_FALSE(s.significant) << s.variable;
  EXPECT_TRUE(d.evidence.empty());
  EXPECT_TRUE(d.regions.empty());
  EXPECT_TRUE(d.next.add.empty() && d.next.where.empty());
  EXPECT_LT(d.unexplained_g, d.noise.sigma_g);
}

TEST(LabVerdict, ALargeResidualNoLoggedVariableExplainsIsUnexplainedNotNoise) {
  // given the deflector plate's ground effect with its height not logged: the force moves by
  // grams from point to point and nothing logged says why
  const lab::Dataset data = without(generated("plate"), "plate_height_m");
  const lab::Diagnosis d = lab::diagnose(data, lab::parseSpec("curve+deadband+voltage"), lab::Holdout::kNone);
  // then it is not called noise: the error is far above the floor, unexplained, and said so
  EXPECT_EQ(d.verdict, lab::Verdict::kUnexplained) << d.verdict_text;
  ASSERT_TRUE(d.noise.known());
  EXPECT_GT(d.fit.rmse_g, 1.3 * d.noise.hi_g);
  EXPECT_GT(d.unexplained_g, 3.0);
  EXPECT_NE(d.verdict_text.find("no logged variable explains it"), std::string::npos) << d.verdict_text;
}

TEST(LabVerdict, SuspectsWhenALoggedVariableExplainsTheResidual) {
  const lab::Diagnosis d = lab::diagnose(generated("sag"), lab::parseSpec("curve+deadband+voltage"), lab::Holdout::kNone);
  EXPECT_EQ(d.verdict, lab::Verdict::kSuspects) << d.verdict_text;
  EXPECT_EQ(d.next.add, "sag");
  EXPECT_GT(d.unexplained_g, 10.0);
}

TEST(LabRegions, TheResidualIsFoundWhereItIsAlongTheDriveAndAtItsVoltage) {
  // given clean sweeps whose force falls above 1700 us in the lowest-voltage run only (a limit
  // there), which a model that rises with the drive cannot follow
  lab::Dataset d = generated("none");
  const auto& v = d.col("vbat_v");
  const auto& p = d.col("pwm_us");
  const double lowest = *std::min_element(v.begin(), v.end());
  int low_run = -1;
  for (std::size_t i = 0; i < d.rows(); ++i)
    if (v[i] == lowest) low_run = d.run[i];
  double at_1700 = 0;
  for (std::size_t i = 0; i < d.rows(); ++i)
    if (d.run[i] == low_run && p[i] == 1700) at_1700 = d.col("force_g")[i];
  std::vector<double> f = d.col("force_g");
  for (std::size_t i = 0; i < d.rows(); ++i)
    if (d.run[i] == low_run && p[i] > 1700) f[i] = at_1700 * (1.0 - (p[i] - 1700) / 500.0);
  d.set("force_g", f);
  const lab::FitResult fit = lab::fitModel(d, lab::parseSpec("curve+deadband+voltage"));
  const auto regions = lab::residualRegions(d, fit, lab::estimateNoise(d));
  // then the first region is that corner: above 1700 us, at that run's voltage level, most of
  // the residual in few rows
  ASSERT_FALSE(regions.empty());
  const lab::Region& r = regions.front();
  EXPECT_GE(r.pwm_lo_us, 1700);
  EXPECT_GT(r.share, 0.4) << r.text;
  EXPECT_LT(r.rows_share, 0.1) << r.text;
  ASSERT_TRUE(std::isfinite(r.vbat_v)) << r.text;
  EXPECT_LT(r.vbat_v, 10.6) << r.text;
  EXPECT_NE(r.text.find(" us at "), std::string::npos) << r.text;
}

TEST(LabWalk, FollowsTheAdviceToTheNoiseFloorOnACurrentLimitedBench) {
  // given the limited supply at its highest and lowest set voltage (two runs keep the test quick)
  const lab::Dataset all = generated("current_limit");
  std::vector<bool> keep(all.rows());
  for (std::size_t i = 0; i < all.rows(); ++i) keep[i] = all.run[i] == 0 || all.run[i] == 3;
  lab::Dataset two = all.subset(keep);
  const lab::Walk w = lab::walk(two, lab::parseSpec("curve"));
  ASSERT_FALSE(w.steps.empty());
  EXPECT_EQ(w.steps.back().verdict, lab::Verdict::kAtNoiseFloor) << w.stop;
  EXPECT_NE(std::find(w.adds.begin(), w.adds.end(), "current_limit"), w.adds.end());
  EXPECT_NE(std::find(w.adds.begin(), w.adds.end(), "voltage"), w.adds.end());
  ASSERT_EQ(w.ladder.size(), w.adds.size() + 1);
  EXPECT_TRUE(w.ladder.back().at_noise_floor);
  for (std::size_t k = 1; k < w.ladder.size(); ++k) EXPECT_TRUE(w.ladder[k].earns) << w.ladder[k].added;
}

TEST(LabWalk, DropsTheRowsOfAClippedReadingBeforeModelling) {
  // given a load cell that reads no more than 600 g
  lab::Dataset d = generated("none");
  std::vector<double> f = d.col("force_g");
  for (auto& x : f) x = std::min(x, 600.0);
  d.set("force_g", f);
  const lab::Walk w = lab::walk(d, lab::parseSpec("curve+deadband+voltage"));
  ASSERT_GE(w.steps.size(), 2u);
  EXPECT_EQ(w.steps.front().advice.where, "force_g < 594");
  EXPECT_EQ(w.where, "force_g < 594");
  EXPECT_LT(w.data.rows(), d.rows());
  EXPECT_EQ(w.steps.back().verdict, lab::Verdict::kAtNoiseFloor) << w.stop;
  EXPECT_TRUE(w.adds.empty()) << "nothing else was wrong";
}

}  // namespace
