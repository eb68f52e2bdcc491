// One flight of the swap experiment (sim/swap.hpp): fly booted on the rig with the part's EEPROM,
// set up over its console as a user would, armed, level for a moment, then the step; the
// figures from the rig's true attitude, the integrator from fly's status.
#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <regex>
#include <stdexcept>

#include "sim/console.hpp"
#include "sim/swap.hpp"
#include "swap_flight_parts.hpp"
#include "thrustcal/limits.hpp"

namespace sim::swap {

namespace {

constexpr double kKeepAliveS = 0.1;      // fly disarms after 500 ms without a line
constexpr double kBaselineS = 0.1;       // y0: the mean true angle over this before the step
constexpr double kSpreadWindowS = 0.25;  // the hover pulses: their means over this before the step

// The console lines that set a flight up, in order (layout, gains, the mode and what it needs).
std::vector<std::string> setupLines(const SwapOptions& o, const Calibration& c, const RunSpec& r) {
  const bool seesaw = r.rig == AirRig::kSeesaw;
  const int ki = r.gains == Gains::kPid ? o.pid_ki : o.pd_gains[1];
  std::vector<std::string> lines = {seesaw ? "layout seesaw" : "layout plus",
                                    fmt::format("gains {} {} {}", o.pd_gains[0], ki, o.pd_gains[2])};
  const long thrust_g = std::lround(o.hover_g * (seesaw ? 2 : 4));
  switch (r.mode) {
    case Mode::kForce:
      lines.insert(lines.end(), {"mode force", fmt::format("thrust {}", thrust_g)});
      break;
    case Mode::kForceDyn:
      lines.insert(lines.end(), {"mode force",
                                 o.dyn_reference_ms > 0
                                     ? fmt::format("dyn on {} {}", o.dyn_reference_ms, o.dyn_reference_ms)
                                     : std::string("dyn on"),
                                 fmt::format("thrust {}", thrust_g)});
      break;
    case Mode::kGeneric:
      lines.insert(lines.end(), {"mode generic 0", fmt::format("thrust {}", thrust_g)});
      break;
    case Mode::kPwm:
      lines.insert(lines.end(),
                   {fmt::format("hover {} {}", c.modes.hover_us, std::lround(c.modes.slope_g_per_us * 1000)),
                    "mode pwm"});
      break;
    case Mode::kArduPilot:
      lines.insert(lines.end(), c.modes.ardupilot_lines.begin(), c.modes.ardupilot_lines.end());
      lines.insert(lines.end(), {"mode ardupilot", fmt::format("thrust {}", thrust_g)});
      break;
    case Mode::kPeer:
      throw std::logic_error("a peer's run is not fly's (flyPeerRun)");
  }
  return lines;
}

// A part heavier than the motor it replaced tilts the seesaw (its weight sits 0.225 m out): as on
// a real rig, a counterweight of the difference beside motor 0 levels the beam again, motor and
// propeller each at their own height. The gimbal turns about the centre of gravity.
void counterweigh(plant::SeesawParams& s, const plant::ActuatorParams& replaced,
                  const plant::ActuatorParams& part) {
  const double motor_kg = (part.motor.mass_g - replaced.motor.mass_g) / 1000.0;
  const double prop_kg = (part.prop.mass_g - replaced.prop.mass_g) / 1000.0;
  if (motor_kg != 0) s.parts.push_back({"counterweight (motor)", motor_kg, s.arm_m, s.motor_height_m, 0.0});
  if (prop_kg != 0) s.parts.push_back({"counterweight (propeller)", prop_kg, s.arm_m, s.prop_height_m, 0.0});
}

}  // namespace

AirframeOptions rigOptions(const SwapOptions& o, const RunSpec& r) {
  AirframeOptions a;
  a.rig = r.rig;
  a.gimbal.layout = plant::Layout::kPlus;  // the thesis's Iqarus
  for (int i = 0; i < 4; ++i)
    a.motors[i] = actuatorOf({kStock, o.stock_preset, o.stock_seeds[i], 1.0, ""}, o.variation);
  if (r.part != kStock) {
    const plant::ActuatorParams replaced = a.motors[kSwapSlot];
    a.motors[kSwapSlot] = actuatorOf(findPart(r.part), o.variation);
    if (o.part_mass_only) {  // the stock motor with the part's weight on it
      plant::ActuatorParams weighted = replaced;
      weighted.motor.mass_g = a.motors[kSwapSlot].motor.mass_g;
      weighted.prop.mass_g = a.motors[kSwapSlot].prop.mass_g;
      a.motors[kSwapSlot] = weighted;
    }
    if (r.rig == AirRig::kSeesaw) counterweigh(a.seesaw, replaced, a.motors[kSwapSlot]);
  }
  a.gimbal.common.reaction_torque = a.seesaw.common.reaction_torque = !o.no_reaction_torque;
  a.imu_params.seed = r.imu_seed;
  a.log_period_s = o.log_period_s;
  return a;
}

namespace {

// `s` simulated seconds with a keep-alive line every 100 ms.
void flyFor(AirframeRig& rig, double s) {
  for (double done = 0; done < s - 1e-9; done += kKeepAliveS) {
    rig.board().sendText("\r");
    rig.run(std::min(kKeepAliveS, s - done));
  }
}

void mustSay(Console& con, const std::string& line, const RunSpec& r) {
  for (const std::string& l : con.command(line))
    if (l.rfind("error:", 0) == 0)
      throw std::runtime_error(fmt::format("{}: fly refused \"{}\": {}\n{}", runId(r), line, l, con.tail()));
}

// fly's `level` on the rig at rest (level, still): the accelerometer's trim, as a user calibrates
// the accelerometer before flying.
void levelled(Console& con, const RunSpec& r) {
  mustSay(con, "level", r);
  const std::vector<std::string> m = con.expect("^(level: accelerometer trim .*|error: level refused.*)$", 3.0);
  if (m[0].rfind("error:", 0) == 0)
    throw std::runtime_error(fmt::format("{}: fly refused to level on the rig at rest: {}\n{}", runId(r), m[0], con.tail()));
  con.expectText("imu: gyro bias", 1.0);
  con.waitPrompt(1.0);
}

// Boots fly, levels and sets it up, arms it and waits out the spool-up; returns the spool-up's
// length.
double armed(AirframeRig& rig, Console& con, const std::vector<std::string>& lines, const RunSpec& r,
             bool level) {
  con.expectText("imu: gyro bias", 5.0);
  con.waitPrompt(1.0);
  if (level) levelled(con, r);
  rig.run(
      std::max(0.0, tc::kArmMs / 1000.0 + 0.1 - rig.board().timeS()));  // the ESCs' time at the stop pulse
  for (const std::string& line : lines) mustSay(con, line, r);
  const auto reply = con.command("arm");
  std::smatch m;
  static const std::regex kSpool("spooling up for (\\d+) ms");
  if (reply.empty() || reply[0].rfind("armed:", 0) != 0 || !std::regex_search(reply[0], m, kSpool))
    throw std::runtime_error(fmt::format("{}: fly did not arm\n{}", runId(r), con.tail()));
  return std::stod(m[1]) / 1000.0;
}

double integratorOf(Console& con, const RunSpec& r) {
  static const std::regex kLine("^integrators: roll (-?[0-9.]+) pitch (-?[0-9.]+) yaw (-?[0-9.]+) mN m");
  for (const std::string& l : con.command("status")) {
    std::smatch m;
    if (std::regex_search(l, m, kLine)) return std::stod(m[r.axis == "roll" ? 1 : 2]);
  }
  throw std::runtime_error(fmt::format("{}: fly's status has no integrators line\n{}", runId(r), con.tail()));
}

double angleOf(const AirSample& s, const std::string& axis) {
  return axis == "roll" ? s.truth.roll_deg : s.truth.pitch_deg;
}

}  // namespace

// The setpoint at `t` of a flight whose steps came at `t_steps` (each held `window_s`).
double setpointAt(double t, const std::vector<double>& t_steps, double window_s, double sp_deg) {
  for (const double ts : t_steps)
    if (t >= ts && t < ts + window_s + 1e-9) return sp_deg;
  return 0.0;
}

void writeSeries(const std::string& path, const std::vector<AirSample>& rows, const std::vector<double>& t_steps,
                 double window_s, const RunSpec& r, double sp_deg) {
  std::ofstream out(path, std::ios::trunc);
  if (!out) throw std::runtime_error(fmt::format("{}: cannot write the time series; check --out-dir", path));
  const int motors = rows.empty() ? 0 : rows.front().motors;
  const double t0 = t_steps.front();
  out << fmt::format("# thrustcal sim swap: {} (the rig's truth; t from the first step, {} step(s))\n", runId(r),
                     t_steps.size());
  out << "t_s,sp_deg,angle_deg,roll_deg,pitch_deg,yaw_deg";
  for (int i = 0; i < motors; ++i) out << fmt::format(",pulse{}_us", i);
  for (int i = 0; i < motors; ++i) out << fmt::format(",force{}_g", i);
  out << "\n";
  for (const AirSample& s : rows) {
    const double t = s.truth.t_s - t0;
    out << fmt::format("{:.4f},{},{:.3f},{:.3f},{:.3f},{:.3f}", t,
                       setpointAt(s.truth.t_s, t_steps, window_s, sp_deg), angleOf(s, r.axis), s.truth.roll_deg,
                       s.truth.pitch_deg, s.truth.yaw_deg);
    for (int i = 0; i < motors; ++i) out << fmt::format(",{:.1f}", s.pulse_us[i]);
    for (int i = 0; i < motors; ++i) out << fmt::format(",{:.1f}", s.thrust_g[i]);
    out << "\n";
  }
}

namespace {

double settleOf(const SwapOptions& o, const RunSpec& r) {
  return r.gains == Gains::kPid ? o.pid_settle_s : o.settle_s;
}

// The mean of each figure over the steps (NaN, a step that never rose or settled, stays NaN).
StepMetrics meanOf(const std::vector<StepMetrics>& steps) {
  StepMetrics m;
  m.rise_s = m.overshoot_pct = m.settling_s = m.sse = m.itae = m.final_value = m.peak = 0;
  for (const StepMetrics& s : steps) {
    m.rise_s += s.rise_s, m.overshoot_pct += s.overshoot_pct, m.settling_s += s.settling_s;
    m.sse += s.sse, m.itae += s.itae, m.final_value += s.final_value, m.peak += s.peak;
  }
  const double n = static_cast<double>(steps.size());
  m.rise_s /= n, m.overshoot_pct /= n, m.settling_s /= n, m.sse /= n, m.itae /= n, m.final_value /= n, m.peak /= n;
  return m;
}

}  // namespace

// The rows of the rig's log from the level flight before the step to the window's end.
std::vector<AirSample> windowOf(const std::vector<AirSample>& log, double t_step, double settle_s,
                                double window_s) {
  std::vector<AirSample> rows;
  for (const AirSample& s : log)
    if (s.truth.t_s >= t_step - settle_s && s.truth.t_s <= t_step + window_s + 1e-9) rows.push_back(s);
  return rows;
}

// The figures of the step (the window's rows, t from the step) and of the level flight before it.
void measure(RunResult& res, const std::vector<AirSample>& rows, double t_step, const SwapOptions& o) {
  std::vector<double> t, y, base_t;
  std::vector<std::vector<double>> pulses;
  double base = 0;
  for (const AirSample& s : rows) {
    const double ts = s.truth.t_s - t_step;
    t.push_back(ts);
    y.push_back(angleOf(s, res.spec.axis));
    if (ts < 0 && ts >= -kBaselineS) base += y.back(), base_t.push_back(ts);
    pulses.emplace_back(s.pulse_us.begin(), s.pulse_us.begin() + s.motors);
  }
  if (base_t.empty()) throw std::runtime_error(runId(res.spec) + ": no sample before the step");
  res.y0_deg = base / static_cast<double>(base_t.size());
  StepSpec spec;
  spec.y0 = res.y0_deg;
  spec.target = o.step_deg;
  res.metrics = stepMetrics(t, y, spec);
  res.hover_pwm_spread_us = meanSpread(t, pulses, -kSpreadWindowS, 0.0);
}

std::string runModeName(const RunSpec& r) {
  return r.mode == Mode::kPeer ? "peer:" + r.peer : std::string(modeName(r.mode));
}

int stepsOf(const SwapOptions& o, Mode mode) {
  return std::max(1, mode == Mode::kForceDyn && o.dyn_steps > 0 ? o.dyn_steps : o.steps);
}

std::string runId(const RunSpec& r) {
  if (r.mode == Mode::kPeer)  // its own gains
    return fmt::format("{}_peer-{}_{}_{}_s{}", airRigName(r.rig), r.peer, r.part, r.axis, r.imu_seed);
  return fmt::format("{}_{}_{}_{}_{}_s{}", airRigName(r.rig), modeName(r.mode), gainsName(r.gains), r.part,
                     r.axis, r.imu_seed);
}

RunResult flyRun(const SwapOptions& o, const Calibration& c, const RunSpec& r, const std::string& csv_path) {
  const auto wall0 = std::chrono::steady_clock::now();
  RunResult res;
  res.spec = r;
  AirframeRig rig(o.fly_elf, rigOptions(o, r));
  const PartCalibration& records = c.of(o.part_mass_only ? std::string(kStock) : r.part);
  rig.board().setEeprom(r.mode == Mode::kForceDyn ? records.eeprom_dyn : records.eeprom);
  Console con(rig.board(), "fly> ");
  const double spool_s = armed(rig, con, setupLines(o, c, r), r, o.level);
  const double settle_s = settleOf(o, r);
  flyFor(rig, spool_s + settle_s);
  const std::string step =
      r.axis == "roll" ? fmt::format("sp {} 0", o.step_deg) : fmt::format("sp 0 {}", o.step_deg);
  std::vector<double> t_steps;
  for (int k = 0; k < stepsOf(o, r.mode); ++k) {
    if (k > 0) {  // back to level, as long as a step's window, before the next
      mustSay(con, "sp 0 0", r);
      flyFor(rig, o.window_s);
    }
    t_steps.push_back(rig.board().timeS());  // the step: the moment its line is sent
    mustSay(con, step, r);
    flyFor(rig, t_steps.back() + o.window_s - rig.board().timeS());
  }
  res.integrator_mnm = integratorOf(con, r);
  finishRun(res, rig, t_steps, settle_s, o, csv_path, wall0);
  return res;
}

void finishRun(RunResult& res, AirframeRig& rig, const std::vector<double>& t_steps, double settle_s,
               const SwapOptions& o, const std::string& csv_path, std::chrono::steady_clock::time_point wall0) {
  std::vector<StepMetrics> each;
  double y0 = 0, spread = 0;
  for (std::size_t k = 0; k < t_steps.size(); ++k) {  // the first after the level flight, the others after
                                                       // their return to level
    measure(res, windowOf(rig.samples(), t_steps[k], k == 0 ? settle_s : o.window_s, o.window_s), t_steps[k], o);
    each.push_back(res.metrics);
    res.step_rise_s.push_back(res.metrics.rise_s);
    y0 += res.y0_deg, spread += res.hover_pwm_spread_us;
  }
  res.metrics = meanOf(each);
  res.y0_deg = y0 / static_cast<double>(t_steps.size());
  res.hover_pwm_spread_us = spread / static_cast<double>(t_steps.size());
  if (!csv_path.empty()) {
    const std::vector<AirSample> rows =
        windowOf(rig.samples(), t_steps.front(), settle_s, t_steps.back() - t_steps.front() + o.window_s);
    writeSeries(csv_path, rows, t_steps, o.window_s, res.spec, o.step_deg);
    res.csv_path = csv_path;
  }
  res.simulated_s = rig.board().timeS();
  res.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
}

}  // namespace sim::swap
