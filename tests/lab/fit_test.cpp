// Fitting: the numerical helpers, model SPECs, user expressions, parameter recovery with
// uncertainties, hold-out validation, and the thesis model evaluated through core/.
#include <gtest/gtest.h>

#include <cmath>

#include "lab/analysis.hpp"
#include "lab/generate.hpp"
#include "lab/model.hpp"
#include "lab/stats.hpp"

namespace {

TEST(LabStats, NnlsMatchesLeastSquaresWhenTheConstraintIsInactiveAndClampsWhenActive) {
  Eigen::MatrixXd A(4, 2);
  A << 1, 0, 1, 1, 1, 2, 1, 3;
  // y = 1 + 2x: both coefficients positive -> plain least squares
  Eigen::VectorXd y(4);
  y << 1, 3, 5, 7;
  Eigen::VectorXd x = lab::nnls(A, y, {false, true});
  EXPECT_NEAR(x[0], 1, 1e-9);
  EXPECT_NEAR(x[1], 2, 1e-9);
  // y = 5 - x: the slope wants to be negative -> clamped to 0, the free intercept is the mean
  y << 5, 4, 3, 2;
  x = lab::nnls(A, y, {false, true});
  EXPECT_NEAR(x[1], 0, 1e-12);
  EXPECT_NEAR(x[0], 3.5, 1e-9);
}

TEST(LabStats, FSurvivalMatchesTabulatedQuantiles) {
  // F(1, 10) 0.05 quantile 4.965; F(3, 100) 0.01 quantile 3.984
  EXPECT_NEAR(lab::fSurvival(4.965, 1, 10), 0.05, 5e-4);
  EXPECT_NEAR(lab::fSurvival(3.984, 3, 100), 0.01, 2e-4);
  EXPECT_DOUBLE_EQ(lab::fSurvival(0, 2, 10), 1.0);
}

TEST(LabSpec, ParsesCatalogueNamesAndUserExpressions) {
  const auto s = lab::parseSpec("curve+deadband+voltage+mul: 1 + a*(temp_c - 25);add: b*t_s");
  EXPECT_EQ(s.effects, (std::vector<std::string>{"curve", "deadband", "voltage"}));
  ASSERT_EQ(s.user.size(), 2u);
  EXPECT_TRUE(s.user[0].multiplicative);
  EXPECT_EQ(s.user[0].expression, "1 + a*(temp_c - 25)");
  EXPECT_FALSE(s.user[1].multiplicative);
}

TEST(LabSpec, RejectsUnknownEffectsListingTheCatalogue) {
  try {
    lab::parseSpec("curve+voltge");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("voltge"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("deadband"), std::string::npos);
  }
  EXPECT_THROW(lab::parseSpec(""), std::invalid_argument);
  EXPECT_THROW(lab::parseSpec("mul:"), std::invalid_argument);
}

TEST(LabCatalogue, DocumentsEveryEffectWithPhysicsColumnsAndParameters) {
  for (const char* name : {"curve", "deadband", "voltage", "sag", "motor", "drift", "lag", "thermal",
                           "density", "thesis", "mul: EXPR", "add: EXPR"}) {
    const lab::EffectInfo* e = lab::findEffect(name);
    ASSERT_NE(e, nullptr) << name;
    EXPECT_GT(e->physics.size(), 40u) << name;
    EXPECT_FALSE(e->columns.empty()) << name;
    EXPECT_FALSE(e->parameters.empty()) << name;
  }
}

lab::Dataset generatedFit(const char* hidden, double noise_g = 0.5) {
  lab::GenerateOptions o;
  o.hidden = hidden;
  o.noise_g = noise_g;
  o.seed = 1;
  lab::Dataset d = lab::generate(o);
  lab::addDerivedColumns(d);
  return d;
}

TEST(LabFit, UserExpressionRecoversTheGroundEffectConstantWithItsUncertainty) {
  // given data with a plate under the propeller: F x 1/(1 - (R/4z)^2), R = 0.1143 m
  const lab::Dataset d = generatedFit("plate");
  // when the ground effect is fitted as a user expression with a free parameter k
  const auto fit = lab::fitModel(d, lab::parseSpec("curve+deadband+voltage+mul: 1/(1 - k/plate_height_m^2)"));
  // then k = (R/4)^2 within three standard uncertainties, and the uncertainty is small
  const double k_true = std::pow(0.2286 / 2 / 4, 2);
  const lab::Param* k = nullptr;
  for (const auto& p : fit.params)
    if (p.name == "k") k = &p;
  ASSERT_NE(k, nullptr);
  EXPECT_GT(k->sigma, 0);
  EXPECT_LT(k->sigma, 0.1 * k_true);
  EXPECT_NEAR(k->value, k_true, 3 * k->sigma + 0.02 * k_true);
}

TEST(LabFit, DeadbandAndVoltageRecoverThePlantsEscStartAndAnIdealMotorExponent) {
  // given the plant's ESC starting at 1097 us (plus the no-load current's share) and force
  // following duty * V
  const lab::Dataset d = generatedFit("none");
  const auto fit = lab::fitModel(d, lab::parseSpec("curve+deadband+voltage"));
  double start = 0, gamma = 0;
  for (const auto& p : fit.params) {
    if (p.name == "pwm_start_us") start = p.value;
    if (p.name == "gamma") gamma = p.value;
  }
  EXPECT_NEAR(start, 1100, 6);
  EXPECT_NEAR(gamma, 1.0, 0.03);
  EXPECT_LT(fit.rmse_g, 1.2 * 0.5);
}

TEST(LabFit, ExpressionWithoutFreeParameterOrWithBadSyntaxIsRefusedClearly) {
  const lab::Dataset d = generatedFit("none");
  EXPECT_THROW(lab::fitModel(d, lab::parseSpec("curve+mul: 1 + vbat_v")), std::invalid_argument);
  EXPECT_THROW(lab::fitModel(d, lab::parseSpec("curve+mul: 1 + (a*")), std::invalid_argument);
  EXPECT_THROW(lab::fitModel(d, lab::parseSpec("curve+density")), std::invalid_argument);
}

TEST(LabFit, HoldingOutVoltagesValidatesTheVoltageEffect) {
  // given four runs at four bench voltages
  const lab::Dataset d = generatedFit("none");
  int groups = 0;
  // when each voltage is predicted by a model fitted on the other three
  const double with_voltage = lab::holdoutRmse(d, lab::parseSpec("curve+deadband+voltage"), lab::Holdout::kVoltage, &groups);
  const double pwm_only = lab::holdoutRmse(d, lab::parseSpec("curve+deadband"), lab::Holdout::kVoltage);
  // then the voltage model predicts unseen voltages near the noise, the PWM-only one does not
  EXPECT_EQ(groups, 4);
  EXPECT_LT(with_voltage, 3 * 0.5);
  EXPECT_GT(pwm_only, 5 * with_voltage);
}

TEST(LabThesis, TwoCurveModelThroughCoreFollowsTheDataNearItsCalibrationVoltages) {
  // given sweeps at four voltages (the thesis model takes the highest and the most different),
  // within the thesis curve's 500 g
  const lab::Dataset all = generatedFit("none");
  std::vector<bool> keep(all.rows());
  for (std::size_t i = 0; i < all.rows(); ++i) keep[i] = all.col("force_g")[i] < 450;
  const lab::Dataset d = all.subset(keep);
  // when the thesis model is built and evaluated through core's forceToPwm
  const auto thesis = lab::fitModel(d, lab::parseSpec("thesis"));
  const auto curve = lab::fitModel(d, lab::parseSpec("curve"));
  // then it follows the data far better than one PWM curve for all voltages, but it is not the
  // noise floor: linear interpolation in voltage drifts between the calibration voltages
  EXPECT_LT(thesis.rmse_g, 0.5 * curve.rmse_g);
  EXPECT_GT(thesis.rmse_g, 1.0);
  EXPECT_THROW(lab::fitModel(d, lab::parseSpec("thesis+voltage")), std::invalid_argument);
}

}  // namespace

namespace {

TEST(LabFit, OddDataGivesAResultOrAClearRefusalNeverACrash) {
  // given small data sets a real log can turn into (one row, a motor that never started,
  // negative tare, zero volts, one PWM, absurd magnitudes)
  struct Odd {
    const char* name;
    std::vector<double> pwm, force, vbat;
  };
  const Odd cases[] = {
      {"one row", {1500}, {100}, {12}},
      {"motor never started", {1000, 1100, 1200, 1300}, {0, 0, 0, 0}, {12, 12, 12, 12}},
      {"negative tare", {1000, 1100, 1200, 1300}, {-50, -40, -20, 10}, {12, 12, 11, 11}},
      {"zero volts", {1000, 1100, 1200, 1300}, {0, 5, 20, 50}, {0, 0, 0, 0}},
      {"one pwm", {1500, 1500, 1500, 1500}, {100, 101, 99, 100}, {12, 11, 10, 9}},
      {"absurd", {1e9, -1e9, 0, 5}, {1e12, -1e12, 3, 4}, {1e6, -5, 0, 12}},
  };
  const char* models[] = {"curve", "curve+deadband+voltage+sag", "thesis", "curve+lag+drift+motor",
                          "curve+deadband+mul: 1 + a*vbat_v"};
  for (const auto& c : cases) {
    lab::Dataset d;
    d.names = {"pwm_us", "force_g", "vbat_v", "t_s", "motor"};
    std::vector<double> t, m;
    for (std::size_t i = 0; i < c.pwm.size(); ++i) {
      t.push_back(0.5 * static_cast<double>(i));
      m.push_back(static_cast<double>(i % 2));
    }
    d.columns = {c.pwm, c.force, c.vbat, t, m};
    d.run.assign(c.pwm.size(), 0);
    d.run_labels = {"odd"};
    lab::addDerivedColumns(d);
    for (const char* model : models) {
      // when diagnosed: then a diagnosis or std::invalid_argument, nothing else
      try {
        const lab::Diagnosis diag = lab::diagnose(d, lab::parseSpec(model), lab::Holdout::kRuns);
        EXPECT_EQ(diag.fit.n, c.pwm.size()) << c.name << " / " << model;
      } catch (const std::invalid_argument& e) {
        EXPECT_GT(std::string(e.what()).size(), 20u) << c.name << " / " << model;
      }
    }
  }
}

}  // namespace
