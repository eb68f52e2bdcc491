#include "plant/cli.hpp"

#include <fmt/core.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "plant/plant.hpp"
#include "plant/rig_cli.hpp"

namespace plant {

namespace {

struct Options {
  std::string preset = "kv1100_9x4.7";
  double supply_v = 11.1;
  double lipo_soc = -1.0;
  double step_us = 20.0;
  double from_us = 1300.0;
  double to_us = 1500.0;
  double temp_c = 20.0;
  double pressure_pa = 101325.0;
  bool json = false;
};

void addPreset(CLI::App* cmd, Options& o) {
  const CLI::Validator known_preset(
      [](std::string& name) -> std::string {
        if (findPreset(name)) return {};
        std::string known;
        for (const Preset& p : presets()) known += (known.empty() ? "" : ", ") + p.params.name;
        return "unknown preset '" + name + "'; use one of: " + known;
      },
      "PRESET");
  cmd->add_option("--preset", o.preset, "actuator preset (see `thrustcal plant presets`)")
      ->capture_default_str()
      ->check(known_preset);
}

// Runs a command; any failure becomes a one-line message and exit code 1.
template <class Fn>
std::function<void()> guarded(Fn fn) {
  return [fn] {
    try {
      fn();
    } catch (const std::exception& e) {
      fmt::print(stderr, "thrustcal plant: {}\n", e.what());
      throw CLI::RuntimeError(1);
    }
  };
}

void cmdPresets(const Options& o) {
  if (o.json) {
    nlohmann::json j = nlohmann::json::array();
    for (const Preset& p : presets()) {
      j.push_back({{"name", p.params.name},
                   {"description", p.description},
                   {"kv_rpm_per_v", p.params.motor.kv_rpm_per_v},
                   {"r_winding_ohm", p.params.motor.r_winding_ohm},
                   {"r_esc_ohm", p.params.esc.r_esc_ohm},
                   {"diameter_m", p.params.prop.diameter_m},
                   {"ct", {p.params.prop.ct_low, p.params.prop.ct_high}},
                   {"cp", {p.params.prop.cp_low, p.params.prop.cp_high}}});
    }
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("{:<15} {:>6} {:>7} {:>7} {:>6} {:>13} {:>13}  {}\n", "preset", "Kv", "R_w ohm",
             "R_esc", "D m", "C_T lo..hi", "C_P lo..hi", "description");
  for (const Preset& p : presets()) {
    const ActuatorParams& a = p.params;
    fmt::print("{:<15} {:>6.0f} {:>7.3f} {:>7.3f} {:>6.4f} {:>6.3f}..{:<6.3f} {:>6.3f}..{:<6.3f}  {}\n",
               a.name, a.motor.kv_rpm_per_v, a.motor.r_winding_ohm, a.esc.r_esc_ohm,
               a.prop.diameter_m, a.prop.ct_low, a.prop.ct_high, a.prop.cp_low, a.prop.cp_high,
               p.description);
  }
}

void cmdCurve(const Options& o) {
  BenchParams bp = o.lipo_soc >= 0.0 ? BenchParams::thesis(o.preset)
                                     : BenchParams::thesisOnSupply(o.supply_v, o.preset);
  if (o.lipo_soc >= 0.0) bp.power.soc = o.lipo_soc;
  bp.env.temp_c = o.temp_c;
  bp.env.pressure_pa = o.pressure_pa;
  const Bench bench(bp);
  nlohmann::json rows = nlohmann::json::array();
  if (!o.json) {
    if (o.lipo_soc >= 0.0) {
      fmt::print("# {} on a 3S LiPo at {:.0f} % charge (resting {:.2f} V), air {:.1f} C {:.0f} Pa\n",
                 o.preset, 100.0 * o.lipo_soc, bench.restingVoltage_v(), o.temp_c, o.pressure_pa);
    } else {
      fmt::print("# {} on a bench supply at {:.2f} V (limit {:.2f} A), air {:.1f} C {:.0f} Pa\n",
                 o.preset, o.supply_v, bp.power.current_limit_a, o.temp_c, o.pressure_pa);
    }
    fmt::print("# steady state, cold motor; bus_v at the ESC (after wiring / internal resistance)\n");
    fmt::print("{:>7} {:>6} {:>9} {:>9} {:>8} {:>8} {:>8}\n", "pwm_us", "duty", "thrust_g",
               "current_a", "rpm", "bus_v", "motor_a");
  }
  for (double pwm = 1000.0; pwm <= 2000.0 + 1e-9; pwm += o.step_us) {
    const OperatingPoint op = bench.steadyState(pwm);
    if (o.json) {
      rows.push_back({{"pwm_us", pwm}, {"duty", op.duty}, {"force_g", op.thrust_g},
                      {"current_a", op.bus_current_a}, {"rpm", op.rpm}, {"vbat_v", op.bus_v},
                      {"motor_current_a", op.motor_current_a}});
    } else {
      fmt::print("{:>7.0f} {:>6.3f} {:>9.1f} {:>9.2f} {:>8.0f} {:>8.2f} {:>8.2f}\n", pwm, op.duty,
                 op.thrust_g, op.bus_current_a, op.rpm, op.bus_v, op.motor_current_a);
    }
  }
  if (o.json) fmt::print("{}\n", rows.dump(2));
}

void cmdTable51(const Options& o) {
  const auto rows = runTable51(presetParams(o.preset));
  double worst = 0.0;
  for (const auto& r : rows) worst = std::max(worst, std::fabs(r.diff_us));
  if (o.json) {
    nlohmann::json j = nlohmann::json::array();
    for (const auto& r : rows) {
      j.push_back({{"supply_v", r.supply_v}, {"measured_pwm_us", r.measured_pwm_us},
                   {"model_pwm_us", r.model_pwm_us}, {"diff_us", r.diff_us}});
    }
    fmt::print("{}\n", nlohmann::json{{"preset", o.preset}, {"rows", j}, {"max_abs_diff_us", worst}}.dump(2));
    return;
  }
  fmt::print("# thesis table 5.1: PWM for {:.0f} g on the bench supply (6.32 A), {}\n",
             kTable51Thrust_g, o.preset);
  fmt::print("{:>9} {:>12} {:>10} {:>8}\n", "supply_v", "measured_us", "model_us", "diff_us");
  for (const auto& r : rows) {
    fmt::print("{:>9.1f} {:>12.0f} {:>10.1f} {:>+8.1f}\n", r.supply_v, r.measured_pwm_us,
               r.model_pwm_us, r.diff_us);
  }
  fmt::print("# max |diff| {:.1f} us (fidelity target: 10 us)\n", worst);
}

void cmdDatasheet(const Options& o) {
  const auto preset = findPreset(o.preset);
  if (!preset) {
    presetParams(o.preset);  // throws with the list of names
    return;
  }
  const DatasheetCheck c = checkDatasheet(preset->params, preset->datasheet);
  const DatasheetPoint& d = c.datasheet;
  auto pct = [](double model, double ref) { return 100.0 * (model - ref) / ref; };
  if (o.json) {
    fmt::print("{}\n", nlohmann::json{{"preset", o.preset},
                                      {"bus_v", d.bus_v},
                                      {"datasheet", {{"throttle", d.throttle}, {"thrust_g", d.thrust_g},
                                                     {"current_a", d.current_a}, {"rpm", d.rpm}}},
                                      {"model_at_rpm", {{"throttle", c.model_throttle},
                                                        {"thrust_g", c.model_thrust_g},
                                                        {"current_a", c.model_current_a}}},
                                      {"model_at_throttle", {{"thrust_g", c.at_throttle_thrust_g},
                                                             {"current_a", c.at_throttle_current_a},
                                                             {"rpm", c.at_throttle_rpm}}}}
                           .dump(2));
    return;
  }
  fmt::print("# {} vs T-motor datasheet at {:.1f} V (ideal supply, cold motor, 20 C)\n", o.preset, d.bus_v);
  fmt::print("{:<28} {:>10} {:>10} {:>8}\n", "", "datasheet", "model", "diff");
  fmt::print("at the datasheet rpm {:>6.0f}:\n", d.rpm);
  fmt::print("{:<28} {:>10.2f} {:>10.2f} {:>+7.1f}%\n", "  throttle (ESC duty)", d.throttle, c.model_throttle, pct(c.model_throttle, d.throttle));
  fmt::print("{:<28} {:>10.0f} {:>10.0f} {:>+7.1f}%\n", "  thrust g", d.thrust_g, c.model_thrust_g, pct(c.model_thrust_g, d.thrust_g));
  fmt::print("{:<28} {:>10.2f} {:>10.2f} {:>+7.1f}%\n", "  current A", d.current_a, c.model_current_a, pct(c.model_current_a, d.current_a));
  fmt::print("at the datasheet throttle {:.0f} % taken as ESC duty:\n", 100.0 * d.throttle);
  fmt::print("{:<28} {:>10.0f} {:>10.0f} {:>+7.1f}%\n", "  thrust g", d.thrust_g, c.at_throttle_thrust_g, pct(c.at_throttle_thrust_g, d.thrust_g));
  fmt::print("{:<28} {:>10.2f} {:>10.2f} {:>+7.1f}%\n", "  current A", d.current_a, c.at_throttle_current_a, pct(c.at_throttle_current_a, d.current_a));
  fmt::print("{:<28} {:>10.0f} {:>10.0f} {:>+7.1f}%\n", "  rpm", d.rpm, c.at_throttle_rpm, pct(c.at_throttle_rpm, d.rpm));
}

void cmdStep(const Options& o) {
  const double tau = stepTimeConstant_s(presetParams(o.preset), o.supply_v, o.from_us, o.to_us);
  const double tau_down = stepTimeConstant_s(presetParams(o.preset), o.supply_v, o.to_us, o.from_us);
  if (o.json) {
    fmt::print("{}\n", nlohmann::json{{"preset", o.preset}, {"bus_v", o.supply_v}, {"from_us", o.from_us},
                                      {"to_us", o.to_us}, {"tau_up_s", tau}, {"tau_down_s", tau_down}}.dump(2));
    return;
  }
  fmt::print("{} at {:.2f} V: rpm time constant {:.0f} -> {:.0f} us: {:.3f} s, back down: {:.3f} s\n",
             o.preset, o.supply_v, o.from_us, o.to_us, tau, tau_down);
}

void cmdSpeed(const Options& o) {
  // Host cost of one 1 ms plant step (wall clock; informative, not a test).
  Bench bench(BenchParams::thesis(o.preset));
  bench.actuator().holdPulse(1500.0);
  const int steps = 2'000'000;
  double sink = 0.0;
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < steps; ++i) {
    bench.step(0.001);
    if ((i & 7) == 0) sink += bench.adcMillivolts(i & 1);
  }
  const auto t1 = std::chrono::steady_clock::now();
  volatile double keep = sink;  // the ADC samples must not be optimized away
  (void)keep;
  std::array<ActuatorParams, 4> m;
  m.fill(presetParams(o.preset));
  QuadFrame quad(QuadFrameParams{}, m);
  for (int i = 0; i < 4; ++i) quad.holdPulse(i, 1500.0);
  const int qsteps = 500'000;
  const auto t2 = std::chrono::steady_clock::now();
  for (int i = 0; i < qsteps; ++i) quad.step(0.001);
  const auto t3 = std::chrono::steady_clock::now();
  const double bench_ns = std::chrono::duration<double, std::nano>(t1 - t0).count() / steps;
  const double quad_ns = std::chrono::duration<double, std::nano>(t3 - t2).count() / qsteps;
  if (o.json) {
    fmt::print("{}\n", nlohmann::json{{"bench_step_ns", bench_ns}, {"quad_step_ns", quad_ns}}.dump(2));
  } else {
    fmt::print("Bench::step (1 ms, incl. 1 ADC sample per 8 steps): {:.0f} ns\n", bench_ns);
    fmt::print("QuadFrame::step (1 ms, four actuators):             {:.0f} ns\n", quad_ns);
    fmt::print("simulated {:.0f} s of bench in {:.3f} s of host time ({:.0f}x real time)\n",
               steps * 0.001, std::chrono::duration<double>(t1 - t0).count(),
               steps * 0.001 / std::chrono::duration<double>(t1 - t0).count());
  }
}

}  // namespace

void registerCommands(CLI::App& app) {
  auto opts = std::make_shared<Options>();
  CLI::App* plant = app.add_subcommand(
      "plant", "The physical model behind the virtual bench: ESC + motor + propeller, power, sensors");
  plant->require_subcommand(1);

  addRigCommands(plant);
  CLI::App* pre = plant->add_subcommand("presets", "List the actuator presets");
  pre->add_flag("--json", opts->json, "print JSON");
  pre->callback(guarded([opts] { cmdPresets(*opts); }));

  CLI::App* curve = plant->add_subcommand(
      "curve", "Steady-state thrust / current / rpm vs PWM on the thesis bench");
  addPreset(curve, *opts);
  curve->add_option("--supply", opts->supply_v, "bench supply voltage, V (6.32 A limit)")
      ->capture_default_str()->check(CLI::Range(1.0, 30.0));
  curve->add_option("--lipo-soc", opts->lipo_soc, "use a 3S LiPo at this state of charge (0..1) instead")
      ->check(CLI::Range(0.0, 1.0));
  curve->add_option("--step", opts->step_us, "PWM step, us")->capture_default_str()->check(CLI::Range(1.0, 500.0));
  curve->add_option("--temp", opts->temp_c, "air temperature, C")->capture_default_str();
  curve->add_option("--pressure", opts->pressure_pa, "air pressure, Pa")->capture_default_str();
  curve->add_flag("--json", opts->json, "print JSON rows");
  curve->callback(guarded([opts] { cmdCurve(*opts); }));

  CLI::App* t51 = plant->add_subcommand(
      "table51", "Fidelity: PWM for 300 g at 9.7..14 V, thesis table 5.1 vs model");
  addPreset(t51, *opts);
  t51->add_flag("--json", opts->json, "print JSON");
  t51->callback(guarded([opts] { cmdTable51(*opts); }));

  CLI::App* ds = plant->add_subcommand("datasheet", "Fidelity: the T-motor datasheet point vs model");
  addPreset(ds, *opts);
  ds->add_flag("--json", opts->json, "print JSON");
  ds->callback(guarded([opts] { cmdDatasheet(*opts); }));

  CLI::App* st = plant->add_subcommand("step", "Speed time constant for a PWM step");
  addPreset(st, *opts);
  st->add_option("--supply", opts->supply_v, "bus voltage, V")->capture_default_str();
  st->add_option("--from", opts->from_us, "PWM before the step, us")->capture_default_str();
  st->add_option("--to", opts->to_us, "PWM after the step, us")->capture_default_str();
  st->add_flag("--json", opts->json, "print JSON");
  st->callback(guarded([opts] { cmdStep(*opts); }));

  CLI::App* sp = plant->add_subcommand("speed", "Host time per plant step (wall clock)");
  addPreset(sp, *opts);
  sp->add_flag("--json", opts->json, "print JSON");
  sp->callback(guarded([opts] { cmdSpeed(*opts); }));
}

}  // namespace plant
