// The autopilots' thrust models (lab/autopilot.hpp) against values computed by hand from their
// sources' formulas, clamps and edge cases included; their fits on generated data whose true
// curve is known; and `thrustcal lab export --to ...` end to end (the files the ground
// stations load, the comparison, the refusals).
//
// Hand values: each expected number below was worked out from the formula quoted next to it
// (a calculator, not this code), to the digits shown.
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

// ArduPilot as most copters run it: defaults, 1000-2000 us, compensation for 3S (4.2 / 3.3 V per cell).
ap::ArduPilotParams ardu3s() {
  ap::ArduPilotParams p;
  p.bat_volt_max_v = 12.6;
  p.bat_volt_min_v = 9.9;
  return p;
}

// ---- ArduPilot: AP_Motors_Thrust_Linearization -----------------------------------------------

TEST(ArduPilotModel, VoltageRatioIsTheClampedVoltageOverBatVoltMaxOrOneWhenOff) {
  struct Case {
    double vmax, vmin, volts, ratio;
  };
  const Case cases[] = {
      {12.6, 9.9, 11.34, 0.9},          // 11.34 / 12.6
      {12.6, 9.9, 14.0, 1.0},           // above V_MAX: clamped to it
      {12.6, 9.9, 9.0, 9.9 / 12.6},     // below V_MIN: clamped to it (0.785714)
      {12.6, 5.0, 7.0, 0.6},            // V_MIN raised to 0.6 V_MAX = 7.56 V: 7.56 / 12.6
      {12.6, 9.9, 2.0, 1.0},            // below a quarter of V_MIN (2.475 V): compensation off
      {0.0, 9.9, 11.0, 1.0},            // V_MAX 0: off (the default)
      {12.6, 13.0, 11.0, 1.0},          // V_MIN >= V_MAX: off
      {12.6, 9.9, NAN, 1.0},            // no voltage logged: off
  };
  for (const Case& c : cases) {
    ap::ArduPilotParams p;
    p.bat_volt_max_v = c.vmax;
    p.bat_volt_min_v = c.vmin;
    EXPECT_NEAR(ardu::voltageRatio(p, c.volts), c.ratio, 1e-9) << c.vmax << " " << c.vmin << " " << c.volts;
  }
  // lift_max = v (1 - e) + e v^2 = 0.9 * 0.35 + 0.65 * 0.81
  EXPECT_NEAR(ardu::liftMax(ardu3s(), 11.34), 0.8415, 1e-9);
}

TEST(ArduPilotModel, ThrustToActuatorFollowsTheSourceFormulaWithItsClamps) {
  struct Case {
    double expo, thrust, volts, actuator;
  };
  // actuator = spin_min + (spin_max - spin_min) * clamp(ratio / v, 0, 1),
  // ratio = ((e - 1) + sqrt((1 - e)^2 + 4 e lift thrust)) / (2 e)
  const Case cases[] = {
      {0.65, 0.5, 11.34, 0.6648225},  // v 0.9, lift 0.8415: ratio 0.579175, / 0.9 = 0.643528
      {0.65, 1.0, 9.9, 0.95},         // full demand reaches SPIN_MAX at any voltage
      {0.65, 0.3, 14.0, 0.5192308},   // above V_MAX: v = 1, ratio (-0.35 + sqrt(0.1225 + 0.78)) / 1.3
      {0.65, 0.5, 9.0, 0.6597400},    // below V_MIN: as at 9.9 V
      {0.65, 1.5, 12.6, 0.95},        // demand above 1: clamped to 1
      {0.65, -0.2, 12.6, 0.15},       // demand below 0: clamped to 0, SPIN_MIN
      {0.0, 0.5, 11.34, 0.55},        // expo 0: lift * thrust / v = 0.5 -> 0.15 + 0.8 * 0.5
      {1.0, 0.25, 12.6, 0.55},        // expo 1: y^2 = 0.25 -> y = 0.5
      {-1.0, 0.75, 12.6, 0.55},       // expo -1: 2y - y^2 = 0.75 -> y = 0.5
  };
  for (const Case& c : cases) {
    ap::ArduPilotParams p = ardu3s();
    p.thst_expo = c.expo;
    EXPECT_NEAR(ardu::thrustToActuator(p, c.thrust, c.volts), c.actuator, 2e-7)
        << "expo " << c.expo << " thrust " << c.thrust << " at " << c.volts << " V";
  }
}

TEST(ArduPilotModel, OutputToPwmTruncatesAsTheInt16ReturnDoes) {
  const ap::ArduPilotParams p = ardu3s();
  EXPECT_EQ(ardu::outputToPwm(p, 0.6648225), 1664);  // 1664.82 -> 1664, not 1665
  EXPECT_EQ(ardu::outputToPwm(p, 0.15), 1150);
  // get_throttle() 0.4 of full thrust at 11.34 V: demand 0.4 / lift 0.8415 -> actuator 0.6479097
  EXPECT_EQ(ardu::pwmForThrust(p, 0.4, 11.34), 1647);
  // ... at 12.6 V (lift 1): actuator 0.5981187
  EXPECT_EQ(ardu::pwmForThrust(p, 0.4, 12.6), 1598);
}

TEST(ArduPilotModel, ThrustFractionIsZeroAtAndBelowSpinMinAndSaturatesAboveSpinMax) {
  const ap::ArduPilotParams p = ardu3s();
  EXPECT_EQ(ardu::thrustFraction(p, 1100, 12.6), 0.0);  // actuator 0.10 < SPIN_MIN 0.15
  EXPECT_EQ(ardu::thrustFraction(p, 1150, 12.6), 0.0);
  // 1600 us at 11.34 V: t = 0.45 / 0.8 = 0.5625, y = 0.50625, e y^2 + (1 - e) y = 0.3437754
  EXPECT_NEAR(ardu::thrustFraction(p, 1600, 11.34), 0.3437754, 1e-7);
  // above SPIN_MAX: lift_max (0.8415 at 11.34 V), however high the PWM
  EXPECT_NEAR(ardu::thrustFraction(p, 1980, 11.34), 0.8415, 1e-9);
  EXPECT_NEAR(ardu::thrustFraction(p, 2000, 11.34), 0.8415, 1e-9);
}

TEST(ArduPilotModel, ItsOwnActuatorToThrustTurnsPositiveAgainFarBelowSpinMinAtHighExpo) {
  // remove_thrust_curve_and_volt_scaling at expo 0.95, actuator 0.10 (1100 us), v = 1:
  // t = -0.0625, ((t 2e) - (e - 1))^2 - (1 - e)^2 = 0.0047266 - 0.0025, / (4 e) = 0.000586
  ap::ArduPilotParams p;
  p.thst_expo = 0.95;
  EXPECT_NEAR(ardu::actuatorToThrust(p, 0.10, NAN), 0.000586, 1e-6);
  EXPECT_EQ(ardu::thrustFraction(p, 1100, NAN), 0.0);  // the model used for fitting says 0 there
}

TEST(ArduPilotModel, PwmForThrustAndThrustFractionAreInversesWithinTheTruncation) {
  const ap::ArduPilotParams p = ardu3s();
  for (double volts : {10.0, 11.1, 12.6})
    for (double frac : {0.1, 0.3, 0.5}) {
      const int pwm = ardu::pwmForThrust(p, frac, volts);
      // one microsecond of truncation is at most ~0.2 % of full thrust here
      EXPECT_LE(ardu::thrustFraction(p, pwm, volts), frac + 1e-9);
      EXPECT_GT(ardu::thrustFraction(p, pwm + 1, volts), frac - 1e-9) << frac << " at " << volts;
    }
}

// ---- PX4: FunctionMotors, output_limit_calc_single, Battery::computeScale --------------------

ap::Px4Params px4Set(double fac) {
  ap::Px4Params p;
  p.thr_mdl_fac = fac;
  p.pwm_min_us = 1100;
  p.pwm_max_us = 1900;
  return p;
}

TEST(Px4Model, ThrustToPwmSolvesTheQuadraticThenMapsMinToMax) {
  struct Case {
    double fac, thrust;
    int pwm;
  };
  // x = -b/(2a) + sqrt(b^2/(4a^2) + T/a), a = f, b = 1 - f; pwm = MIN + x (MAX - MIN), rounded
  const Case cases[] = {
      {0.3, 0.5, 1559},   // x = 0.5733844 -> 1558.71
      {0.3, 0.0, 1100},   // zero thrust: MIN
      {0.3, 1.5, 1900},   // x = 1.355 -> clamped to MAX
      {0.3, -0.2, 1000},  // negative: NaN -> the disarmed value
      {0.0, 0.5, 1500},   // f = 0: linear
      {1.5, 0.5, 1500},   // f outside (FLT_EPSILON, 1]: left linear
      {1.0, 0.25, 1500},  // f = 1: x = sqrt(T)
  };
  for (const Case& c : cases)
    EXPECT_EQ(px4::pwmForThrust(px4Set(c.fac), c.thrust, 12.0), c.pwm) << c.fac << " " << c.thrust;
  // MIN > MAX is swapped by updateParams
  ap::Px4Params swapped = px4Set(0.0);
  std::swap(swapped.pwm_min_us, swapped.pwm_max_us);
  EXPECT_EQ(px4::pwmForThrust(swapped, 0.5, 12.0), 1500);
}

TEST(Px4Model, BatteryScaleIsChargedOverCellVoltageWithinOneAndOnePointThree) {
  ap::Px4Params p = px4Set(0.3);
  p.bat_scale_en = true;
  p.bat_n_cells = 3;
  EXPECT_NEAR(px4::batteryScale(p, 11.1), 4.05 / 3.7, 1e-12);  // 1.0945946
  EXPECT_EQ(px4::batteryScale(p, 12.6), 1.0);                  // 4.2 V per cell: 0.964 -> 1
  EXPECT_EQ(px4::batteryScale(p, 9.0), 1.3);                   // 3.0 V per cell: 1.35 -> 1.3
  EXPECT_EQ(px4::batteryScale(p, NAN), 1.0);
  // thrust 0.5 at 11.1 V: 0.5 * 1.0945946 = 0.5472973, x = 0.6181122 -> 1594.49
  EXPECT_EQ(px4::pwmForThrust(p, 0.5, 11.1), 1594);
  // the model: (0.3 * 0.25 + 0.7 * 0.5) / 1.0945946 at 1500 us
  EXPECT_NEAR(px4::thrustFraction(p, 1500, 11.1), 0.3882716, 1e-7);
  p.bat_scale_en = false;
  EXPECT_NEAR(px4::thrustFraction(p, 1500, 11.1), 0.425, 1e-12);
  EXPECT_EQ(px4::thrustFraction(p, 1050, 11.1), 0.0);  // below MIN
  EXPECT_EQ(px4::thrustFraction(p, 1950, 11.1), 1.0);  // above MAX
}

// ---- Betaflight: pidApplyThrustLinearization, motor endpoints, sag compensation ---------------

TEST(BetaflightModel, ThrustLinearizationIsTheSecondOrderExpansionFromPidC) {
  // c(x) = x (1 + e (1 - x) (1 + e (1 - 2x))), e = 0.4 (the float 40 / 100.0f: 0.4 + 6e-9)
  EXPECT_NEAR(bf::applyThrustLinearization(40, 0.5), 0.6, 1e-8);
  EXPECT_NEAR(bf::applyThrustLinearization(40, 0.25), 0.34, 1e-8);
  EXPECT_NEAR(bf::applyThrustLinearization(40, 0.8), 0.84864, 1e-8);
  EXPECT_EQ(bf::applyThrustLinearization(40, 0.0), 0.0);
  EXPECT_NEAR(bf::applyThrustLinearization(40, 1.0), 1.0, 1e-12);
  EXPECT_NEAR(bf::applyThrustLinearization(0, 0.37), 0.37, 1e-12);
  // pidCompensateThrustLinearization: 0.5 (1 - 0.4 * 0.5)
  EXPECT_NEAR(bf::compensateThrustLinearization(40, 0.5), 0.4, 1e-8);
  EXPECT_NEAR(bf::removeThrustLinearization(40, 0.6), 0.5, 1e-8);
}

TEST(BetaflightModel, AboveThrustLinear129TheCurveFallsWhileTheDemandRises) {
  // slope 5/6 - e^2/2 at x = 0.5 + 1/(6e): +0.0013 at 1.29, -0.0117 at 1.30
  EXPECT_GT(bf::applyThrustLinearization(129, 0.6293), bf::applyThrustLinearization(129, 0.6292));
  EXPECT_LT(bf::applyThrustLinearization(150, 0.65), bf::applyThrustLinearization(150, 0.55));  // 0.8377 < 0.8656
}

TEST(BetaflightModel, EndpointsForPwmAndDshotFollowMotorIdleAndOutputLimit) {
  ap::BetaflightParams p;  // motor_idle 550
  p.protocol = ap::BfProtocol::kPwm;
  EXPECT_NEAR(bf::endpoints(p).low, 1055, 1e-9);  // min_command + 550 * 0.1
  EXPECT_NEAR(bf::endpoints(p).high, 2000, 1e-9);
  p.motor_output_limit = 80;  // max_throttle - (max_throttle - 1055) * 0.2
  EXPECT_NEAR(bf::endpoints(p).high, 1811, 1e-9);
  p.protocol = ap::BfProtocol::kDshot;
  EXPECT_NEAR(bf::endpoints(p).low, 157.945, 1e-9);  // 48 + 0.055 * 1999
  EXPECT_NEAR(bf::endpoints(p).high, 1647.2, 1e-9);  // 2047 - 1999 * 0.2
  EXPECT_NEAR(bf::toPulseUs(p, 157.945), 1055.0, 1e-9);
  EXPECT_NEAR(bf::fromPulseUs(p, 1055.0), 157.945, 1e-9);
}

TEST(BetaflightModel, SagCompensationLowersTheTopWithTheIntegerCellVoltage) {
  ap::BetaflightParams p;
  p.protocol = ap::BfProtocol::kPwm;
  p.vbat_sag_compensation = 100;
  p.cells = 4;
  struct Case {
    double volts, top;
  };
  // factor = (70 / 420) * goodness, goodness = 1 - clamp((420 - cell_cv) / 70, 0, 1)
  const Case cases[] = {
      {16.8, 1842.5},   // 420 cV per cell: goodness 1, top - (1/6) * 945
      {15.43, 1921.25}, // 1543 / 4 = 385 (integer): goodness 0.5
      {15.4, 1921.25},
      {14.0, 2000},     // 350 cV = the warning voltage: no compensation
      {13.5, 2000},
  };
  for (const Case& c : cases) EXPECT_NEAR(bf::rangeMax(p, c.volts), c.top, 1e-9) << c.volts;
  p.cells = 0;  // cell count unknown: getBatterySagCellVoltage() is 0, no compensation
  EXPECT_NEAR(bf::rangeMax(p, 16.8), 2000, 1e-9);
}

TEST(BetaflightModel, MotorOutputAndThrustFractionInvertEachOther) {
  ap::BetaflightParams p;
  p.protocol = ap::BfProtocol::kPwm;
  p.thrust_linear = 40;
  EXPECT_NEAR(bf::motorOutput(p, 0.5, 12.0), 1622.0, 1e-5);  // 1055 + 945 * 0.6
  EXPECT_NEAR(bf::thrustFraction(p, 1622.0, 12.0), 0.5, 1e-8);
  EXPECT_EQ(bf::thrustFraction(p, 1040.0, 12.0), 0.0);  // below motor_idle
  EXPECT_EQ(bf::thrustFraction(p, 2000.0, 12.0), 1.0);
  EXPECT_NEAR(bf::motorOutput(p, 1.3, 12.0), 2000.0, 1e-9);  // constrained to the range
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
