// `thrustcal sim swap --json FILE` (sim/swap.hpp): runs[] and targets[] as docs/architecture.md fixes them
// ("Interfaces other people script against"), with what made them beside.
#include <cmath>
#include <nlohmann/json.hpp>

#include "sim/swap.hpp"

namespace sim::swap {

namespace {

// A figure that could not be measured (no rise, never settled) is null, not NaN.
nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

nlohmann::json runJson(const RunResult& r, int step_deg) {
  const StepMetrics& m = r.metrics;
  return {{"rig", airRigName(r.spec.rig)},
          {"mode", runModeName(r.spec)},
          {"part", r.spec.part},
          {"gains", r.spec.mode == Mode::kPeer ? "own" : gainsName(r.spec.gains)},
          {"axis", r.spec.axis},
          {"step_deg", step_deg},
          {"seed", r.spec.imu_seed},
          {"rise_s", num(m.rise_s)},
          {"overshoot_pct", num(m.overshoot_pct)},
          {"settling_s", num(m.settling_s)},
          {"sse_deg", num(m.sse)},
          {"itae", num(m.itae)},
          {"integrator", num(r.integrator_mnm)},
          {"hover_pwm_spread_us", num(r.hover_pwm_spread_us)},
          {"y0_deg", num(r.y0_deg)},
          {"final_deg", num(m.final_value)},
          {"peak_deg", num(m.peak)},
          {"steps", r.step_rise_s.size()},
          {"step_rise_s", r.step_rise_s},
          {"csv", r.csv_path}};
}

nlohmann::json setupJson(const SwapOptions& o) {
  nlohmann::json parts = nlohmann::json::array();
  for (const std::string& name : o.parts) {
    const Part& p = findPart(name);
    parts.push_back({{"part", p.name},
                     {"preset", p.preset},
                     {"seed", p.seed},
                     {"thrust_scale", p.thrust_scale},
                     {"description", p.description}});
  }
  return {{"stock", {{"preset", o.stock_preset}, {"seeds", o.stock_seeds}, {"variation", o.variation}}},
          {"swapped_slot", kSwapSlot},
          {"parts", parts},
          {"gains", {{"pd", o.pd_gains}, {"pid", {o.pd_gains[0], o.pid_ki, o.pd_gains[2]}}}},
          {"hover_g_per_motor", o.hover_g},
          {"step_deg", o.step_deg},
          {"settle_s", {{"pd", o.settle_s}, {"pid", o.pid_settle_s}}},
          {"level", o.level},
          {"window_s", o.window_s},
          {"steps", o.steps},
          {"dyn_steps", stepsOf(o, Mode::kForceDyn)},
          {"part_mass_only", o.part_mass_only},
          {"reaction_torque", !o.no_reaction_torque},
          {"log_period_s", o.log_period_s},
          {"gimbal_layout", "plus"},
          {"calibration_model", gatherModelName(o.model)},
          {"dyn", {{"from", o.dyn_from},
                   {"reference_ms", o.dyn_reference_ms > 0 ? nlohmann::json(o.dyn_reference_ms)
                                                           : nlohmann::json("slowest")}}},
          {"peer", o.peer ? nlohmann::json({{"name", o.peer->name},
                                            {"profile", o.peer->file},
                                            {"elf", o.peer->elf},
                                            {"layout", o.peer->layout},
                                            {"rc", o.peer->rc.text}})
                          : nlohmann::json(nullptr)}};
}

nlohmann::json calibrationJson(const Calibration& c) {
  nlohmann::json parts = nlohmann::json::array();
  for (const PartCalibration& p : c.parts)
    parts.push_back(
        {{"part", p.part},
         {"slots", p.part == kStock ? nlohmann::json({0, 1, 2, 3}) : nlohmann::json({kSwapSlot})},
         {"eeprom", p.eeprom_path},
         {"cached", p.cached},
         {"curve_error_max_g", p.cached ? nlohmann::json(nullptr) : nlohmann::json(p.curve_error_max_g)},
         {"other_slots_unchanged", p.part == kStock ? nlohmann::json(nullptr) : nlohmann::json(true)}});
  nlohmann::json ap;
  for (const auto& [name, value] : c.modes.ardupilot_params) ap[name] = value;
  return {{"parts", parts},
          {"pwm", {{"hover_us", c.modes.hover_us}, {"slope_g_per_us", c.modes.slope_g_per_us}}},
          {"ardupilot",
           {{"params", ap},
            {"full_g", c.modes.ardupilot_full_g},
            {"rows", c.modes.ardupilot_rows},
            {"rms_g", c.modes.ardupilot_rms_g},
            {"console", c.modes.ardupilot_lines}}},
          {"stock_sweeps", c.stock_sweeps}};
}

}  // namespace

nlohmann::json SwapResult::toJson() const {
  nlohmann::json runs_json = nlohmann::json::array();
  for (const RunResult& r : runs) runs_json.push_back(runJson(r, options.step_deg));
  nlohmann::json targets_json = nlohmann::json::array();
  for (const Target& t : targets)
    targets_json.push_back({{"section", "swap"},
                            {"target", t.target},
                            {"figure", t.figure},
                            {"wanted", t.wanted},
                            {"met", t.met},
                            {"what", t.what},
                            {"part", t.part},
                            {"rig", t.rig},
                            {"mode", t.mode}});
  nlohmann::json dyn = nlohmann::json::array();
  for (const Dynamics& d : dynamics.parts)
    dyn.push_back({{"part", d.part},
                   {"tau_s", d.tau_s},
                   {"stock_tau_s", d.stock_tau_s},
                   {"tau_change_pct", 100.0 * (d.tau_s / d.stock_tau_s - 1.0)},
                   {"rise_change_pct", num(d.rise_change_pct)}});
  return {{"scenario", "swap"},
          {"units",
           {{"rise_s", "s"},
            {"overshoot_pct", "% of the step"},
            {"settling_s", "s, 2 % band"},
            {"sse_deg", "deg"},
            {"itae", "deg s^2"},
            {"integrator", "mN m"},
            {"hover_pwm_spread_us", "us"}}},
          {"setup", setupJson(options)},
          {"calibration", calibrationJson(calibration)},
          {"dynamics", {{"stock_tau_s", dynamics.stock_tau_s}, {"parts", dyn}}},
          {"runs", runs_json},
          {"targets", targets_json},
          {"sim",
           {{"flights", runs.size()},
            {"simulated_s", simulated_s},
            {"flight_wall_s", flight_wall_s},
            {"wall_s", wall_s},
            {"realtime_factor", flight_wall_s > 0 ? simulated_s / flight_wall_s : 0}}}};
}

}  // namespace sim::swap
