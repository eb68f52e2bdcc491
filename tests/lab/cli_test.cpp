// The command line as scripts use it: `thrustcal lab diagnose|ladder ... --json` shapes, several
// DATA files, --report files, clean errors.
#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "lab/cli.hpp"
#include "lab_cli_run.hpp"
#include "lab/effect.hpp"
#include "lab/dataset.hpp"
#include "lab/generate.hpp"
#include "lab/report.hpp"

namespace {

namespace fs = std::filesystem;

std::string tmpCli(const std::string& name) {
  fs::create_directories(THRUSTCAL_LAB_TMP_DIR);
  return std::string(THRUSTCAL_LAB_TMP_DIR) + "/" + name;
}

// Writes a generated log split into one file per run, as a bench session would leave them.
std::vector<std::string> writeRuns(const char* hidden) {
  lab::GenerateOptions o;
  o.hidden = hidden;
  o.noise_g = 0.5;
  const lab::Dataset d = lab::generate(o);
  std::vector<std::string> files;
  for (std::size_t r = 0; r < d.runs(); ++r) {
    std::vector<bool> keep(d.rows());
    for (std::size_t i = 0; i < d.rows(); ++i) keep[i] = d.run[i] == static_cast<int>(r);
    const std::string path = tmpCli(std::string(hidden) + "_run" + std::to_string(r) + ".csv");
    std::ofstream(path) << lab::toCsv(d.subset(keep), {"generated for cli_test"});
    files.push_back(path);
  }
  return files;
}

int run(std::vector<std::string> args, std::string& out) {
  const labtest::CliRun r = labtest::runLabCli(std::move(args));
  out = r.out;
  return r.rc;
}

TEST(LabCli, DiagnoseJsonHasTheIssueShapeWithSuspectsBestFirst) {
  // given four run files with a load-cell drift
  auto files = writeRuns("drift");
  std::vector<std::string> args = {"lab", "diagnose"};
  args.insert(args.end(), files.begin(), files.end());
  for (const char* a : {"--model", "curve+deadband+voltage", "--json"}) args.push_back(a);
  std::string out;
  // when diagnosed with --json
  ASSERT_EQ(run(args, out), 0);
  const auto j = nlohmann::json::parse(out);
  // then {"rmse_g": x, "n": N, "suspects": [{"variable", "score", "effects"}...]} best first
  EXPECT_GT(j.at("rmse_g").get<double>(), 1.0);
  EXPECT_EQ(j.at("n").get<int>(), 296);
  EXPECT_EQ(j.at("runs").get<int>(), 4);
  const auto& s = j.at("suspects");
  ASSERT_GE(s.size(), 1u);
  EXPECT_EQ(s[0].at("variable"), "t_s");
  EXPECT_EQ(s[0].at("effects")[0], "drift");
  for (std::size_t i = 1; i < s.size(); ++i)
    if (s[i].at("variable") != "run") {
      EXPECT_GE(s[i - 1].at("score").get<double>(), s[i].at("score").get<double>());
    }
}

TEST(LabCli, LadderJsonListsTheStepsInOrderAndTheReportIsWritten) {
  auto files = writeRuns("sag");
  const std::string dir = tmpCli("report_sag");
  fs::remove_all(dir);
  std::vector<std::string> args = {"lab", "ladder"};
  args.insert(args.end(), files.begin(), files.end());
  for (const char* a : {"--model", "curve", "--add", "deadband", "--add", "voltage", "--add", "sag", "--json", "--report"})
    args.push_back(a);
  args.push_back(dir);
  std::string out;
  ASSERT_EQ(run(args, out), 0);
  const auto j = nlohmann::json::parse(out);
  const auto& steps = j.at("steps");
  ASSERT_EQ(steps.size(), 4u);
  EXPECT_EQ(steps[0].at("model"), "curve");
  EXPECT_EQ(steps[3].at("model"), "curve+deadband+voltage+sag");
  EXPECT_LT(steps[3].at("rmse_g").get<double>(), steps[0].at("rmse_g").get<double>() / 3);
  EXPECT_TRUE(steps[3].contains("bic"));
  // the report: a page, and each plot as PNG and SVG
  EXPECT_TRUE(fs::exists(dir + "/report.md"));
  for (const char* img : {"ladder", "measured_vs_model", "residual_vs_vbat_v"}) {
    for (const char* ext : {".png", ".svg"}) {
      const std::string p = dir + "/" + img + ext;
      ASSERT_TRUE(fs::exists(p)) << p;
      EXPECT_GT(fs::file_size(p), 1000u) << p;
    }
  }
}

TEST(LabCli, DiagnoseJsonHasTheNoiseFloorTheVerdictWhereTheResidualIsAndTheEvidence) {
  // given four run files from a current-limited bench supply
  auto files = writeRuns("current_limit");
  std::vector<std::string> args = {"lab", "diagnose"};
  args.insert(args.end(), files.begin(), files.end());
  for (const char* a : {"--model", "curve+deadband+voltage", "--json"}) args.push_back(a);
  std::string out;
  ASSERT_EQ(run(args, out), 0);
  const auto j = nlohmann::json::parse(out);
  // then the fields scripts use stay, and the new ones are there
  for (const char* k : {"rmse_g", "n", "suspects"}) EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_NEAR(j.at("noise_g").get<double>(), 0.5, 0.1);
  ASSERT_EQ(j.at("noise_g_ci").size(), 2u);
  EXPECT_LT(j.at("noise_g_ci")[0].get<double>(), j.at("noise_g").get<double>());
  EXPECT_GT(j.at("noise_g_ci")[1].get<double>(), j.at("noise_g").get<double>());
  EXPECT_EQ(j.at("verdict"), "suspects");
  EXPECT_GT(j.at("unexplained_g").get<double>(), 10.0);
  ASSERT_FALSE(j.at("regions").empty());
  EXPECT_GT(j.at("regions")[0].at("pwm_lo_us").get<double>(), 1500);
  ASSERT_FALSE(j.at("evidence").empty());
  EXPECT_EQ(j.at("evidence")[0].at("kind"), "current_plateau");
  EXPECT_NEAR(j.at("evidence")[0].at("level").get<double>(), 6.32, 0.02);
  EXPECT_EQ(j.at("evidence")[0].at("effects")[0], "current_limit");
  EXPECT_EQ(j.at("next").at("add"), "current_limit");
  // current is evidence, never a suspect to model with
  for (const auto& s : j.at("suspects")) EXPECT_NE(s.at("variable"), "current_a");
}

TEST(LabCli, LadderAndWalkJsonCarryTheNoiseFloor) {
  auto files = writeRuns("current_limit");
  files = {files.front(), files.back()};  // the highest and the lowest set voltage: enough, and quick
  std::vector<std::string> ladder = {"lab", "ladder"}, walk = {"lab", "walk"};
  ladder.insert(ladder.end(), files.begin(), files.end());
  walk.insert(walk.end(), files.begin(), files.end());
  for (const char* a : {"--model", "curve+deadband+voltage", "--add", "current_limit", "--json"}) ladder.push_back(a);
  for (const char* a : {"--model", "curve+deadband+voltage", "--json"}) walk.push_back(a);  // the short walk
  std::string out;
  ASSERT_EQ(run(ladder, out), 0);
  auto j = nlohmann::json::parse(out);
  EXPECT_GT(j.at("noise_g").get<double>(), 0.3);
  EXPECT_FALSE(j.at("steps")[0].at("at_noise_floor").get<bool>());
  EXPECT_TRUE(j.at("steps")[1].at("earns").get<bool>());
  ASSERT_EQ(run(walk, out), 0);
  j = nlohmann::json::parse(out);
  EXPECT_EQ(j.at("verdict"), "at_noise_floor");
  EXPECT_EQ(j.at("walk").back().at("verdict"), "at_noise_floor");
  EXPECT_NE(std::find(j.at("adds").begin(), j.at("adds").end(), "current_limit"), j.at("adds").end());
  EXPECT_TRUE(j.at("ladder").at("steps").back().at("at_noise_floor").get<bool>());
}

TEST(LabCli, BadInputIsAnErrorExitNotACrash) {
  const std::string bad = tmpCli("bad.csv");
  std::ofstream(bad) << "pwm_us,force_g\n1000,1\n1100,x\n";
  const labtest::CliRun bad_cell = labtest::runLabCli({"lab", "diagnose", bad, "--model", "curve"});
  EXPECT_NE(bad_cell.rc, 0);
  EXPECT_NE(bad_cell.err.find("bad.csv:3:6"), std::string::npos) << bad_cell.err;
  EXPECT_NE(labtest::runLabCli({"lab", "diagnose", bad, "--model", "nonsense"}).rc, 0);
}

// The sag data as an RCbenchmark 1585 export (thrust logged negative in newtons, App message),
// logged at `log_hz` while each point settles (0: one row per point).
std::string standFile(const std::string& name, double log_hz = 0) {
  lab::GenerateOptions o;
  o.hidden = "sag";
  o.noise_g = 0.5;
  o.log_hz = log_hz;
  lab::StandLayout l;
  l.series = "1585";
  l.thrust_unit = "N";
  l.negative_thrust = true;
  const std::string path = tmpCli(name);
  std::ofstream(path) << lab::toStandCsv(lab::generate(o), l);
  return path;
}

bool contains(const nlohmann::json& list, const std::string& text) {
  for (const auto& n : list)
    if (n.get<std::string>().find(text) != std::string::npos) return true;
  return false;
}

TEST(LabCli, EveryReaderNoteAndDataWarningIsInTheJson) {
  // given a raw RCbenchmark export, rows selected with --where
  const std::string file = standFile("stand_notes.csv");
  std::string out;
  ASSERT_EQ(run({"lab", "diagnose", file, "--model", "curve+deadband+voltage", "--where", "pwm_us < 1800 and t_s >= 0",
                 "--json"},
                out),
            0);
  const auto j = nlohmann::json::parse(out);
  // then the sign flip, the text and empty columns and the selection are in "notes"
  EXPECT_TRUE(contains(j.at("notes"), "sign flipped")) << j.at("notes").dump();
  EXPECT_TRUE(contains(j.at("notes"), "'App message' holds text ('Tare done'"));
  EXPECT_TRUE(contains(j.at("notes"), "are empty; ignored"));
  EXPECT_TRUE(contains(j.at("notes"), "--where 'pwm_us < 1800 and t_s >= 0': kept 256 of 296 rows, dropped 40"))
      << j.at("notes").dump();
  // and the responses are listed apart from the suspects
  EXPECT_TRUE(contains(j.at("responses"), "current_a"));
  EXPECT_TRUE(contains(j.at("responses"), "torque_nm"));
  for (const auto& s : j.at("suspects")) EXPECT_NE(s.at("variable"), "current_a");
}

TEST(LabCli, HoldoutOnOneRunIsAnErrorNotNan) {
  const std::string file = standFile("stand_one_run.csv");
  const labtest::CliRun r = labtest::runLabCli({"lab", "diagnose", file, "--model", "curve+deadband", "--holdout", "runs"});
  EXPECT_EQ(r.rc, 2);
  EXPECT_NE(r.err.find("needs at least two runs"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("nan"), std::string::npos) << r.out;
}

TEST(LabCli, ReportIsOneSelfContainedPageWithUnitsAndStaysSmallOnLargeData) {
  // given 14,800 rows (each point logged at 100 Hz while it settles) in the 1585 layout
  const std::string file = standFile("stand_100hz.csv", 100);
  const std::string dir = tmpCli("report_100hz");
  fs::remove_all(dir);
  std::string out;
  // when the ladder writes its report
  ASSERT_EQ(run({"lab", "ladder", file, "--model", "curve+deadband+voltage", "--add", "sag", "--report", dir, "--json"},
                out),
            0);
  const auto j = nlohmann::json::parse(out);
  // then report.html carries every plot inside, and the whole report is small
  std::ifstream html_file(dir + "/report.html");
  const std::string html((std::istreambuf_iterator<char>(html_file)), std::istreambuf_iterator<char>());
  EXPECT_NE(html.find("<img alt=\"ladder\" src=\"data:image/png;base64,"), std::string::npos);
  EXPECT_EQ(html.find("src=\"ladder.png\""), std::string::npos);
  EXPECT_LT(j.at("report").at("bytes").get<double>(), 20e6);
  std::uintmax_t total = 0;
  for (const auto& e : fs::directory_iterator(dir)) total += fs::file_size(e.path());
  EXPECT_LT(total, 20u * 1000u * 1000u);
  // the plots' axes carry the file's names and units, and the samples are thinned
  std::ifstream gp_file(dir + "/plots.gp");
  const std::string gp((std::istreambuf_iterator<char>(gp_file)), std::istreambuf_iterator<char>());
  EXPECT_NE(gp.find("set xlabel 'ESC signal (\xC2\xB5s)'"), std::string::npos);
  EXPECT_NE(gp.find("set ylabel 'Thrust (g), logged in N'"), std::string::npos);
  EXPECT_NE(gp.find("of 14800 samples shown"), std::string::npos);
  std::ifstream tsv(dir + "/data.tsv");
  std::size_t lines = 0;
  for (std::string l; std::getline(tsv, l);) ++lines;
  EXPECT_LE(lines, lab::kMaxPlotRows + 1);
  // and the ladder's verdicts are on the page
  std::ifstream md_file(dir + "/report.md");
  const std::string md((std::istreambuf_iterator<char>(md_file)), std::istreambuf_iterator<char>());
  EXPECT_NE(md.find("| verdict |"), std::string::npos) << md;
  EXPECT_NE(md.find("| earns its parameters |"), std::string::npos) << md;
}

TEST(LabCli, EffectsListingDocumentsTheWholeCatalogue) {
  std::string out;
  ASSERT_EQ(run({"lab", "effects"}, out), 0);
  for (const char* name : {"curve", "deadband", "voltage", "sag", "motor", "drift", "lag", "thermal", "density", "thesis", "mul: EXPR"})
    EXPECT_NE(out.find(std::string("\n  ") + name + "\n"), std::string::npos) << name;
  EXPECT_NE(out.find("[ohm]"), std::string::npos);
}

TEST(LabCli, EffectsListingDocumentsEveryRegisteredEffectAndParameter) {
  std::string out;
  ASSERT_EQ(run({"lab", "effects"}, out), 0);
  for (const auto* e : lab::effects::registry()) {
    EXPECT_NE(out.find("\n  " + e->name + "\n"), std::string::npos) << e->name;
    for (const auto& p : e->params) EXPECT_NE(out.find(p.name + " [" + p.unit + "]"), std::string::npos) << p.name;
  }
  std::string md;
  ASSERT_EQ(run({"lab", "effects", "--markdown"}, md), 0);
  EXPECT_EQ(md, lab::effects::markdownTable());
}

}  // namespace
