#include "bench/accuracy.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <stdexcept>

#include <fmt/format.h>

#include "plant/actuator.hpp"
#include "plant/fidelity.hpp"
#include "plant/sensors.hpp"
#include "thrustcal/battery_monitor.hpp"
#include "thrustcal/dynamics_fit.hpp"
#include "thrustcal/curve_builder.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/motor_calibration.hpp"

namespace bench {

namespace {

constexpr double kPwmMinUs = 1000;

struct Accum {
  double sum = 0, sum_sq = 0, max_abs = 0;
  int n = 0;
  void add(double e) {
    sum += e;
    sum_sq += e * e;
    max_abs = std::max(max_abs, std::fabs(e));
    ++n;
  }
  ErrorStats stats() const { return {n ? std::sqrt(sum_sq / n) : 0.0, max_abs, n}; }
};


// Everything fitted for one motor from its two sweeps.
struct MotorModels {
  plant::Actuator actuator;
  tc::MotorCalibration cal;
  tc::ModelV2 v2;
  ExpoModel expo;
};

void buildThesisCurve(const Sweep& sweep, tc::ThesisCurve& curve, tc::SagTable* sag,
                      const std::string& what) {
  tc::CurveBuilder<256> builder;
  tc::SagBuilder sag_builder;
  sag_builder.reset(static_cast<uint16_t>(sweep.points.front().pwm_us));
  for (const SweepPoint& p : sweep.points) {
    builder.add(p.pwm_us, p.force_dg);
    sag_builder.add(p.pwm_us, p.vbat_mv);
  }
  const tc::BuildReport rep = builder.build(curve);
  if (rep.status != tc::BuildStatus::kOk)
    throw std::runtime_error(fmt::format("{}: the thesis curve builder failed (status {}); the "
                                         "sweep does not reach 1 g or is too coarse",
                                         what, static_cast<int>(rep.status)));
  tc::SagTable table;
  uint16_t start_mv = 0;
  if (!sag_builder.build(table, start_mv))
    throw std::runtime_error(what + ": no sample in the first sag bin, no start voltage");
  curve.start_mv = start_mv;
  if (sag) *sag = table;
}

void fitV2(const Sweep& high, const Sweep& low, tc::ModelV2& model, MotorSummary& summary,
           const std::string& what) {
  tc::ModelV2Fitter<256> fitter;
  for (const SweepPoint& p : high.points) fitter.add(p.pwm_us, p.force_dg, p.vbat_mv);
  tc::FitV2Report rep = fitter.fit(model);
  if (rep.status != tc::FitV2Status::kOk)
    throw std::runtime_error(what + ": v2 fit failed: " + tc::fitV2StatusText(rep.status));
  fitter.reset();
  for (const SweepPoint& p : low.points) fitter.add(p.pwm_us, p.force_dg, p.vbat_mv);
  rep = fitter.refine(model);
  if (rep.status != tc::FitV2Status::kOk)
    throw std::runtime_error(what + ": v2 refine failed: " + tc::fitV2StatusText(rep.status));
  summary.fit_v2 = "fit ok, refine ok";
  summary.v2_start_us = model.start_q4_us / 16.0;
}

// Thesis option 2.1 as read_run flies it in steady state: the reading plus the sag offset of
// the PWM last sent, iterated until the PWM stops changing (read_run does one step per frame).
double thesisPwm(const tc::MotorCalibration& cal, int force_g, uint16_t reading_mv) {
  const tc::BatteryMonitor monitor;
  uint16_t pwm = tc::forceToPwm(cal, static_cast<uint16_t>(force_g), reading_mv).pwm_us;
  for (int i = 0; i < 20; ++i) {
    const uint16_t mv = monitor.compensatedMillivolts(reading_mv, pwm, cal.sag);
    const uint16_t next = tc::forceToPwm(cal, static_cast<uint16_t>(force_g), mv).pwm_us;
    if (next == pwm) break;
    pwm = next;
  }
  return pwm;
}

double v2Pwm(const tc::ModelV2& model, int force_g, uint16_t reading_mv) {
  tc::BusVoltageFilter bus;
  bus.reset(reading_mv);
  return tc::forceToPwmV2(model, static_cast<uint16_t>(force_g * 10), bus).pwm_us;
}

}  // namespace

nlohmann::json ErrorStats::toJson() const {
  return {{"rms_pct", rms_pct}, {"max_pct", max_pct}, {"points", points}};
}

double ExpoModel::spinMin_us() const {
  return params.pwm_min_us + params.spin_min * (params.pwm_max_us - params.pwm_min_us);
}
double ExpoModel::thrust_g(double pwm_us, double bus_v) const {
  return full_g * lab::autopilot::ardupilot::thrustFraction(params, pwm_us, bus_v);
}
double ExpoModel::pwmFor_us(double force_g, double bus_v) const {
  return lab::autopilot::ardupilot::pwmForThrust(params, full_g > 0 ? force_g / full_g : 0.0, bus_v);
}

ExpoModel fitExpo(const std::vector<SweepPoint>& points) {
  std::vector<lab::autopilot::Row> rows;
  int used = 0;
  for (const SweepPoint& p : points) {
    lab::autopilot::Row r;
    r.pwm_us = p.pwm_us;
    r.force_g = p.force_dg / 10.0;
    r.vbat_v = p.vbat_mv / 1000.0;
    const bool in = p.force_dg >= 100 && p.force_dg <= 6000;
    r.weight = in ? 1.0 / (r.force_g * r.force_g) : 0.0;
    used += in;
    rows.push_back(r);
  }
  if (used < 6)
    throw std::runtime_error(fmt::format(
        "ArduPilot fit: only {} samples between 10 g and 600 g (need 6); sweep higher", used));
  lab::autopilot::FitSetup setup;
  setup.cells = 3;                     // MOT_BAT_VOLT_MAX 12.6 V
  setup.bat_volt_min_per_cell = 2.52;  // MOT_BAT_VOLT_MIN 7.56 V, the lowest ArduPilot uses: the
                                       // current-limited supply sags below 9.9 V near full throttle
  setup.fit_spin_max = false;
  const lab::autopilot::ArduPilotFit fit = lab::autopilot::fitArduPilot(rows, setup);
  ExpoModel m;
  m.params = fit.params;
  m.full_g = fit.scale.full_g;
  m.rms_fit_pct = 100.0 * std::sqrt(fit.scale.rss / used);
  return m;
}

const ModelAccuracy& AccuracyResult::model(const std::string& key) const {
  for (const ModelAccuracy& m : models)
    if (m.key == key) return m;
  throw std::out_of_range("no model '" + key + "' in the accuracy result");
}

nlohmann::json AccuracyResult::toJson() const {
  nlohmann::json j;
  const AccuracyConfig& c = config;
  j["grid"] = {{"bus_v", {c.v_min, c.v_max, c.v_step}},
               {"force_g", {c.force_min_g, c.force_max_g, c.force_step_g}},
               {"motors", c.seeds.size()},
               {"preset", c.preset},
               {"variation", c.variation}};
  j["calibration"] = {{"high_v_lipo", c.cal_high_v},
                      {"low_v_bench_supply", c.cal_low_v},
                      {"sweep", {{"pwm_min_us", c.sweep.pwm_min_us},
                                 {"pwm_max_us", c.sweep.pwm_max_us},
                                 {"step_us", c.sweep.step_us},
                                 {"settle_ms", c.sweep.settle_ms}, {"settle_auto", c.sweep.settle_auto},
                                 {"fine_force", c.sweep.fine_force}}}};
  for (const ModelAccuracy& m : models) {
    nlohmann::json by_v = nlohmann::json::array();
    for (const auto& [v, st] : m.by_voltage) {
      nlohmann::json row = st.toJson();
      row["bus_v"] = std::round(v * 1000.0) / 1000.0;
      by_v.push_back(row);
    }
    j["models"][m.key] = {{"name", m.name},
                          {"all", m.all.toJson()},
                          {"mean_pct", m.mean_pct},
                          {"inside_calibration_v", m.inside.toJson()},
                          {"outside_calibration_v", m.outside.toJson()},
                          {"by_bus_v", by_v}};
  }
  for (const MotorSummary& s : motors)
    j["motors"].push_back({{"seed", s.seed},
                           {"v2", s.fit_v2},
                           {"v2_start_us", s.v2_start_us},
                           {"ardupilot_expo", s.expo},
                           {"ardupilot_spin_min_us", s.expo_spin_min_us},
                           {"ardupilot_lift_max_g", s.expo_lift_max_g},
                           {"ardupilot_fit_rms_pct", s.expo_fit_rms_pct},
                           {"sweep_high_rest_v", s.sweep_high_rest_v},
                           {"sweep_low_rest_v", s.sweep_low_rest_v},
                           {"sweep_samples", s.sweep_samples},
                           {"sweep_reading_error_rms_pct", s.sweep_reading_error_rms_pct},
                           {"sweep_reading_bias_pct", s.sweep_reading_bias_pct}});
  return j;
}

namespace {

// How far the sweep's readings are from the plant's true thrust (50-600 g, both sweeps).
void sweepReadingError(const Sweep& high, const Sweep& low, MotorSummary& summary) {
  double sum = 0, sum_sq = 0;
  int n = 0;
  for (const Sweep* sw : {&high, &low})
    for (const SweepPoint& p : sw->points)
      if (p.true_thrust_g > 50.0 && p.true_thrust_g < 600.0) {
        const double e = 100.0 * (p.force_dg / 10.0 - p.true_thrust_g) / p.true_thrust_g;
        sum += e, sum_sq += e * e, ++n;
      }
  summary.sweep_reading_bias_pct = n ? sum / n : 0.0;
  summary.sweep_reading_error_rms_pct = n ? std::sqrt(sum_sq / n) : 0.0;
}

}  // namespace

namespace {

// Motor `i` of the config: its two sweeps (LiPo, bench supply) and every model fitted to them.
std::unique_ptr<MotorModels> calibrateMotor(const AccuracyConfig& config, size_t i,
                                            const plant::ActuatorParams& nominal, MotorSummary& summary) {
  const uint64_t seed = config.seeds[i];
  const plant::ActuatorParams params = plant::makeVaried(nominal, seed, config.variation);
  const std::string what = fmt::format("motor {} (seed {})", i, seed);
  SweepSpec spec = config.sweep;
  if (config.lag_correction) {
    spec.lag_dynamics = plantDynamics(params, config.lag_tau_scale);
    const plant::LoadCellParams cell;
    spec.lag_bench.stages = static_cast<uint8_t>(cell.lowpass_tau_s.size());
    spec.lag_bench.tau_01ms = tc::secondsTo01ms(static_cast<float>(cell.lowpass_tau_s[0]));
  }
  spec.noise_seed = seed * 2 + 1;
  const Sweep high = simulateSweep(params, lipoAt(config.cal_high_v), spec);
  spec.noise_seed = seed * 2 + 2;
  const Sweep low = simulateSweep(params, plant::BatteryParams::benchSupply(config.cal_low_v, 6.32), spec);
  auto m = std::make_unique<MotorModels>(MotorModels{plant::Actuator(params), {}, {}, {}});
  summary.seed = seed;
  summary.sweep_high_rest_v = high.rest_v;
  summary.sweep_low_rest_v = low.rest_v;
  summary.sweep_samples = static_cast<int>(high.points.size());
  sweepReadingError(high, low, summary);
  buildThesisCurve(high, m->cal.first, &m->cal.sag, what + ", first curve");
  buildThesisCurve(low, m->cal.second, nullptr, what + ", second curve");
  fitV2(high, low, m->v2, summary, what);
  std::vector<SweepPoint> both = high.points;
  both.insert(both.end(), low.points.begin(), low.points.end());
  m->expo = fitExpo(both);
  summary.expo = m->expo.expo();
  summary.expo_spin_min_us = m->expo.spinMin_us();
  summary.expo_lift_max_g = m->expo.liftMax_g();
  summary.expo_fit_rms_pct = m->expo.rms_fit_pct;
  return m;
}

// One model of the comparison: the pulse it gives a motor for f grams at a monitor reading.
using PwmFn = std::function<double(const MotorModels&, int, uint16_t)>;
struct ModelEntry {
  const char* key;
  const char* name;
  PwmFn pwm;
};

// Flies every motor with the model at every point of the grid (steady state on the plant).
ModelAccuracy scoreModel(const AccuracyConfig& config, const ModelEntry& e,
                         const std::vector<std::unique_ptr<MotorModels>>& motors) {
  const double lo_cal = std::min(config.cal_low_v, config.cal_high_v);
  const double hi_cal = std::max(config.cal_low_v, config.cal_high_v);
  const int v_steps = static_cast<int>(std::floor((config.v_max - config.v_min) / config.v_step + 1e-6));
  Accum all, inside, outside;
  std::vector<Accum> per_v(static_cast<size_t>(v_steps) + 1);
  for (const auto& m : motors) {
    for (int vi = 0; vi <= v_steps; ++vi) {
      const double v = config.v_min + vi * config.v_step;
      const uint16_t reading = monitorReading_mv(v);
      const bool in = v >= lo_cal - 1e-9 && v <= hi_cal + 1e-9;
      for (int f = config.force_min_g; f <= config.force_max_g; f += config.force_step_g) {
        const double pwm = e.pwm(*m, f, reading);
        const double thrust = m->actuator.steadyState(pwm, v).thrust_g;
        const double err_pct = 100.0 * (thrust - f) / f;
        all.add(err_pct);
        (in ? inside : outside).add(err_pct);
        per_v[static_cast<size_t>(vi)].add(err_pct);
      }
    }
  }
  ModelAccuracy ma{e.key, e.name, all.stats(), inside.stats(), outside.stats(), {}, 0.0};
  for (int vi = 0; vi <= v_steps; ++vi)
    ma.by_voltage.emplace_back(config.v_min + vi * config.v_step, per_v[static_cast<size_t>(vi)].stats());
  ma.mean_pct = all.n ? all.sum / all.n : 0.0;
  return ma;
}

}  // namespace

AccuracyResult runAccuracy(const AccuracyConfig& config) {
  if (config.seeds.empty()) throw std::runtime_error("accuracy: no motor seeds given");
  if (config.v_step <= 0 || config.force_step_g <= 0 || config.v_max < config.v_min ||
      config.force_max_g < config.force_min_g || config.force_min_g <= 0)
    throw std::runtime_error("accuracy: empty grid; check the voltage and force ranges and steps");
  AccuracyResult result;
  result.config = config;
  const plant::ActuatorParams nominal = plant::presetParams(config.preset);
  std::vector<std::unique_ptr<MotorModels>> motors;
  for (size_t i = 0; i < config.seeds.size(); ++i) {
    MotorSummary summary;
    motors.push_back(calibrateMotor(config, i, nominal, summary));
    result.motors.push_back(summary);
  }
  // The uncalibrated map: the nominal motor's steady state at nominal_v, per gram.
  const plant::Actuator nominal_actuator(nominal);
  std::vector<double> generic_pwm(static_cast<size_t>(config.force_max_g) + 1, kPwmMinUs);
  for (int f = config.force_min_g; f <= config.force_max_g; ++f)
    generic_pwm[static_cast<size_t>(f)] = nominal_actuator.pulseForThrust_us(f, config.nominal_v);
  const ModelEntry entries[] = {
      {"uncalibrated", "same PWM map on all motors (nominal, 11.1 V)",
       [&](const MotorModels&, int f, uint16_t) { return generic_pwm[static_cast<size_t>(f)]; }},
      {"thesis_2_1", "thesis option 2.1 (two curves, sag offsets)",
       [](const MotorModels& m, int f, uint16_t mv) { return thesisPwm(m.cal, f, mv); }},
      {"ardupilot", "ArduPilot's thrust model (expo + voltage scaling), fitted",
       [](const MotorModels& m, int f, uint16_t mv) { return m.expo.pwmFor_us(f, mv / 1000.0); }},
      {"v2", "model v2 (effective voltage, fit + refine)",
       [](const MotorModels& m, int f, uint16_t mv) { return v2Pwm(m.v2, f, mv); }},
  };
  for (const ModelEntry& e : entries) result.models.push_back(scoreModel(config, e, motors));
  return result;
}

}  // namespace bench
