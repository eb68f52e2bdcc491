// The lab learns dynamics (issue 26): it reads step logs (the project CSV with t_s, a captured
// session, any `time` column), names the lag when a step log's residual shows it, fits each
// motor's time constants up and down within 5 % of the plant's own, and says in words when the
// spin-down is slower than the spin-up. The step log is made once by the plant (`lab generate
// --hidden lag`) and shared by the tests.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "lab/analysis.hpp"
#include "lab/generate.hpp"
#include "lab/model.hpp"
#include "lab/steps.hpp"
#include "lab_cli_run.hpp"

namespace {

lab::GenerateOptions stepLogOptions() {
  lab::GenerateOptions o;
  o.hidden = "lag";
  o.noise_g = 0.5;
  o.seed = 3;
  return o;
}

// One motor's rows of a step log.
lab::Dataset motorRows(const lab::Dataset& d, int motor) {
  std::vector<bool> keep(d.rows());
  for (std::size_t i = 0; i < d.rows(); ++i) keep[i] = d.col("motor")[i] == motor;
  return d.subset(keep);
}

// The step log (two motors), each motor's rows fitted with `lag`, made once.
struct StepLog {
  lab::Dataset data;
  std::vector<lab::FitResult> per_motor;
  std::vector<lab::StepTruth> truth;
};
const StepLog& stepLog() {
  static const StepLog log = [] {
    StepLog s;
    s.data = lab::generate(stepLogOptions());
    lab::addDerivedColumns(s.data);
    for (int m = 0; m < 2; ++m) s.per_motor.push_back(lab::fitModel(motorRows(s.data, m), lab::parseSpec("curve+lag")));
    s.truth = lab::stepTruth(stepLogOptions());
    return s;
  }();
  return log;
}

TEST(LabDynamics, APlantStepLogIsAStepLogAndASweepIsNot) {
  EXPECT_TRUE(lab::isStepLog(stepLog().data));
  lab::GenerateOptions sweep;
  sweep.noise_g = 0.5;
  EXPECT_FALSE(lab::isStepLog(lab::generate(sweep)));
}

TEST(LabDynamics, EachMotorsTimeConstantsUpAndDownAreThePlantsWithin5Percent) {
  // given the plant's step log of two motors (3 % part variation) and the plant's own time
  // constants for the log's 100 us steps
  const StepLog& s = stepLog();
  ASSERT_EQ(s.truth.size(), 2u);
  for (const auto& t : s.truth) {
    // when curve+lag is fitted to the motor's rows, then its tau_up and tau_down are within 5 %
    const auto dyn = lab::dynamicsOf(s.per_motor[static_cast<std::size_t>(t.motor)]);
    ASSERT_EQ(dyn.size(), 1u);
    EXPECT_NEAR(dyn[0].tau_up_s, t.tau_up_s, 0.05 * t.tau_up_s) << "motor " << t.motor;
    EXPECT_NEAR(dyn[0].tau_down_s, t.tau_down_s, 0.05 * t.tau_down_s) << "motor " << t.motor;
    EXPECT_GT(dyn[0].tau_up_sigma_s, 0);
    EXPECT_LT(dyn[0].tau_up_sigma_s, 0.02 * dyn[0].tau_up_s);
  }
}

TEST(LabDynamics, ASpinDownSlowerThanTheSpinUpIsSaidInWords) {
  // given the plant's step log (its ESC does not brake: the rotor slows by the propeller's drag)
  for (const auto& fit : stepLog().per_motor)
    for (const auto& d : lab::dynamicsOf(fit)) {
      // then each motor's spin-down is diagnosed as slower, in words
      EXPECT_EQ(d.asymmetry, 1) << d.text;
      EXPECT_NE(d.text.find("spin-down is slower than spin-up"), std::string::npos) << d.text;
      EXPECT_NE(d.text.find("does not brake"), std::string::npos) << d.text;
    }
}

TEST(LabDynamics, ALogOfSeveralMotorsGetsTimeConstantsPerMotor) {
  // given both motors' rows in one fit (their static difference left to `motor`)
  const lab::FitResult f = lab::fitModel(stepLog().data, lab::parseSpec("curve+motor+lag"), nullptr, false, false);
  // then the lag has an up and a down time constant per motor, named after the motor
  std::set<std::string> names;
  for (const auto& p : f.params)
    if (p.effect == "lag") names.insert(p.name);
  EXPECT_EQ(names, (std::set<std::string>{"tau_up_s_motor_0", "tau_down_s_motor_0", "tau_up_s_motor_1",
                                          "tau_down_s_motor_1"}));
  const auto dyn = lab::dynamicsOf(f);
  ASSERT_EQ(dyn.size(), 2u);
  EXPECT_EQ(dyn[0].motor, "0");
  EXPECT_EQ(dyn[1].motor, "1");
}

TEST(LabDynamics, TheDiagnosisOfAStepLogWithoutLagNamesTheLag) {
  // given one motor's step log and a static model
  const StepLog& s = stepLog();
  const lab::Dataset d = motorRows(s.data, 0);
  const lab::FitResult fit = lab::fitModel(d, lab::parseSpec("curve"));
  const auto vars = lab::rankVariables(d, fit, lab::parseSpec("curve"));
  // then the first suspect is significant and its effect is `lag`
  ASSERT_FALSE(vars.empty());
  EXPECT_TRUE(vars.front().significant) << vars.front().variable;
  ASSERT_FALSE(vars.front().effects.empty()) << vars.front().variable;
  EXPECT_EQ(vars.front().effects.front(), "lag") << vars.front().variable << ": " << vars.front().advice;
  // and the lag cuts the error to a few times the noise
  EXPECT_LT(s.per_motor[0].rmse_g, 0.1 * fit.rmse_g) << fit.rmse_g << " -> " << s.per_motor[0].rmse_g;
}

TEST(LabDynamics, ASweepKeepsOneTimeConstant) {
  // given a sweep (one row per set point at the end of its settling)
  lab::GenerateOptions o;
  o.noise_g = 0.5;
  lab::Dataset d = lab::generate(o);
  const lab::FitResult f = lab::fitModel(d, lab::parseSpec("curve+deadband+voltage+lag"));
  bool tau = false, up = false;
  for (const auto& p : f.params) tau = tau || p.name == "tau_s", up = up || p.name.rfind("tau_up", 0) == 0;
  EXPECT_TRUE(tau);
  EXPECT_FALSE(up);
  EXPECT_TRUE(lab::dynamicsOf(f).empty());
}

TEST(LabDynamics, ATimeColumnUnderItsUsualNamesIsTheTime) {
  // given a step log's time under the names loggers give it, in seconds or milliseconds
  for (const auto& [name, scale] : std::vector<std::pair<std::string, double>>{
           {"time", 1.0}, {"Time (s)", 1.0}, {"time_ms", 1e-3}, {"t_ms", 1e-3}, {"Time (ms)", 1e-3},
           {"time_us", 1e-6}, {"t_us", 1e-6}, {"Time (us)", 1e-6}, {"Time (\u00b5s)", 1e-6},
           {"timestamp (ms)", 1e-3}, {"timestamp_us", 1e-6}, {"timestamp_ms", 1e-3}, {"timestamp_s", 1.0}}) {
    const std::string csv = name + ",pwm_us,force_g\n0,1500,100\n10,1500,101\n20,1550,120\n";
    const lab::Dataset d = lab::parseText(csv, "steps.csv", lab::ReadOptions());
    // then it is t_s in seconds
    ASSERT_TRUE(d.has("t_s")) << name;
    EXPECT_DOUBLE_EQ(d.col("t_s")[2], 20 * scale) << name;
  }
}

TEST(LabDynamics, ATimestampWithoutUnitIsNotGuessedButSaysHowToMapIt) {
  // given a log stamped in microseconds under a bare `timestamp` (as PX4 writes it)
  const std::string csv = "timestamp,pwm_us,force_g\n0,1500,100\n2000,1500,101\n4000,1550,120\n";
  const lab::Dataset d = lab::parseText(csv, "steps.csv", lab::ReadOptions());
  // then it is not the time, and a note says how to make it one
  EXPECT_FALSE(d.has("t_s"));
  bool said = false;
  for (const std::string& n : d.notes) said = said || n.find("--map t_s=timestamp/1000000") != std::string::npos;
  EXPECT_TRUE(said);
  // when mapped as the note says, it is the time in seconds
  lab::ReadOptions o;
  o.maps.push_back(lab::parseColumnMap("t_s=timestamp/1000000"));
  const lab::Dataset m = lab::parseText(csv, "steps.csv", o);
  ASSERT_TRUE(m.has("t_s"));
  EXPECT_DOUBLE_EQ(m.col("t_s")[2], 0.004);
}

TEST(LabDynamics, DiagnoseJsonCarriesEachMotorsDynamicsAndTheFloorsEstimator) {
  // given the step log written as the project's CSV (a bench's dynamics session)
  std::vector<std::string> comments;
  const lab::Dataset d = lab::generate(stepLogOptions(), &comments);
  const std::string path = std::string(THRUSTCAL_LAB_TMP_DIR) + "/steps.csv";
  std::filesystem::create_directories(THRUSTCAL_LAB_TMP_DIR);
  std::ofstream(path) << lab::toCsv(d, comments);
  // when one motor's rows are diagnosed with the lag in the model
  const auto r = labtest::runLabCli(
      {"lab", "diagnose", path, "--model", "curve+lag", "--where", "motor == 1", "--json"});
  ASSERT_EQ(r.rc, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  // then the JSON has its time constants, spin-down slower, and the pure-error floor
  ASSERT_EQ(j["dynamics"].size(), 1u) << r.out.substr(0, 2000);
  for (const auto& m : j["dynamics"]) {
    EXPECT_EQ(m["spin_down"], "slower");
    EXPECT_GT(m["tau_down_s"].get<double>(), m["tau_up_s"].get<double>());
  }
  EXPECT_EQ(j["noise"]["estimator"], "pure_error");
  EXPECT_NEAR(j["noise_g"].get<double>(), 0.5, 0.1);
  EXPECT_TRUE(j["noise"]["lack_of_fit"]["tested"].get<bool>());
}

}  // namespace
