// The autopilots' thrust models fitted on generated data whose true curve is known, and
// `thrustcal lab export --to ...` end to end (the files the ground stations load, the comparison,
// the refusals). The models themselves against hand values: autopilot_test.cpp.
#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <cstdio>
#include <cstdlib>

#include "lab/autopilot.hpp"
#include "lab/autopilot_export.hpp"
#include "lab/cli.hpp"
#include "lab_cli_run.hpp"
#include "lab/dataset.hpp"
#include "lab/generate.hpp"

#include "autopilot_params.hpp"

namespace {

namespace fs = std::filesystem;
namespace ap = lab::autopilot;
namespace ardu = lab::autopilot::ardupilot;
namespace px4 = lab::autopilot::px4;
namespace bf = lab::autopilot::betaflight;

std::string tmpAutopilot(const std::string& name) {
  fs::create_directories(THRUSTCAL_LAB_TMP_DIR);
  return std::string(THRUSTCAL_LAB_TMP_DIR) + "/" + name;
}

std::string slurpAutopilot(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// ---- Fits on data whose true curve is known ---------------------------------------------------

// Rows from ArduPilot's own model with known parameters, at four voltages, with noise.
std::vector<ap::Row> fromArduPilot(const ap::ArduPilotParams& truth, double full_g, double noise_g, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, noise_g);
  std::vector<ap::Row> rows;
  for (double v : {10.2, 11.1, 12.0, 12.6})
    for (int pwm = 1000; pwm <= 2000; pwm += 20) {
      ap::Row r;
      r.pwm_us = pwm;
      r.vbat_v = v;
      r.force_g = full_g * ardu::thrustFraction(truth, pwm, v) + n(rng);
      rows.push_back(r);
    }
  return rows;
}

TEST(ArduPilotFit, RecoversTheParametersOfDataMadeByArduPilotsOwnModel) {
  struct Case {
    double expo, spin_min, spin_max;
  };
  const Case cases[] = {{0.65, 0.15, 0.95}, {0.42, 0.08, 0.92}, {0.85, 0.11, 1.0}, {-0.2, 0.05, 0.95}};
  for (const Case& c : cases) {
    ap::ArduPilotParams truth = ardu3s();
    truth.thst_expo = c.expo;
    truth.spin_min = c.spin_min;
    truth.spin_max = c.spin_max;
    ap::FitSetup setup;
    setup.cells = 3;
    const ap::ArduPilotFit fit = ap::fitArduPilot(fromArduPilot(truth, 900, 0.5, 7), setup);
    EXPECT_NEAR(fit.params.thst_expo, c.expo, 0.02) << c.expo;
    EXPECT_NEAR(fit.params.spin_min, c.spin_min, 0.002) << c.expo;
    EXPECT_NEAR(fit.params.spin_max, c.spin_max, 0.006) << c.expo;
    EXPECT_NEAR(fit.scale.full_g, 900, 9) << c.expo;
    EXPECT_DOUBLE_EQ(fit.params.bat_volt_max_v, 12.6);
  }
}

lab::Dataset generatedSet(const char* hidden, const std::string& path) {
  lab::GenerateOptions o;
  o.hidden = hidden;
  o.noise_g = 0.5;
  std::ofstream(path) << lab::toCsv(lab::generate(o), {"generated for autopilot_test"});
  return lab::readFiles({path}, lab::ReadOptions());
}

std::vector<ap::Row> rowsOf(const lab::Dataset& d) {
  std::vector<ap::Row> rows;
  for (std::size_t i = 0; i < d.rows(); ++i) {
    ap::Row r;
    r.pwm_us = d.col("pwm_us")[i];
    r.force_g = d.col("force_g")[i];
    r.vbat_v = d.has("vbat_v") ? d.col("vbat_v")[i] : NAN;
    rows.push_back(r);
  }
  return rows;
}

double rmsOf(const std::vector<ap::Row>& rows, const std::function<double(const ap::Row&)>& fraction) {
  return std::sqrt(ap::bestScale(rows, fraction).rss / static_cast<double>(rows.size()));
}

// The parameter file's NAME,VALUE (ArduPilot) lines.
std::map<std::string, double> parmFile(const std::string& text) {
  std::map<std::string, double> m;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    const auto comma = line.find(',');
    m[line.substr(0, comma)] = std::stod(line.substr(comma + 1));
  }
  return m;
}

// Minimum of f over a box by Nelder-Mead, coordinates clamped into the box.
template <typename F>
double nelderMead(std::vector<double> x0, const std::vector<double>& lo, const std::vector<double>& hi,
                  const std::vector<double>& step, F f) {
  const std::size_t n = x0.size();
  auto clampTo = [&](std::vector<double> x) {
    for (std::size_t k = 0; k < n; ++k) x[k] = std::clamp(x[k], lo[k], hi[k]);
    return x;
  };
  std::vector<std::vector<double>> s{clampTo(x0)};
  for (std::size_t k = 0; k < n; ++k) {
    auto x = x0;
    x[k] += step[k];
    s.push_back(clampTo(x));
  }
  std::vector<double> fs;
  for (auto& x : s) fs.push_back(f(x));
  for (int it = 0; it < 400; ++it) {
    std::vector<std::size_t> ord(n + 1);
    for (std::size_t k = 0; k <= n; ++k) ord[k] = k;
    std::sort(ord.begin(), ord.end(), [&](std::size_t a, std::size_t b) { return fs[a] < fs[b]; });
    const std::size_t best = ord[0], worst = ord[n];
    std::vector<double> c(n, 0.0);
    for (std::size_t k = 0; k < n; ++k)
      for (std::size_t j = 0; j < n; ++j) c[j] += s[ord[k]][j] / static_cast<double>(n);
    auto along = [&](double t) {
      std::vector<double> x(n);
      for (std::size_t j = 0; j < n; ++j) x[j] = c[j] + t * (s[worst][j] - c[j]);
      return clampTo(x);
    };
    auto xr = along(-1.0);
    const double fr = f(xr);
    if (fr < fs[best]) {
      auto xe = along(-2.0);
      const double fe = f(xe);
      if (fe < fr) s[worst] = xe, fs[worst] = fe; else s[worst] = xr, fs[worst] = fr;
    } else if (fr < fs[ord[n - 1]]) {
      s[worst] = xr, fs[worst] = fr;
    } else {
      auto xc = along(0.5);
      const double fc = f(xc);
      if (fc < fs[worst]) {
        s[worst] = xc, fs[worst] = fc;
      } else {
        for (std::size_t k = 1; k <= n; ++k) {
          for (std::size_t j = 0; j < n; ++j) s[ord[k]][j] = s[best][j] + 0.5 * (s[ord[k]][j] - s[best][j]);
          fs[ord[k]] = f(s[ord[k]]);
        }
      }
    }
  }
  return *std::min_element(fs.begin(), fs.end());
}

// The best RMS error ArduPilot's model reaches on the rows, found without the fitter: a grid
// over expo, SPIN_MIN and SPIN_MAX (each point with its best scale), then Nelder-Mead from the
// five best grid points.
double bestArduPilotRms(const std::vector<ap::Row>& rows, const ap::ArduPilotParams& base) {
  auto rms = [&](const std::vector<double>& x) {
    ap::ArduPilotParams p = base;
    p.thst_expo = x[0], p.spin_min = x[1], p.spin_max = x[2];
    return rmsOf(rows, [&](const ap::Row& r) { return ardu::thrustFraction(p, r.pwm_us, r.vbat_v); });
  };
  std::vector<std::pair<double, std::vector<double>>> grid;
  for (double e = -1.0; e <= 1.0 + 1e-9; e += 0.05)
    for (double smin = 0.0; smin <= 0.3 + 1e-9; smin += 0.01)
      for (double smax = 0.9; smax <= 1.0 + 1e-9; smax += 0.025) grid.push_back({rms({e, smin, smax}), {e, smin, smax}});
  std::partial_sort(grid.begin(), grid.begin() + 5, grid.end(),
                    [](const auto& a, const auto& b) { return a.first < b.first; });
  double best = grid.front().first;
  for (int k = 0; k < 5; ++k)
    best = std::min(best, nelderMead(grid[k].second, {-1, 0, 0.9}, {1, 0.3, 1.0}, {0.05, 0.01, 0.02}, rms));
  return best;
}

TEST(ArduPilotFit, TheWrittenParametersReachArduPilotsBestErrorOnPlantDataWithin5Percent) {
  for (const char* hidden : {"none", "sag"}) {
    // given: the plant's motor on the bench (true curve: the plant's steady state)
    const lab::Dataset d = generatedSet(hidden, tmpAutopilot(std::string("ap_best_") + hidden + ".csv"));
    ap::ExportOptions o;
    o.to = "ardupilot";
    // when: exported, and the file read back as a ground station would
    const ap::ExportReport r = ap::buildExport(d, o);
    const auto file = parmFile(r.file_text);
    ap::ArduPilotParams p;
    p.thst_expo = file.at("MOT_THST_EXPO");
    p.spin_min = file.at("MOT_SPIN_MIN");
    p.spin_max = file.at("MOT_SPIN_MAX");
    p.pwm_min_us = file.at("MOT_PWM_MIN");
    p.pwm_max_us = file.at("MOT_PWM_MAX");
    p.bat_volt_max_v = file.at("MOT_BAT_VOLT_MAX");
    p.bat_volt_min_v = file.at("MOT_BAT_VOLT_MIN");
    const std::vector<ap::Row> rows = rowsOf(d);
    const double fitted = rmsOf(rows, [&](const ap::Row& r) { return ardu::thrustFraction(p, r.pwm_us, r.vbat_v); });
    // then: within 5 % of the best that model can do with these battery settings
    const double best = bestArduPilotRms(rows, p);
    EXPECT_LE(fitted, 1.05 * best) << hidden << ": fitted " << fitted << " g, best " << best << " g";
    if (std::getenv("AUTOPILOT_TEST_PRINT"))
      std::printf("ArduPilot on %s: fitted %.4f g, best %.4f g, defaults %.4f g\n", hidden, fitted, best,
                  rmsOf(rows, [](const ap::Row& r) { return ardu::thrustFraction(ap::ArduPilotParams(), r.pwm_us, r.vbat_v); }));
    // and better than the defaults
    ap::ArduPilotParams defaults;
    const double def = rmsOf(rows, [&](const ap::Row& r) { return ardu::thrustFraction(defaults, r.pwm_us, r.vbat_v); });
    EXPECT_LT(fitted, 0.75 * def) << hidden;
  }
}

// The best RMS error PX4's model reaches on the rows, without the fitter: a grid over
// THR_MDL_FAC, MIN and MAX, then Nelder-Mead (continuous pulses) from the five best points.
double bestPx4Rms(const std::vector<ap::Row>& rows) {
  auto rms = [&](const std::vector<double>& x) {
    ap::Px4Params p;
    p.thr_mdl_fac = x[0], p.pwm_min_us = x[1], p.pwm_max_us = x[2];
    return rmsOf(rows, [&](const ap::Row& r) { return px4::thrustFraction(p, r.pwm_us, r.vbat_v); });
  };
  std::vector<std::pair<double, std::vector<double>>> grid;
  for (double f = 0.0; f <= 1.0 + 1e-9; f += 0.1)
    for (double lo = 800; lo <= 1400; lo += 20)
      for (double hi = 1600; hi <= 2000; hi += 50) grid.push_back({rms({f, lo, hi}), {f, lo, hi}});
  std::partial_sort(grid.begin(), grid.begin() + 5, grid.end(),
                    [](const auto& a, const auto& b) { return a.first < b.first; });
  double best = grid.front().first;
  for (int k = 0; k < 5; ++k)
    best = std::min(best, nelderMead(grid[k].second, {0, 800, 1600}, {1, 1400, 2000}, {0.05, 10, 25}, rms));
  return best;
}

TEST(Px4Fit, ReachesTheBestErrorOfPx4sModelOnPlantData) {
  const lab::Dataset d = generatedSet("none", tmpAutopilot("px4_best.csv"));
  const std::vector<ap::Row> rows = rowsOf(d);
  ap::FitSetup setup;
  setup.cells = 3;
  const ap::Px4Fit fit = ap::fitPx4(rows, setup, false);
  const double fitted = std::sqrt(fit.scale.rss / rows.size());
  const double best = bestPx4Rms(rows);
  EXPECT_LE(fitted, 1.01 * best) << "fitted " << fitted << " g, best " << best << " g";
  if (std::getenv("AUTOPILOT_TEST_PRINT")) std::printf("PX4 fitted %.4f g, best %.4f g\n", fitted, best);
  EXPECT_GT(fit.params.thr_mdl_fac, 0.1);      // a propeller's thrust is not linear in the command
}

TEST(BetaflightFit, ReachesTheBestErrorOfBetaflightsModelOnPlantData) {
  const lab::Dataset d = generatedSet("none", tmpAutopilot("bf_best.csv"));
  const std::vector<ap::Row> rows = rowsOf(d);
  ap::FitSetup setup;
  setup.use_voltage = false;
  const ap::BetaflightFit fit = ap::fitBetaflight(rows, setup);
  const double fitted = std::sqrt(fit.scale.rss / rows.size());
  double best = INFINITY;
  for (int tl = 0; tl <= bf::kMonotoneThrustLinearMax; tl += 3)
    for (int idle = 0; idle <= 2000; idle += 25)
      for (int limit = 80; limit <= 100; limit += 5) {
        ap::BetaflightParams p;
        p.thrust_linear = tl, p.motor_idle = idle, p.motor_output_limit = limit;
        best = std::min(best, rmsOf(rows, [&](const ap::Row& r) { return bf::thrustFraction(p, r.pwm_us, r.vbat_v); }));
      }
  EXPECT_LE(fitted, 1.01 * best) << "fitted " << fitted << " g, best " << best << " g";
  if (std::getenv("AUTOPILOT_TEST_PRINT")) std::printf("Betaflight fitted %.4f g, best %.4f g\n", fitted, best);
  EXPECT_GT(fit.params.thrust_linear, 10);
}

// ---- The export: comparison, refusals, files -------------------------------------------------

const ap::ModelColumn& column(const ap::ExportReport& r, const std::string& prefix) {
  for (const auto& m : r.models)
    if (m.name.rfind(prefix, 0) == 0) return m;
  throw std::out_of_range("no model column " + prefix);
}

double rmsColumn(const ap::ExportReport& r, const std::string& prefix) {
  const auto& m = column(r, prefix);
  double ss = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < r.rows.size(); ++i)
    if (std::isfinite(m.predicted_g[i])) ss += std::pow(r.rows[i].force_g - m.predicted_g[i], 2), ++n;
  return n ? std::sqrt(ss / n) : NAN;
}

TEST(AutopilotExport, ComparesFittedDefaultsAndModelV2PerVoltageAndMotor) {
  // given four varied motors at two voltages
  const lab::Dataset d = generatedSet("motor", tmpAutopilot("ap_motor.csv"));
  for (const char* to : {"ardupilot", "px4", "betaflight"}) {
    ap::ExportOptions o;
    o.to = to;
    // when
    const ap::ExportReport r = ap::buildExport(d, o);
    // then: the fitted set beats the defaults, and v2 (per motor) beats both
    const double fitted = rmsColumn(r, "fitted (the file)");
    EXPECT_LT(fitted, rmsColumn(r, "defaults")) << to;
    EXPECT_LT(rmsColumn(r, "thrustcal model v2"), 0.5 * fitted) << to;
    // groups: all, the two voltages, the four motors
    ASSERT_EQ(r.groups.size(), 1u + 2u + 4u) << to;
    EXPECT_EQ(r.groups[1].label.back(), 'V');
    EXPECT_LT(std::stod(r.groups[1].label), std::stod(r.groups[2].label));
    // each motor's own best set, and the spread in the printed table
    ASSERT_EQ(r.per_motor.size(), 4u);
    for (const auto& b : r.per_motor) EXPECT_LE(b.own_rms_g, b.common_rms_g + 1e-9) << b.label;
    const std::string text = ap::formatReport(r);
    EXPECT_NE(text.find("spread"), std::string::npos);
    EXPECT_NE(text.find("motor 3"), std::string::npos);
  }
}

TEST(AutopilotExport, DataWithoutAVoltageColumnFitWithoutVoltageScalingAndSaySo) {
  lab::Dataset d = generatedSet("none", tmpAutopilot("ap_nov.csv"));
  const int v = d.find("vbat_v");
  d.names.erase(d.names.begin() + v);
  d.columns.erase(d.columns.begin() + v);
  ap::ExportOptions o;
  o.to = "ardupilot";
  const ap::ExportReport r = ap::buildExport(d, o);
  const auto file = parmFile(r.file_text);
  EXPECT_EQ(file.at("MOT_BAT_VOLT_MAX"), 0.0);
  const std::string text = ap::formatReport(r);
  EXPECT_NE(text.find("no battery voltage column (vbat_v): fitted without ArduPilot's voltage term"), std::string::npos);
  EXPECT_NE(text.find("model v2: needs the battery voltage"), std::string::npos);
}

TEST(AutopilotExport, TooFewRowsOrTooLittleForceAreRefusedWithWhatToLog) {
  const lab::Dataset d = generatedSet("none", tmpAutopilot("ap_short.csv"));
  ap::ExportOptions o;
  o.to = "px4";
  // eight rows
  std::vector<bool> few(d.rows(), false);
  for (std::size_t i = 20; i < 28; ++i) few[i] = true;
  try {
    ap::buildExport(d.subset(few), o);
    FAIL() << "eight rows were fitted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("only 8 rows"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("log a sweep from below the start of thrust"), std::string::npos);
  }
  // only the bottom of the sweep: thrust barely starts
  std::vector<bool> low(d.rows(), false);
  for (std::size_t i = 0; i < d.rows(); ++i) low[i] = d.col("pwm_us")[i] <= 1125;
  EXPECT_THROW(ap::buildExport(d.subset(low), o), std::invalid_argument);
  // one PWM step above the start of thrust, repeated
  std::vector<bool> narrow(d.rows(), false);
  for (std::size_t i = 0; i < d.rows(); ++i) narrow[i] = d.col("pwm_us")[i] <= 1200;
  try {
    ap::buildExport(d.subset(narrow), o);
    FAIL() << "a 75 us wide curve was fitted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("cannot be seen"), std::string::npos) << e.what();
  }
}

TEST(AutopilotExport, HoverThrustFromTheTakeOffWeightMakesTheModelLiftItsShare) {
  const lab::Dataset d = generatedSet("none", tmpAutopilot("ap_hover.csv"));
  ap::ExportOptions o;
  o.to = "ardupilot";
  o.auw_g = 1400;
  o.motors = 4;
  o.motors_given = true;
  const ap::ExportReport r = ap::buildExport(d, o);
  const auto file = parmFile(r.file_text);
  // ArduPilot hovering at MOT_THST_HOVER sends the PWM that, by its model, gives 350 g per motor
  ap::ArduPilotParams p;
  p.thst_expo = file.at("MOT_THST_EXPO"), p.spin_min = file.at("MOT_SPIN_MIN"), p.spin_max = file.at("MOT_SPIN_MAX");
  p.bat_volt_max_v = file.at("MOT_BAT_VOLT_MAX"), p.bat_volt_min_v = file.at("MOT_BAT_VOLT_MIN");
  const int pwm = ardu::pwmForThrust(p, file.at("MOT_THST_HOVER"), 11.1);
  EXPECT_NEAR(r.full_g * ardu::thrustFraction(p, pwm, 11.1), 350.0, 2.0);
  // and --auw-g without --motors is refused
  o.motors_given = false;
  EXPECT_THROW(ap::buildExport(d, o), std::invalid_argument);
}


labtest::CliRun thrustcalAutopilot(std::vector<std::string> args) { return labtest::runLabCli(std::move(args)); }

TEST(AutopilotExportCli, WritesTheFileEachGroundStationLoads) {
  const std::string data = tmpAutopilot("ap_cli.csv");
  generatedSet("none", data);
  // ArduPilot: NAME,VALUE lines (Mission Planner, MAVProxy), comments with '#'
  const std::string parm = tmpAutopilot("quad.parm");
  labtest::CliRun r = thrustcalAutopilot({"lab", "export", data, "--to", "ardupilot", "-o", parm, "--auw-g", "1400", "--motors", "4"});
  ASSERT_EQ(r.rc, 0) << r.err;
  const auto ap_file = parmFile(slurpAutopilot(parm));
  for (const char* name : {"MOT_THST_EXPO", "MOT_SPIN_MIN", "MOT_SPIN_MAX", "MOT_PWM_MIN", "MOT_PWM_MAX",
                           "MOT_BAT_VOLT_MAX", "MOT_BAT_VOLT_MIN", "MOT_THST_HOVER"})
    EXPECT_EQ(ap_file.count(name), 1u) << name;
  EXPECT_NE(r.out.find("force error, g"), std::string::npos);
  EXPECT_NE(r.out.find("wrote " + parm), std::string::npos);
  // PX4: QGroundControl's tab-separated lines, type 9 for floats and 6 for integers
  const std::string params = tmpAutopilot("quad.params");
  r = thrustcalAutopilot({"lab", "export", data, "--to", "px4", "-o", params});
  ASSERT_EQ(r.rc, 0) << r.err;
  const std::string px4_text = slurpAutopilot(params);
  EXPECT_NE(px4_text.find("# Vehicle-Id Component-Id Name Value Type\n"), std::string::npos);
  EXPECT_NE(px4_text.find("1\t1\tTHR_MDL_FAC\t"), std::string::npos);
  EXPECT_NE(px4_text.find("1\t1\tPWM_MAIN_MIN4\t"), std::string::npos);
  EXPECT_EQ(px4_text.find("PWM_MAIN_MIN5"), std::string::npos);
  // Betaflight: CLI set lines ending with save
  const std::string cli = tmpAutopilot("quad.txt");
  r = thrustcalAutopilot({"lab", "export", data, "--to", "betaflight", "-o", cli});
  ASSERT_EQ(r.rc, 0) << r.err;
  const std::string bf_text = slurpAutopilot(cli);
  EXPECT_NE(bf_text.find("\nset thrust_linear = "), std::string::npos);
  EXPECT_NE(bf_text.find("\nset motor_idle = "), std::string::npos);
  EXPECT_EQ(bf_text.substr(bf_text.size() - 5), "save\n");
}

TEST(AutopilotExportCli, MixingTheBoardExportWithToOrForgettingTheOutputIsRefused) {
  const std::string data = tmpAutopilot("ap_cli_refuse.csv");
  generatedSet("none", data);
  EXPECT_NE(thrustcalAutopilot({"lab", "export", data, "--to", "ardupilot"}).rc, 0);  // no -o
  labtest::CliRun r = thrustcalAutopilot({"lab", "export", data, "--to", "ardupilot", "-o", tmpAutopilot("x.parm"), "--slot", "1"});
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.err.find("use one or the other"), std::string::npos) << r.err;
  EXPECT_NE(thrustcalAutopilot({"lab", "export", data, "--to", "inav", "-o", tmpAutopilot("x.parm")}).rc, 0);
  // the board export still needs its options
  EXPECT_NE(thrustcalAutopilot({"lab", "export", data, "--slot", "1"}).rc, 0);
}

TEST(AutopilotExportCli, PlotsThroughGnuplot) {
  const std::string data = tmpAutopilot("ap_plot.csv");
  generatedSet("none", data);
  const std::string base = tmpAutopilot("ap_plot_fit");
  const labtest::CliRun r = thrustcalAutopilot({"lab", "export", data, "--to", "px4", "-o", tmpAutopilot("plot.params"), "--plot", base});
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_TRUE(fs::exists(base + ".tsv"));
  EXPECT_TRUE(fs::exists(base + ".gp"));
  if (std::system("gnuplot --version > /dev/null 2>&1") == 0) {
    EXPECT_GT(fs::file_size(base + ".png"), 10000u);
    EXPECT_TRUE(fs::exists(base + ".svg"));
  }
}

}  // namespace
