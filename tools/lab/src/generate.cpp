#include "lab/generate.hpp"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>

#ifdef THRUSTCAL_LAB_HAVE_PLANT
#include "plant/actuator.hpp"
#include "plant/fidelity.hpp"
#include "plant/params.hpp"
#include "plant/power_source.hpp"
#include "plant/random.hpp"
#include "plant/sensors.hpp"
#endif

namespace lab {

namespace {

const std::vector<HiddenEffectInfo> kHidden = {
    {"none", "bench supply at four voltages, one motor, nothing hidden",
     "curve+deadband+voltage", "", ""},
    {"density",
     "four runs at different air temperature and pressure (sea level to ~1500 m, 5-35 C), the "
     "temperature also cycling +-15 K within each run (a climate box); temp_c and pressure_hpa logged",
     "curve+deadband+voltage", "density", "rho_kg_m3"},
    {"sag",
     "a worn 3S LiPo (0.15 ohm) at four states of charge (12.6 to 10.2 V) that also feeds the "
     "frame's other motors (0-8 A, changing point by point); vbat_v is the resting voltage (logged "
     "before the load), current_a the pack current",
     "curve+deadband+voltage", "sag", "vbat_v"},
    {"motor", "four motors with 3 % part variation (Kv, R, I0, C_T, C_P, D), two voltages each",
     "curve+deadband+voltage", "motor", "motor"},
    {"drift",
     "the load cell's zero creeps by 1.2 g per minute through an 18-minute session",
     "curve+deadband+voltage", "drift", "t_s"},
    {"thermal",
     "the motor warms up through long sweeps (2 s per point) and cools between runs; temp_c is "
     "a thermocouple on the motor (winding resistance +0.39 %/K, magnets -0.1 %/K)",
     "curve+deadband+voltage", "thermal", "temp_c"},
    {"current_limit",
     "a bench supply current-limited at 6.32 A (the thesis's: two 3.16 A outputs in parallel) at four set "
     "voltages (10.0 to 12.4 V): above the limit it folds its voltage back and the force falls while the drive "
     "rises; vbat_v is the supply's set voltage (read at the supply, not at the ESC), current_a its current",
     "curve+deadband+voltage", "current_limit", "current_a (a response: evidence, not a suspect)"},
    {"lag",
     "a dynamics session (a step log): two motors with 3 % part variation on an 11.1 V bench supply, each "
     "held at PWM set points and logged at 500 Hz through every step: a staircase 1400-1600 us in 50 us steps "
     "and back, then four 100 us steps up and down between 1450 and 1550 us; the rotor follows each step "
     "with the plant's own dynamics, spin-down slower than spin-up (the ESC does not brake)",
     "curve+motor", "lag", "dpwm_us"},
    {"plate",
     "a deflector plate under the propeller at a height varied per point (plate_height_m): "
     "ground effect, force x 1/(1 - (R/4z)^2); not in the catalogue",
     "curve+deadband+voltage", "mul: 1/(1 - k/plate_height_m^2)", "plate_height_m"},
};

}  // namespace

const std::vector<HiddenEffectInfo>& hiddenEffects() { return kHidden; }

std::string toStandCsv(const Dataset& d, const StandLayout& l) {
  static const std::vector<std::pair<std::string, double>> kThrust = {
      {"N", 9.80665e-3}, {"kgf", 1e-3}, {"gf", 1.0}, {"lbf", 1.0 / 453.59237}, {"ozf", 1.0 / 28.349523125}};
  static const std::vector<std::pair<std::string, double>> kTorque = {{"N·m", 1.0}, {"ozf·in", 1.0 / 0.0070615518}};
  auto scaleOf = [](const std::vector<std::pair<std::string, double>>& units, const std::string& u, const char* what) {
    for (const auto& [name, k] : units)
      if (name == u) return k;
    std::string known;
    for (const auto& [name, k] : units) known += (known.empty() ? "" : ", ") + name;
    throw std::invalid_argument(fmt::format("{} unit '{}': the RCbenchmark software writes {}", what, u, known));
  };
  if (l.series != "1520" && l.series != "1585" && l.series != "1580")
    throw std::invalid_argument("--layout: RCbenchmark series 1520, 1580 or 1585");
  const bool big = l.series != "1520";
  const double kf = scaleOf(kThrust, l.thrust_unit, "thrust") * (l.negative_thrust ? -1.0 : 1.0);
  const double kt = big ? scaleOf(kTorque, l.torque_unit, "torque") : 1.0;
  const std::string tu = l.thrust_unit;
  std::string out;
  out += "Time (s),ESC signal (µs),Servo 1 (µs),Servo 2 (µs),Servo 3 (µs),";
  if (big) out += fmt::format("AccX (g),AccY (g),AccZ (g),Torque ({}),", l.torque_unit);
  out += fmt::format("Thrust ({}),Voltage (V),Current (A),Motor Electrical Speed (RPM),Motor Optical Speed (RPM),"
                     "Electrical Power (W),",
                     tu);
  if (big)
    out += fmt::format("Mechanical Power (W),Motor Efficiency (%),Propeller Mech. Efficiency ({}/W),", tu);
  out += fmt::format("Overall Efficiency ({}/W),", tu);
  if (big) out += "Vibration (g),";
  out += "App message,\n";
  const auto& t = d.col("t_s");
  const auto& pwm = d.col("pwm_us");
  const auto& f = d.col("force_g");
  const auto& v = d.col("vbat_v");
  const auto& i_a = d.col("current_a");
  const auto& rpm = d.col("rpm");
  const auto& torque = d.col("torque_nm");
  for (std::size_t r = 0; r < d.rows(); ++r) {
    const double thrust = f[r] * kf;
    const double elec = v[r] * i_a[r];
    const double mech = torque[r] * rpm[r] * 2 * M_PI / 60.0;
    out += fmt::format("{:.6g},{:.6g},,,,", t[r] - t[0], pwm[r]);
    if (big)
      out += fmt::format("{:.4g},{:.4g},{:.4g},{:.6g},", 0.01 * std::sin(0.7 * r), 0.01 * std::cos(0.3 * r), -1.0,
                         -torque[r] * kt);
    out += fmt::format("{:.8g},{:.6g},{:.6g},{:.0f},0,{:.6g},", thrust, v[r], i_a[r], rpm[r], elec);
    if (big)
      out += fmt::format("{:.6g},{:.6g},{:.6g},", mech, elec > 1e-3 ? 100.0 * mech / elec : 0.0,
                         mech > 1e-3 ? std::fabs(thrust) / mech : 0.0);
    out += fmt::format("{:.6g},", elec > 1e-3 ? std::fabs(thrust) / elec : 0.0);
    if (big) out += fmt::format("{:.4g},", 0.05 + 3e-6 * rpm[r]);
    out += (r == 0 && l.tare_message ? "Tare done" : "");
    out += ",\n";
  }
  return out;
}

#ifdef THRUSTCAL_LAB_HAVE_PLANT

namespace {

struct RunSetup {
  int motor = 0;
  plant::ActuatorParams params;
  plant::BatteryParams battery;
  double temp_c = 20.0;
  double pressure_pa = 101325.0;
  double temp_swing_k = 0.0;  // within-run sinusoid amplitude
  double pause_before_s = 5.0;
};

struct Row {
  double t_s, motor, pwm_us, force_g, vbat_v, current_a, rpm, temp_c, pressure_hpa, dir, plate_m, torque_nm;
  int run;
};

const HiddenEffectInfo& hiddenInfo(const std::string& name) {
  for (const auto& h : kHidden)
    if (h.name == name) return h;
  std::string names;
  for (const auto& h : kHidden) names += (names.empty() ? "" : ", ") + h.name;
  throw std::invalid_argument("unknown hidden effect '" + name + "'; known: " + names);
}

// The step log (`lag`): its bus voltage and the steps its truth is measured on.
constexpr double kStepBusV = 11.1;
constexpr double kStepLowUs = 1450, kStepHighUs = 1550;

// The set points of one run: a sweep up and down in 25 us steps, or the step log's staircase and
// steps; each with its direction.
std::vector<std::pair<double, double>> pointsOf(const std::string& h) {
  std::vector<std::pair<double, double>> points;  // pulse, dir
  if (h == "lag") {
    for (double p = 1400; p <= 1600.0 + 1e-9; p += 50) points.emplace_back(p, 1.0);
    for (double p = 1550; p >= 1400.0 - 1e-9; p -= 50) points.emplace_back(p, -1.0);
    for (int k = 0; k < 4; ++k) {
      points.emplace_back(kStepLowUs, -1.0);
      points.emplace_back(kStepHighUs, 1.0);
    }
    points.emplace_back(kStepLowUs, -1.0);
    return points;
  }
  for (double p = 1000; p <= 1900.0 + 1e-9; p += 25) points.emplace_back(p, 1.0);
  for (double p = 1900; p >= 1000.0 - 1e-9; p -= 25) points.emplace_back(p, -1.0);
  return points;
}

plant::BatteryParams benchAt(double v) {
  plant::BatteryParams b = plant::BatteryParams::benchSupply(v, 80.0);
  b.wiring_r_ohm = 0.03;
  return b;
}

// The runs of a session with hidden effect `h`: motors, power sources, air.
std::vector<RunSetup> runSetups(const std::string& h, const plant::ActuatorParams& base, uint64_t seed) {
  std::vector<RunSetup> runs;
  const double volts[] = {10.2, 11.1, 12.0, 12.6};
  if (h == "lag") {
    for (int m = 0; m < 2; ++m) {
      RunSetup r;
      r.motor = m;
      r.params = plant::makeVaried(base, seed * 100 + static_cast<uint64_t>(m), 0.03);
      r.battery = plant::BatteryParams::benchSupply(kStepBusV, 80.0);
      r.battery.wiring_r_ohm = 0.0;  // the truth is the plant's at this bus voltage
      r.pause_before_s = 1.0;
      runs.push_back(r);
    }
  } else if (h == "motor") {
    for (int m = 0; m < 4; ++m) {
      const plant::ActuatorParams p = plant::makeVaried(base, seed * 100 + static_cast<uint64_t>(m), 0.03);
      for (double v : {10.8, 12.4}) {
        RunSetup r;
        r.motor = m;
        r.params = p;
        r.battery = benchAt(v);
        runs.push_back(r);
      }
    }
  } else if (h == "current_limit") {
    for (double v : {12.4, 11.6, 10.8, 10.0}) {
      RunSetup r;
      r.params = base;
      r.battery = plant::BatteryParams::benchSupply(v, 6.32);
      r.battery.wiring_r_ohm = 0.03;
      runs.push_back(r);
    }
  } else if (h == "sag") {
    for (double v : {12.6, 11.8, 11.0, 10.2}) {
      RunSetup r;
      r.params = base;
      r.battery = plant::BatteryParams::lipo3s(plant::socForCellOcv(v / 3.0));
      r.battery.r_internal_ohm = 0.15;
      r.battery.r_polarization_ohm = 0.0;
      r.battery.wiring_r_ohm = 0.03;
      runs.push_back(r);
    }
  } else {
    const double temps[] = {5, 35, 20, 12};
    const double press[] = {1020e2, 1000e2, 900e2, 850e2};
    for (int k = 0; k < 4; ++k) {
      RunSetup r;
      r.params = base;
      // density runs share one voltage: sites and days differ, the bench supply does not
      r.battery = benchAt(h == "density" ? 11.1 : volts[k]);
      if (h == "density") {
        r.temp_c = temps[k];
        r.pressure_pa = press[k];
        r.temp_swing_k = 15.0;
      }
      if (h == "drift" || h == "thermal") r.pause_before_s = 120.0;
      runs.push_back(r);
    }
  }
  return runs;
}

// One session on the plant: each run sweeps up and down in 25 us steps, settling `settle_s` per
// point; a row at the end of each point's settling, or at `log_hz` while it settles.
class Session {
 public:
  Session(const GenerateOptions& o, double settle_s, plant::Rng& rng)
      : o_(o), h_(o.hidden), settle_s_(settle_s), rng_(rng), creep_g_per_min_(h_ == "drift" ? 1.2 : 0.0) {}

  std::vector<Row> run(const std::vector<RunSetup>& runs) {
    for (std::size_t run_index = 0; run_index < runs.size(); ++run_index) sweep(runs[run_index], run_index);
    return std::move(rows_);
  }

 private:
  static constexpr double kDt = 0.002;  // the plant's step

  void sweep(const RunSetup& run, std::size_t run_index) {
    plant::Environment env;
    env.temp_c = run.temp_c;
    env.pressure_pa = run.pressure_pa;
    plant::Actuator act(run.params, env);
    plant::PowerSource ps(run.battery);
    const std::vector<std::pair<double, double>> points = pointsOf(h_);
    // the step log starts with its rotor settled at the first set point
    if (h_ == "lag") act.setSpeed_rpm(act.steadyState(points.front().first, kStepBusV).rpm);
    clock_ += run.pause_before_s;
    const double run_start = clock_;
    cell_.fill(act.thrust_g());
    for (const auto& [pulse, dir] : points) {
      act.holdPulse(pulse);
      // sag: the pack also feeds the frame's other motors, 0..8 A that change point by point
      const double other_a = h_ == "sag" ? 8.0 * rng_.uniform() : 0.0;
      const double plate = 0.08 + 0.42 * rng_.uniform();
      double bus_current = 0, bus_v = 0;
      const int steps = static_cast<int>(std::lround(settle_s_ / kDt));
      const int every = o_.log_hz > 0 ? std::max(1, static_cast<int>(std::lround(1.0 / (o_.log_hz * kDt)))) : steps;
      for (int k = 0; k < steps; ++k) {
        const double now = clock_ + k * kDt;
        if (run.temp_swing_k != 0) {
          env.temp_c = run.temp_c + run.temp_swing_k * std::sin(2 * M_PI * (now - run_start) / 23.0);
          act.setEnvironment(env);
        }
        if (h_ != "thermal") act.setWindingTemp_c(25.0);  // thermal effect off: winding at 25 C
        plant::BusLoad load = act.busLoad();
        load.offset_a += other_a;
        bus_v = ps.solveBusVoltage(load);
        bus_current = act.step(kDt, bus_v);
        ps.step(kDt, bus_current + other_a);
        readCell(act.thrust_g());
        if ((k + 1) % every == 0)
          record(now + kDt, run, run_index, act, ps, env, {pulse, dir, other_a, plate, bus_current, bus_v});
      }
      clock_ += settle_s_;
    }
  }

  struct Point {
    double pulse, dir, other_a, plate, bus_current, bus_v;
  };

  // The bench's load-cell low-pass between the thrust and its reading (--bench-filter): the
  // plant's stages (plant/sensors.hpp), stepped with the plant.
  void readCell(double thrust_g) {
    const auto& tau = plant::LoadCellParams().lowpass_tau_s;
    double in = thrust_g;
    for (std::size_t k = 0; k < cell_.size(); ++k) in = cell_[k] += (1 - std::exp(-kDt / tau[k])) * (in - cell_[k]);
  }

  // One row: the bench's reading now.
  void record(double now, const RunSetup& run, std::size_t run_index, const plant::Actuator& act,
              const plant::PowerSource& ps, const plant::Environment& env, const Point& pt) {
    Row r{};
    r.t_s = now;
    r.motor = run.motor;
    r.pwm_us = pt.pulse;
    double force = o_.bench_filter ? cell_.back() : act.thrust_g();
    if (h_ == "plate") {
      const double ratio = run.params.prop.diameter_m / 2 / (4 * pt.plate);
      force /= 1 - ratio * ratio;
    }
    force += creep_g_per_min_ * now / 60.0;
    // the load cell's noise, AR(1) when its samples correlate (a filtered reading)
    const double rho = o_.noise_lag1;
    noise_state_ = rho * noise_state_ + std::sqrt(1 - rho * rho) * (o_.noise_g > 0 ? rng_.normal(o_.noise_g, 4.0) : 0.0);
    r.force_g = force + noise_state_;
    r.vbat_v = h_ == "sag" || h_ == "current_limit" ? ps.restingVoltage_v() : pt.bus_v;
    r.current_a = pt.bus_current + pt.other_a;
    r.rpm = act.rpm();
    r.temp_c = h_ == "thermal" ? act.windingTemp_c() : env.temp_c;
    r.pressure_hpa = env.pressure_pa / 100.0;
    r.dir = pt.dir;
    r.plate_m = pt.plate;
    r.torque_nm = act.torque_nm();
    r.run = static_cast<int>(run_index);
    rows_.push_back(r);
  }

  const GenerateOptions& o_;
  const std::string& h_;
  double settle_s_;
  plant::Rng& rng_;
  double creep_g_per_min_;
  double noise_state_ = 0.0;
  std::array<double, 3> cell_{};
  double clock_ = 0.0;
  std::vector<Row> rows_;
};

Dataset toDataset(const std::vector<Row>& rows, const std::vector<RunSetup>& runs, const std::string& h) {
  Dataset d;
  auto column = [&](const char* name, std::function<double(const Row&)> get) {
    std::vector<double> v;
    for (const auto& r : rows) v.push_back(get(r));
    d.names.push_back(name);
    d.columns.push_back(std::move(v));
  };
  column("run", [](const Row& r) { return static_cast<double>(r.run); });
  column("t_s", [](const Row& r) { return r.t_s; });
  column("motor", [](const Row& r) { return r.motor; });
  column("pwm_us", [](const Row& r) { return r.pwm_us; });
  column("force_g", [](const Row& r) { return r.force_g; });
  column("vbat_v", [](const Row& r) { return r.vbat_v; });
  column("current_a", [](const Row& r) { return r.current_a; });
  column("rpm", [](const Row& r) { return r.rpm; });
  column("temp_c", [](const Row& r) { return r.temp_c; });
  column("dir", [](const Row& r) { return r.dir; });
  if (h == "density") column("pressure_hpa", [](const Row& r) { return r.pressure_hpa; });
  if (h == "plate") column("plate_height_m", [](const Row& r) { return r.plate_m; });
  column("torque_nm", [](const Row& r) { return r.torque_nm; });
  // runs: one per (motor, setup)
  for (std::size_t ri = 0; ri < runs.size(); ++ri)
    d.run_labels.push_back(fmt::format("generated run {} motor {}", ri, runs[ri].motor));
  for (const auto& r : rows) d.run.push_back(r.run);
  return d;
}

void describe(const GenerateOptions& o, const HiddenEffectInfo& info, double settle_s,
              std::vector<std::string>& comments) {
  comments.push_back(fmt::format("thrustcal lab generate --hidden {} --noise-g {} --seed {} (plant preset {}){}",
                                 o.hidden, o.noise_g, o.seed, o.preset,
                                 o.log_hz > 0 ? fmt::format(", logged at {} Hz, {} s per point", o.log_hz, settle_s)
                                              : std::string()));
  comments.push_back("hidden effect: " + info.description);
  if (!info.right_effect.empty())
    comments.push_back(fmt::format("a model without it: {}; the effect that explains it: {}; "
                                   "the variable to blame: {}",
                                   info.start_model, info.right_effect, info.responsible));
  comments.push_back(fmt::format("load-cell noise: {} g (one standard deviation){}", o.noise_g,
                                 o.noise_lag1 > 0 ? fmt::format(", lag-1 autocorrelation {}", o.noise_lag1) : ""));
  if (o.bench_filter)
    comments.push_back("the force read through the plant's load-cell low-pass (its stages: plant/sensors.hpp)");
}

}  // namespace

Dataset generate(const GenerateOptions& o, std::vector<std::string>* comments) {
  const HiddenEffectInfo& info = hiddenInfo(o.hidden);
  if (!(o.noise_g >= 0)) throw std::invalid_argument("--noise-g must be >= 0");
  if (!(o.noise_lag1 >= 0 && o.noise_lag1 <= 0.95))
    throw std::invalid_argument("--noise-lag1 must be within 0..0.95 (the noise's lag-1 autocorrelation)");
  const std::string& h = o.hidden;
  const plant::ActuatorParams base = plant::presetParams(o.preset);
  plant::Rng rng(o.seed * 7919 + 13);
  const std::vector<RunSetup> runs = runSetups(h, base, o.seed);
  if (!(o.settle_s >= 0) || !(o.log_hz >= 0) || o.log_hz > 1.0 / 0.002)
    throw std::invalid_argument("--settle-s must be >= 0 and --log-hz within 0..500 (the plant steps at 500 Hz)");
  const double settle_s = o.settle_s > 0 ? o.settle_s : h == "drift" || h == "thermal" ? 2.0 : 0.5;
  GenerateOptions with_rate = o;
  if (h == "lag" && !(o.log_hz > 0)) with_rate.log_hz = 500;  // a step log: every sample of the bench's ADC
  const std::vector<Row> rows = Session(with_rate, settle_s, rng).run(runs);
  Dataset d = toDataset(rows, runs, h);
  if (comments) {
    describe(with_rate, info, settle_s, *comments);
    for (const auto& t : stepTruth(o))
      comments->push_back(fmt::format("truth: motor {} tau_up {:.4f} s, tau_down {:.4f} s (the plant's rotor speed, "
                                      "{:.0f} <-> {:.0f} us at {:.1f} V)",
                                      t.motor, t.tau_up_s, t.tau_down_s, t.from_us, t.to_us, t.bus_v));
  }
  return d;
}

std::vector<StepTruth> stepTruth(const GenerateOptions& o) {
  std::vector<StepTruth> out;
  if (o.hidden != "lag") return out;
  for (const RunSetup& r : runSetups(o.hidden, plant::presetParams(o.preset), o.seed)) {
    StepTruth t;
    t.motor = r.motor;
    t.from_us = kStepLowUs;
    t.to_us = kStepHighUs;
    t.bus_v = kStepBusV;
    t.tau_up_s = plant::stepTimeConstant_s(r.params, kStepBusV, kStepLowUs, kStepHighUs);
    t.tau_down_s = plant::stepTimeConstant_s(r.params, kStepBusV, kStepHighUs, kStepLowUs);
    out.push_back(t);
  }
  return out;
}

#else

Dataset generate(const GenerateOptions&, std::vector<std::string>*) {
  throw std::runtime_error("this build has no plant model (tools/plant): cannot generate data");
}

std::vector<StepTruth> stepTruth(const GenerateOptions&) {
  throw std::runtime_error("this build has no plant model (tools/plant): no step truth");
}

#endif

}  // namespace lab
