// Real data: Bitcraze's Crazyflie 2.1 thrust-stand logs (tests/lab/data, MIT licence). The force follows
// pwm * vbat; the `voltage` effect must lower the error against a PWM-only curve, and a direct fit
// equals the ladder that adds its effects one by one.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "lab/analysis.hpp"
#include "lab/dataset.hpp"
#include "lab/model.hpp"

namespace {

lab::Dataset crazyflie() {
  const std::string dir = THRUSTCAL_LAB_CF_DIR;
  lab::ReadOptions ro;
  ro.maps = {lab::parseColumnMap("force_g=weight[g]/4"), lab::parseColumnMap("pwm_us=pwm"),
             lab::parseColumnMap("vbat_v=vbat[V]")};
  lab::Dataset d = lab::readFiles({dir + "/cf2.1-stock-prop.csv", dir + "/cf21_stock2.csv"}, ro);
  lab::addDerivedColumns(d);
  return d;
}

bool haveData() { return std::filesystem::exists(std::string(THRUSTCAL_LAB_CF_DIR) + "/cf21_stock2.csv"); }

TEST(LabCrazyflie, VoltageEffectLowersTheErrorAgainstAPwmOnlyCurve) {
  if (!haveData()) GTEST_SKIP() << "no Crazyflie data at " << THRUSTCAL_LAB_CF_DIR;
  // given both real logs (two runs, 4308 samples) and a PWM-only model with the lag they show
  const lab::Dataset d = crazyflie();
  ASSERT_EQ(d.rows(), 2573u + 1735u);
  // when the ladder adds `voltage`
  const auto steps = lab::ladder(d, lab::parseSpec("curve+deadband+lag"), {"voltage"}, lab::Holdout::kNone);
  // then the error falls and BIC says the voltage exponent earns its parameter
  EXPECT_LT(steps[1].fit.rmse_g, 0.95 * steps[0].fit.rmse_g)
      << steps[0].fit.rmse_g << " -> " << steps[1].fit.rmse_g;
  EXPECT_TRUE(steps[1].earns);
  EXPECT_LT(steps[1].delta_bic, -100.0);
}

TEST(LabCrazyflie, DiagnosisOfAPwmOnlyCurveBlamesTheLagFirst) {
  if (!haveData()) GTEST_SKIP() << "no Crazyflie data at " << THRUSTCAL_LAB_CF_DIR;
  const lab::Dataset d = crazyflie();
  const lab::Diagnosis diag = lab::diagnose(d, lab::parseSpec("curve+deadband"), lab::Holdout::kNone);
  ASSERT_FALSE(diag.variables.empty());
  EXPECT_EQ(diag.variables.front().variable, "dpwm_us");
  EXPECT_EQ(diag.variables.front().effects.front(), "lag");
}

double paramCrazyflie(const lab::FitResult& f, const std::string& name) {
  for (const auto& p : f.params)
    if (p.name == name) return p.value;
  return NAN;
}

TEST(LabCrazyflie, DirectFitOfCurveLagVoltageEqualsTheLadder) {
  if (!haveData()) GTEST_SKIP() << "no Crazyflie data at " << THRUSTCAL_LAB_CF_DIR;
  // given the real logs; measured before: the direct fit stopped with gamma at its bound 0
  // (0.148 g) where the ladder reached 0.128 g
  const lab::Dataset d = crazyflie();
  // when fitted directly and by the ladder curve -> +lag -> +voltage
  const lab::FitResult direct = lab::fitModel(d, lab::parseSpec("curve+lag+voltage"));
  const auto steps = lab::ladder(d, lab::parseSpec("curve"), {"lag", "voltage"}, lab::Holdout::kNone);
  // then both give the same fit, gamma inside its range
  EXPECT_NEAR(direct.rmse_g, steps[2].fit.rmse_g, 1e-9 * steps[2].fit.rmse_g);
  EXPECT_NEAR(paramCrazyflie(direct, "gamma"), paramCrazyflie(steps[2].fit, "gamma"), 1e-9);
  EXPECT_LT(direct.rmse_g, 0.130);
  EXPECT_GT(paramCrazyflie(direct, "gamma"), 0.5);
  for (const auto& p : direct.params) EXPECT_FALSE(p.at_bound) << p.name;
}

}  // namespace
