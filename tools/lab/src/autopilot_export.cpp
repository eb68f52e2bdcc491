#include "lab/autopilot_export.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>

#include "lab/export.hpp"
#include "lab/model.hpp"

namespace lab::autopilot {

namespace {

namespace fs = std::filesystem;

constexpr double kTie = 1e-3;        // relative RSS within which the autopilot's default wins
constexpr double kCellMaxV = 4.35;   // the highest per-cell voltage a LiPo (HV) is charged to
constexpr int kMinRows = 10;
constexpr double kMinForceG = 1;  // a Crazyflie motor makes 12 g: the rest is the PWM span check
constexpr double kMinSpanUs = 100;

// One way to set the autopilot up: its parameters as written, and the force it assumes.
struct Fitted {
  std::string name;
  std::vector<std::pair<std::string, std::string>> file_params;
  std::vector<std::pair<std::string, double>> numeric;  // for the per-motor spread
  std::function<double(const Row&)> fraction;
  Scaled scale;
  std::vector<std::string> notes;
  std::string summary;
  double start_us = NAN;  // the pulse where the model's thrust starts
};

std::string num(double v, int decimals) { return fmt::format("{:.{}f}", v, decimals); }

Fitted describe(const ArduPilotParams& p, const Scaled& s, const std::string& name) {
  Fitted f;
  f.name = name;
  f.file_params = {{"MOT_THST_EXPO", num(p.thst_expo, 4)},     {"MOT_SPIN_MIN", num(p.spin_min, 4)},
                   {"MOT_SPIN_MAX", num(p.spin_max, 3)},       {"MOT_PWM_MIN", num(p.pwm_min_us, 0)},
                   {"MOT_PWM_MAX", num(p.pwm_max_us, 0)},      {"MOT_BAT_VOLT_MAX", num(p.bat_volt_max_v, 2)},
                   {"MOT_BAT_VOLT_MIN", num(p.bat_volt_min_v, 2)}};
  f.numeric = {{"MOT_THST_EXPO", p.thst_expo}, {"MOT_SPIN_MIN", p.spin_min}, {"MOT_SPIN_MAX", p.spin_max}};
  f.fraction = [p](const Row& r) { return ardupilot::thrustFraction(p, r.pwm_us, r.vbat_v); };
  f.scale = s;
  const double span = p.pwm_max_us - p.pwm_min_us;
  f.start_us = p.pwm_min_us + p.spin_min * span;
  f.summary = fmt::format(
      "thrust starts at {:.1f} us (MOT_SPIN_MIN), saturates at {:.1f} us (MOT_SPIN_MAX), expo {:.4f}; "
      "voltage scaling {}; full thrust {:.1f} g",
      p.pwm_min_us + p.spin_min * span, p.pwm_min_us + p.spin_max * span, p.thst_expo,
      p.bat_volt_max_v > 0 ? fmt::format("{:.2f}..{:.2f} V", p.bat_volt_min_v, p.bat_volt_max_v) : "off",
      s.full_g);
  return f;
}

Fitted describe(const Px4Params& p, const Scaled& s, const std::string& name, int motors, const std::string& prefix) {
  Fitted f;
  f.name = name;
  f.file_params = {{"THR_MDL_FAC", num(p.thr_mdl_fac, 3)}, {"MC_BAT_SCALE_EN", p.bat_scale_en ? "1" : "0"}};
  for (int m = 1; m <= motors; ++m) f.file_params.push_back({fmt::format("{}_MIN{}", prefix, m), num(p.pwm_min_us, 0)});
  for (int m = 1; m <= motors; ++m) f.file_params.push_back({fmt::format("{}_MAX{}", prefix, m), num(p.pwm_max_us, 0)});
  f.numeric = {{"THR_MDL_FAC", p.thr_mdl_fac}, {prefix + "_MIN", p.pwm_min_us}, {prefix + "_MAX", p.pwm_max_us}};
  f.fraction = [p](const Row& r) { return px4::thrustFraction(p, r.pwm_us, r.vbat_v); };
  f.scale = s;
  f.start_us = std::min(p.pwm_min_us, p.pwm_max_us);
  f.summary = fmt::format("thrust from {:.0f} us to {:.0f} us ({}_MIN/MAX), THR_MDL_FAC {:.3f}; battery scaling {}; "
                          "full thrust {:.1f} g",
                          p.pwm_min_us, p.pwm_max_us, prefix, p.thr_mdl_fac,
                          p.bat_scale_en ? fmt::format("on (V_CHARGED {:.2f} V x {} cells)", p.bat_v_charged, p.bat_n_cells)
                                         : "off",
                          s.full_g);
  return f;
}

Fitted describe(const BetaflightParams& p, const Scaled& s, const std::string& name) {
  Fitted f;
  f.name = name;
  f.file_params = {{"thrust_linear", std::to_string(p.thrust_linear)},
                   {"motor_idle", std::to_string(p.motor_idle)},
                   {"motor_output_limit", std::to_string(p.motor_output_limit)},
                   {"vbat_sag_compensation", std::to_string(p.vbat_sag_compensation)}};
  if (p.protocol == BfProtocol::kPwm) {
    f.file_params.push_back({"min_command", std::to_string(p.min_command)});
    f.file_params.push_back({"max_throttle", std::to_string(p.max_throttle)});
  }
  f.numeric = {{"thrust_linear", p.thrust_linear},
               {"motor_idle", p.motor_idle},
               {"motor_output_limit", p.motor_output_limit},
               {"vbat_sag_compensation", p.vbat_sag_compensation}};
  f.fraction = [p](const Row& r) { return betaflight::thrustFraction(p, r.pwm_us, r.vbat_v); };
  f.scale = s;
  const betaflight::Endpoints ep = betaflight::endpoints(p);
  f.start_us = betaflight::toPulseUs(p, ep.low);
  f.summary = fmt::format("thrust from {:.1f} us (motor_idle) to {:.1f} us (motor_output_limit) as pulses of a "
                          "{}-{} us ESC, thrust_linear {}; sag compensation {} %; full thrust {:.1f} g",
                          betaflight::toPulseUs(p, ep.low), betaflight::toPulseUs(p, ep.high), p.min_command,
                          p.max_throttle, p.thrust_linear, p.vbat_sag_compensation, s.full_g);
  return f;
}

// The autopilot's fit; `voltage` lets it use its voltage term.
Fitted fitOne(Autopilot to, const std::vector<Row>& rows, FitSetup setup, bool voltage, const ExportOptions& o) {
  setup.use_voltage = voltage;
  switch (to) {
    case Autopilot::kArduPilot: {
      const ArduPilotFit a = fitArduPilot(rows, setup);
      Fitted f = describe(a.params, a.scale, "");
      f.notes = a.notes;
      return f;
    }
    case Autopilot::kPx4: {
      const Px4Fit p = fitPx4(rows, setup, voltage);
      Fitted f = describe(p.params, p.scale, "", o.motors, o.px4_prefix);
      f.notes = p.notes;
      return f;
    }
    case Autopilot::kBetaflight: {
      const BetaflightFit b = fitBetaflight(rows, setup);
      Fitted f = describe(b.params, b.scale, "");
      f.notes = b.notes;
      return f;
    }
  }
  throw std::logic_error("unknown autopilot");
}

Fitted defaultsOf(Autopilot to, const std::vector<Row>& rows, const FitSetup& setup, const ExportOptions& o) {
  switch (to) {
    case Autopilot::kArduPilot: {
      ArduPilotParams p;  // expo 0.65, spin 0.15 / 0.95, voltage compensation off
      p.pwm_min_us = setup.esc_min_us;
      p.pwm_max_us = setup.esc_max_us;
      return describe(p, bestScale(rows, [&](const Row& r) { return ardupilot::thrustFraction(p, r.pwm_us, r.vbat_v); }),
                      "defaults (expo 0.65, spin 0.15/0.95)");
    }
    case Autopilot::kPx4: {
      Px4Params p;  // THR_MDL_FAC 0, PWM 1000..2000, no battery scaling
      return describe(p, bestScale(rows, [&](const Row& r) { return px4::thrustFraction(p, r.pwm_us, r.vbat_v); }),
                      "defaults (THR_MDL_FAC 0, 1000-2000)", o.motors, o.px4_prefix);
    }
    case Autopilot::kBetaflight: {
      BetaflightParams p;  // thrust_linear 0, motor_idle 5.5 %, no limit, no sag compensation
      p.protocol = setup.bf_protocol;
      p.min_command = static_cast<int>(std::lround(setup.esc_min_us));
      p.max_throttle = static_cast<int>(std::lround(setup.esc_max_us));
      return describe(p, bestScale(rows, [&](const Row& r) { return betaflight::thrustFraction(p, r.pwm_us, r.vbat_v); }),
                      "defaults (thrust_linear 0, motor_idle 550)");
    }
  }
  throw std::logic_error("unknown autopilot");
}

std::vector<double> predict(const Fitted& f, const std::vector<Row>& rows) {
  std::vector<double> out(rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) out[i] = f.scale.full_g * f.fraction(rows[i]);
  return out;
}

ErrorStats stats(const std::vector<Row>& rows, const std::vector<double>& pred, const std::vector<std::size_t>& which,
                 double largest) {
  ErrorStats s;
  double ss = 0, mx = 0;
  for (std::size_t i : which) {
    if (!std::isfinite(pred[i])) continue;
    const double e = rows[i].force_g - pred[i];
    ss += e * e, mx = std::max(mx, std::fabs(e)), ++s.n;
  }
  if (s.n == 0) return s;
  s.rms_g = std::sqrt(ss / static_cast<double>(s.n));
  s.max_g = mx;
  s.rms_pct = 100.0 * s.rms_g / largest;
  s.max_pct = 100.0 * s.max_g / largest;
  return s;
}

double rmsOn(const std::vector<Row>& rows, const std::vector<double>& pred, const std::vector<std::size_t>& which) {
  return stats(rows, pred, which, 1.0).rms_g;
}

// Groups of rows by battery voltage: clusters split at gaps of more than 0.25 V when there are
// 2..8 of them (runs at set voltages), else three equal parts (a discharging battery).
std::vector<RowGroup> voltageGroups(const std::vector<Row>& rows) {
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < rows.size(); ++i)
    if (std::isfinite(rows[i].vbat_v)) idx.push_back(i);
  if (idx.size() < 2) return {};
  std::sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) { return rows[a].vbat_v < rows[b].vbat_v; });
  std::vector<std::vector<std::size_t>> parts(1);
  for (std::size_t k = 0; k < idx.size(); ++k) {
    if (k && rows[idx[k]].vbat_v - rows[idx[k - 1]].vbat_v > 0.25) parts.emplace_back();
    parts.back().push_back(idx[k]);
  }
  if (parts.size() == 1 && rows[idx.back()].vbat_v - rows[idx.front()].vbat_v < 0.3) return {};
  if (parts.size() < 2 || parts.size() > 8) {
    parts.assign(3, {});
    for (std::size_t k = 0; k < idx.size(); ++k) parts[k * 3 / idx.size()].push_back(idx[k]);
  }
  std::vector<RowGroup> groups;
  for (auto& p : parts) {
    if (p.empty()) continue;
    const double lo = rows[p.front()].vbat_v, hi = rows[p.back()].vbat_v;
    RowGroup g;
    g.label = hi - lo < 0.05 ? fmt::format("{:.2f} V", 0.5 * (lo + hi)) : fmt::format("{:.2f}-{:.2f} V", lo, hi);
    std::sort(p.begin(), p.end());
    g.rows = p;
    groups.push_back(g);
  }
  return groups;
}

std::pair<double, double> parseRange(const std::string& text) {
  const auto colon = text.find(':');
  double lo = NAN, hi = NAN;
  try {
    if (colon != std::string::npos) {
      lo = std::stod(text.substr(0, colon));
      hi = std::stod(text.substr(colon + 1));
    }
  } catch (const std::exception&) {
  }
  if (!(lo >= 500 && hi <= 2500 && hi - lo >= 200))
    throw std::invalid_argument(fmt::format("--esc-range {}: expected MIN:MAX in microseconds, e.g. 1000:2000 (the "
                                            "pulse range the ESC was calibrated to)", text));
  return {lo, hi};
}

// The data must show the curve: enough rows, enough force, over enough PWM.
void checkFittable(const std::vector<Row>& rows, const std::string& autopilot) {
  const std::string what_to_log =
      "log a sweep from below the start of thrust to full throttle (e.g. 1000..2000 us in steps of 25 us, "
      "each step held until the force settles), with the battery voltage";
  if (static_cast<int>(rows.size()) < kMinRows)
    throw std::invalid_argument(fmt::format("only {} rows with a PWM and a force: fitting {}'s thrust curve needs at "
                                            "least {}; {}", rows.size(), autopilot, kMinRows, what_to_log));
  double fmax = 0;
  for (const Row& r : rows) fmax = std::max(fmax, r.force_g);
  if (fmax < kMinForceG)
    throw std::invalid_argument(fmt::format("the largest force is {:.1f} g: too little to fit a thrust curve (the "
                                            "motor barely ran, or force_g is in another unit; --map force_g=COLUMN*K); {}",
                                            fmax, what_to_log));
  std::set<double> pwms;
  double lo = INFINITY, hi = -INFINITY;
  for (const Row& r : rows)
    if (r.force_g >= 0.1 * fmax) pwms.insert(r.pwm_us), lo = std::min(lo, r.pwm_us), hi = std::max(hi, r.pwm_us);
  if (pwms.size() < 5 || hi - lo < kMinSpanUs)
    throw std::invalid_argument(fmt::format(
        "the force rises over only {} PWM value(s) spanning {:.0f} us: {}'s curve (where thrust starts, how it "
        "bends) cannot be seen in that; {}", pwms.size(), hi - lo, autopilot, what_to_log));
}

std::string fileText(Autopilot to, const ExportReport& r, const std::string& command, const std::string& summary,
                     const ErrorStats& fitted, const ErrorStats& defaults) {
  std::string head;
  auto comment = [&](const std::string& line) { head += "# " + line + "\n"; };
  const std::string errors = fmt::format(
      "force error on the data: fitted RMS {:.2f} g ({:.2f} %), max {:.2f} g; with the defaults RMS {:.2f} g",
      fitted.rms_g, fitted.rms_pct, fitted.max_g, defaults.rms_g);
  std::string body;
  switch (to) {
    case Autopilot::kArduPilot:
      comment("ArduPilot thrust model fitted by thrustcal to thrust-stand data");
      comment(command);
      comment("model: AP_Motors_Thrust_Linearization, force = full * (e y^2 + (1-e) y), y = t v, t = (actuator -");
      comment("SPIN_MIN)/(SPIN_MAX - SPIN_MIN), actuator = (pwm - PWM_MIN)/(PWM_MAX - PWM_MIN), v = V/BAT_VOLT_MAX");
      comment(summary);
      comment(errors);
      comment("load: Mission Planner Config > Full Parameter List > Load from file, or MAVProxy `param load FILE`");
      for (const auto& [n, v] : r.params) body += n + "," + v + "\n";
      return head + body;
    case Autopilot::kPx4:
      head = "# Onboard parameters for Vehicle 1\n#\n";
      comment("PX4 thrust model fitted by thrustcal to thrust-stand data");
      comment(command);
      comment("model: rel_thrust = f x^2 + (1-f) x (THR_MDL_FAC f), x = (pwm - MIN)/(MAX - MIN)");
      comment(summary);
      comment(errors);
      comment("load: QGroundControl Vehicle Setup > Parameters > Tools > Load from file");
      head += "#\n# Vehicle-Id Component-Id Name Value Type\n";
      for (const auto& [n, v] : r.params) {
        const bool real = v.find('.') != std::string::npos;
        body += fmt::format("1\t1\t{}\t{}\t{}\n", n, v, real ? 9 : 6);  // MAV_PARAM_TYPE_REAL32 / INT32
      }
      return head + body;
    case Autopilot::kBetaflight:
      comment("Betaflight thrust model fitted by thrustcal to thrust-stand data");
      comment(command);
      comment("model: motor = low + (high - low) * c(x), c(x) = x (1 + e (1-x) (1 + e (1-2x))), e = thrust_linear/100");
      comment(summary);
      comment(errors);
      comment("paste into the Betaflight CLI; thrust_linear, motor_output_limit and vbat_sag_compensation go into the");
      comment("selected PID profile; `save` stores everything and reboots");
      for (const auto& [n, v] : r.params) body += "set " + n + " = " + v + "\n";
      return head + body + "save\n";
  }
  return head;
}

}  // namespace

namespace {

// The options that do not depend on the data; returns the ESC range.
std::pair<double, double> checkOptions(const ExportOptions& o) {
  if (o.auw_g < 0) throw std::invalid_argument("--auw-g must be positive (the take-off weight in grams)");
  if (o.auw_g > 0 && !o.motors_given)
    throw std::invalid_argument("--auw-g needs --motors N: the hover force of one motor is the weight / N");
  if (o.motors < 1 || o.motors > 16) throw std::invalid_argument("--motors must be 1..16");
  const auto range = parseRange(o.esc_range);
  if (o.esc != "dshot" && o.esc != "pwm") throw std::invalid_argument("--esc " + o.esc + ": choose dshot or pwm");
  return range;
}

// The rows: finite PWM and force. Returns how many have no voltage.
std::size_t takeRows(ExportReport& r, const Dataset& data_in, const std::string& ap) {
  const auto& pw = data_in.col("pwm_us");
  const auto& fo = data_in.col("force_g");
  std::vector<bool> keep(data_in.rows());
  for (std::size_t i = 0; i < keep.size(); ++i) keep[i] = std::isfinite(pw[i]) && std::isfinite(fo[i]);
  r.data = data_in.subset(keep);
  const bool has_v = r.data.has("vbat_v");
  std::size_t v_missing = 0;
  for (std::size_t i = 0; i < r.data.rows(); ++i) {
    Row row;
    row.pwm_us = r.data.col("pwm_us")[i];
    row.force_g = r.data.col("force_g")[i];
    row.vbat_v = has_v ? r.data.col("vbat_v")[i] : NAN;
    if (has_v && !std::isfinite(row.vbat_v)) ++v_missing;
    r.rows.push_back(row);
  }
  checkFittable(r.rows, ap);
  for (const Row& row : r.rows) r.largest_force_g = std::max(r.largest_force_g, row.force_g);
  return v_missing;
}

// Whether the voltage term can be fitted (a voltage on every row), with the cells and the notes.
bool voltageTerm(ExportReport& r, const ExportOptions& o, std::size_t v_missing, const std::string& ap) {
  const bool has_v = r.data.has("vbat_v");
  const bool voltage = has_v && v_missing == 0;
  if (!has_v) {
    r.notes.push_back(fmt::format("no battery voltage column (vbat_v): fitted without {}'s voltage term; log the voltage "
                                  "(or --map vbat_v=COLUMN) to fit it",
                                  ap));
  } else if (v_missing) {
    r.notes.push_back(fmt::format("{} of {} rows have no battery voltage: fitted without {}'s voltage term", v_missing,
                                  r.rows.size(), ap));
  }
  if (voltage) {
    double vmin = INFINITY, vmax = 0;
    for (const Row& row : r.rows) vmin = std::min(vmin, row.vbat_v), vmax = std::max(vmax, row.vbat_v);
    r.cells = o.cells > 0 ? o.cells : std::max(1, static_cast<int>(std::ceil(vmax / kCellMaxV)));
    if (o.cells <= 0)
      r.notes.push_back(fmt::format("{} cells assumed from the largest voltage {:.2f} V (--cells N to say)", r.cells, vmax));
    if (vmax - vmin < 0.3)
      r.notes.push_back(fmt::format("the data hold one voltage ({:.2f}-{:.2f} V): the voltage term is not tested by them; "
                                    "measure at a second voltage (another state of charge) to see it",
                                    vmin, vmax));
  }
  return voltage;
}

// The parameter set written, and the other voltage choice when it differs.
struct Choice {
  Fitted chosen;
  bool chosen_voltage = false;
  std::optional<Fitted> other;
};

// The fit, with and without the voltage term; the default (without) wins a tie.
Choice choose(ExportReport& r, const FitSetup& setup, bool voltage, const ExportOptions& o) {
  Choice c{fitOne(r.to, r.rows, setup, false, o), false, std::nullopt};
  if (voltage) {
    Fitted with_v = fitOne(r.to, r.rows, setup, true, o);
    if (with_v.scale.rss < c.chosen.scale.rss * (1 - kTie)) std::swap(c.chosen, with_v), c.chosen_voltage = true;
    if (with_v.file_params != c.chosen.file_params) c.other = std::move(with_v);
  }
  c.chosen.name = "fitted (the file)";
  if (c.other) {
    const char* names[3][2] = {{"fitted with voltage scaling", "fitted, no voltage scaling (MOT_BAT_VOLT_MAX 0)"},
                               {"fitted, MC_BAT_SCALE_EN 1", "fitted, MC_BAT_SCALE_EN 0"},
                               {"fitted with vbat_sag_compensation", "fitted, vbat_sag_compensation 0"}};
    c.other->name = names[static_cast<int>(r.to)][c.chosen_voltage ? 1 : 0];
  }
  if (r.to == Autopilot::kPx4 && c.chosen_voltage)
    r.notes.push_back(fmt::format("MC_BAT_SCALE_EN 1 scales thrust by BAT1_V_CHARGED / cell voltage: set BAT1_V_CHARGED "
                                  "{:.2f} V and BAT1_N_CELLS {} on the vehicle as the fit assumed (--bat-v-charged, --cells)",
                                  o.px4_v_charged, r.cells));
  return c;
}

// The most the motor makes where the model says thrust has not started, when it matters.
void startNote(ExportReport& r, const Fitted& chosen, const std::string& ap) {
  double before = 0;
  for (const Row& row : r.rows)
    if (row.pwm_us <= chosen.start_us) before = std::max(before, row.force_g);
  if (before > 0.03 * r.largest_force_g)
    r.notes.push_back(fmt::format(
        "{} assumes no thrust up to {:.0f} us, where the motor already makes {:.0f} g ({:.1f} % of the largest force): "
        "its curve cannot bend like the propeller's, and the fit moves the start up to bend it",
        ap, chosen.start_us, before, 100 * before / r.largest_force_g));
}

// The hover thrust parameter (--auw-g): the fraction of full thrust one motor makes at hover.
void hoverThrust(ExportReport& r, const ExportOptions& o, const Fitted& chosen) {
  if (!(o.auw_g > 0)) return;
  const double hover = o.auw_g / o.motors / chosen.scale.full_g;
  auto hoverParam = [&](const char* name, double lo, double hi) {
    const double h = std::clamp(hover, lo, hi);
    if (h != hover)
      r.notes.push_back(fmt::format("hover needs {:.1f} % of full thrust ({:.0f} g of {:.0f} g per motor): outside {}'s "
                                    "{}..{}; {} written (the aircraft is {} for these motors)",
                                    100 * hover, o.auw_g / o.motors, chosen.scale.full_g, name, lo, hi, num(h, 4),
                                    hover > hi ? "too heavy" : "too light"));
    r.params.push_back({name, num(h, 4)});
  };
  if (r.to == Autopilot::kArduPilot) hoverParam("MOT_THST_HOVER", 0.125, 0.6875);
  if (r.to == Autopilot::kPx4) hoverParam("MPC_THR_HOVER", 0.1, 0.8);
  if (r.to == Autopilot::kBetaflight)
    r.notes.push_back(fmt::format("Betaflight keeps no hover-thrust parameter: this aircraft hovers at {:.1f} % of "
                                  "full thrust", 100 * hover));
}

std::vector<long> motorIdsOf(const Dataset& data) {
  std::vector<long> motor_ids;
  if (data.has("motor")) {
    std::set<long> ids;
    for (double m : data.col("motor"))
      if (std::isfinite(m)) ids.insert(std::lround(m));
    motor_ids.assign(ids.begin(), ids.end());
  }
  return motor_ids;
}

// thrustcal's model v2 per motor, through the lab's export path.
ModelColumn modelV2Column(const ExportReport& r, const ExportOptions& o, bool voltage,
                          const std::vector<long>& motor_ids) {
  ModelColumn v2{"thrustcal model v2 (per motor)", std::vector<double>(r.rows.size(), NAN), ""};
  if (!voltage) {
    v2.unavailable = "needs the battery voltage on every row";
    return v2;
  }
  std::string spec_text = o.v2_model;
  if (spec_text.empty()) spec_text = r.data.has("current_a") ? "curve+deadband+voltage+sag" : "curve+deadband+voltage";
  try {
    const ModelSpec spec = parseSpec(spec_text);
    const std::vector<long> groups = motor_ids.empty() ? std::vector<long>{-1} : motor_ids;
    for (long id : groups) {
      std::vector<bool> mine(r.rows.size(), true);
      if (id >= 0)
        for (std::size_t i = 0; i < mine.size(); ++i) mine[i] = std::lround(r.data.col("motor")[i]) == id;
      std::vector<uint8_t> image(kEepromBytes, 0xFF);
      const ExportResult e = exportModel(r.data.subset(mine), spec, 0, image);
      std::size_t k = 0;
      for (std::size_t i = 0; i < mine.size(); ++i)
        if (mine[i]) v2.predicted_g[i] = e.v2_force_g[k++];
    }
    v2.name = "thrustcal model v2 (per motor)";
  } catch (const std::exception& e) {
    v2.unavailable = e.what();
    std::fill(v2.predicted_g.begin(), v2.predicted_g.end(), NAN);
  }
  return v2;
}

// The row groups of the comparison (all, each voltage, each motor) and, with several motors,
// each motor's own best parameters with the voltage choice of the common set.
void groupsAndMotors(ExportReport& r, const std::vector<long>& motor_ids, const FitSetup& setup,
                     bool chosen_voltage, const ExportOptions& o) {
  RowGroup all{"all", {}};
  for (std::size_t i = 0; i < r.rows.size(); ++i) all.rows.push_back(i);
  r.groups.push_back(all);
  for (auto& g : voltageGroups(r.rows)) r.groups.push_back(g);
  if (motor_ids.size() <= 1) return;
  for (long id : motor_ids) {
    RowGroup g{fmt::format("motor {}", id), {}};
    for (std::size_t i = 0; i < r.rows.size(); ++i)
      if (std::lround(r.data.col("motor")[i]) == id) g.rows.push_back(i);
    r.groups.push_back(g);
  }
  const std::vector<double>& common = r.models.front().predicted_g;
  for (long id : motor_ids) {
    std::vector<Row> mine;
    std::vector<std::size_t> which;
    for (std::size_t i = 0; i < r.rows.size(); ++i)
      if (std::lround(r.data.col("motor")[i]) == id) mine.push_back(r.rows[i]), which.push_back(i);
    MotorBest b;
    b.label = fmt::format("motor {}", id);
    try {
      const Fitted f = fitOne(r.to, mine, setup, chosen_voltage, o);
      b.params = f.numeric;
      b.own_rms_g = std::sqrt(f.scale.rss / static_cast<double>(mine.size()));
    } catch (const std::exception& e) {
      r.notes.push_back(fmt::format("motor {} alone: {}", id, e.what()));
    }
    b.common_rms_g = rmsOn(r.rows, common, which);
    r.per_motor.push_back(b);
  }
}

}  // namespace

ExportReport buildExport(const Dataset& data_in, const ExportOptions& o) {
  ExportReport r;
  r.to = parseAutopilot(o.to);
  const std::string ap = autopilotName(r.to);
  const auto [esc_lo, esc_hi] = checkOptions(o);
  const std::size_t v_missing = takeRows(r, data_in, ap);

  FitSetup setup;
  setup.esc_min_us = esc_lo;
  setup.esc_max_us = esc_hi;
  setup.px4_v_charged = o.px4_v_charged;
  setup.bf_protocol = o.esc == "pwm" ? BfProtocol::kPwm : BfProtocol::kDshot;
  const bool voltage = voltageTerm(r, o, v_missing, ap);
  setup.cells = r.cells;
  setup.bf_vbat_warning_cell_cv = 350;

  const Choice c = choose(r, setup, voltage, o);
  const Fitted defaults = defaultsOf(r.to, r.rows, setup, o);
  r.full_g = c.chosen.scale.full_g;
  r.notes.insert(r.notes.end(), c.chosen.notes.begin(), c.chosen.notes.end());
  startNote(r, c.chosen, ap);
  r.params = c.chosen.file_params;
  r.summary = c.chosen.summary;
  hoverThrust(r, o, c.chosen);

  // model columns
  r.models.push_back({c.chosen.name, predict(c.chosen, r.rows), ""});
  if (c.other) r.models.push_back({c.other->name, predict(*c.other, r.rows), ""});
  r.models.push_back({defaults.name, predict(defaults, r.rows), ""});
  const std::vector<long> motor_ids = motorIdsOf(r.data);
  const ModelColumn v2 = modelV2Column(r, o, voltage, motor_ids);
  r.models.push_back(v2);
  if (!v2.unavailable.empty()) r.notes.push_back("model v2: " + v2.unavailable);
  groupsAndMotors(r, motor_ids, setup, c.chosen_voltage, o);

  const std::vector<std::size_t>& rows_all = r.groups.front().rows;
  const ErrorStats fitted = stats(r.rows, r.models.front().predicted_g, rows_all, r.largest_force_g);
  const ErrorStats def = stats(r.rows, predict(defaults, r.rows), rows_all, r.largest_force_g);
  r.file_text = fileText(r.to, r, o.command_line, r.summary, fitted, def);
  return r;
}

namespace {

// The comparison: one column pair (RMS, max) per model, a row per group of rows.
std::string errorTable(const ExportReport& r) {
  std::string s;
  const char letters[] = "ABCDEFGH";
  s += fmt::format("force error, g (RMS and max |measured - model|; % of the largest force, {:.0f} g):\n", r.largest_force_g);
  s += fmt::format("  {:<18} {:>5}", "rows", "n");
  for (std::size_t m = 0; m < r.models.size(); ++m) s += fmt::format("   {:>8} {:>7}", fmt::format("{} RMS", letters[m]), "max");
  s += "\n";
  for (std::size_t gi = 0; gi < r.groups.size(); ++gi) {
    const RowGroup& g = r.groups[gi];
    s += fmt::format("  {:<18} {:>5}", g.label, g.rows.size());
    std::vector<ErrorStats> st;
    for (const auto& m : r.models) {
      st.push_back(stats(r.rows, m.predicted_g, g.rows, r.largest_force_g));
      if (st.back().n == 0)
        s += fmt::format("   {:>8} {:>7}", "-", "-");
      else
        s += fmt::format("   {:>8.2f} {:>7.2f}", st.back().rms_g, st.back().max_g);
    }
    s += "\n";
    if (gi == 0) {
      s += fmt::format("  {:<18} {:>5}", "  in %", "");
      for (const auto& e : st)
        s += e.n ? fmt::format("   {:>7.2f}% {:>6.2f}%", e.rms_pct, e.max_pct) : fmt::format("   {:>8} {:>7}", "-", "-");
      s += "\n";
    }
  }
  for (std::size_t m = 0; m < r.models.size(); ++m)
    s += fmt::format("  {}: {}{}\n", letters[m], r.models[m].name,
                     r.models[m].unavailable.empty() ? "" : " (n/a: " + r.models[m].unavailable + ")");
  return s;
}

// Each motor's own best parameters, against the one set the autopilot flies, and their spread.
std::string perMotorTable(const ExportReport& r, const std::string& ap) {
  std::string s = fmt::format("\nbest parameters per motor ({} flies one set for all motors):\n", ap);
  const auto& names = r.per_motor.front().params;
  s += fmt::format("  {:<10}", "motor");
  for (const auto& [n, v] : names) s += fmt::format(" {:>{}}", n, std::max<std::size_t>(10, n.size()));
  s += fmt::format(" {:>12} {:>14}\n", "RMS g alone", "RMS g the set");
  std::map<std::string, std::pair<double, double>> range;
  for (const auto& b : r.per_motor) {
    s += fmt::format("  {:<10}", b.label);
    for (std::size_t k = 0; k < b.params.size(); ++k) {
      const auto& [n, v] = b.params[k];
      const int w = static_cast<int>(std::max<std::size_t>(10, names[k].first.size()));
      s += fmt::format(" {:>{}.4g}", v, w);
      auto& rg = range.try_emplace(n, INFINITY, -INFINITY).first->second;
      rg.first = std::min(rg.first, v), rg.second = std::max(rg.second, v);
    }
    if (b.params.empty()) s += "  (no fit)";
    s += fmt::format(" {:>12.2f} {:>14.2f}\n", b.own_rms_g, b.common_rms_g);
  }
  s += fmt::format("  {:<10}", "spread");
  for (const auto& [n, v] : names) {
    const auto it = range.find(n);
    s += fmt::format(" {:>{}.4g}", it == range.end() ? NAN : it->second.second - it->second.first,
                     std::max<std::size_t>(10, n.size()));
  }
  return s + "\n";
}

}  // namespace

std::string formatReport(const ExportReport& r) {
  std::string s;
  const std::string ap = autopilotName(r.to);
  std::set<long> motors;
  if (r.data.has("motor"))
    for (double m : r.data.col("motor"))
      if (std::isfinite(m)) motors.insert(std::lround(m));
  double vlo = INFINITY, vhi = -INFINITY;
  for (const Row& row : r.rows)
    if (std::isfinite(row.vbat_v)) vlo = std::min(vlo, row.vbat_v), vhi = std::max(vhi, row.vbat_v);
  s += fmt::format("{} thrust model fitted to {} rows in {} run(s), {} motor(s){}\n", ap, r.rows.size(),
                   r.data.runs(), std::max<std::size_t>(1, motors.size()),
                   std::isfinite(vlo) ? fmt::format(", {:.2f}-{:.2f} V", vlo, vhi) : ", no voltage");
  s += "  " + r.summary + "\n";
  std::string line = " ";
  for (const auto& [n, v] : r.params) {
    const std::string item = fmt::format(" {} {}", n, v);
    if (line.size() + item.size() > 100) s += line + "\n", line = " ";
    line += item;
  }
  s += line + "\n\n";
  s += errorTable(r);
  if (!r.per_motor.empty()) s += perMotorTable(r, ap);
  if (!r.notes.empty()) s += "\n";
  for (const auto& n : r.notes) s += "note: " + n + "\n";
  return s;
}

std::vector<std::string> writePlot(const ExportReport& r, const std::string& base, std::vector<std::string>& warnings) {
  auto quote = [](const std::string& text) {
    std::string out = "'";
    for (char c : text) out += c == '\'' ? std::string("''") : std::string(1, c);
    return out + "'";
  };
  const fs::path tsv = base + ".tsv", gp = base + ".gp";
  if (tsv.has_parent_path()) fs::create_directories(tsv.parent_path());
  {
    std::ofstream f(tsv);
    if (!f) throw std::runtime_error("cannot write " + tsv.string() + "; check the directory is writable");
    f << "# pwm_us force_g vbat_v";
    for (const auto& m : r.models) f << " \"" << m.name << "\"";
    f << "\n";
    for (std::size_t i = 0; i < r.rows.size(); ++i) {
      f << fmt::format("{:.6g} {:.6g} {:.6g}", r.rows[i].pwm_us, r.rows[i].force_g, r.rows[i].vbat_v);
      for (const auto& m : r.models) f << fmt::format(" {:.6g}", m.predicted_g[i]);
      f << "\n";
    }
  }
  const char* colors[] = {"#1f77b4", "#2ca02c", "#d62728", "#9467bd", "#ff7f0e"};
  std::string plots;
  {
    std::string cmd = "set multiplot layout 1,2\n";
    cmd += fmt::format("set title {}\nset xlabel 'PWM (us)'\nset ylabel 'force (g)'\nset key left top Left reverse\n",
                       quote(std::string(autopilotName(r.to)) + ": measured and modelled force"));
    cmd += fmt::format("plot {} using 1:2 with points pt 6 ps 0.7 lc rgb '#222222' title 'measured'", quote(tsv.string()));
    for (std::size_t m = 0; m < r.models.size(); ++m)
      if (r.models[m].unavailable.empty())
        cmd += fmt::format(", '' using 1:{} with points pt 7 ps 0.35 lc rgb '{}' title {}", 4 + m, colors[m % 5],
                           quote(r.models[m].name));
    cmd += "\n";
    cmd += fmt::format("set title {}\nset ylabel 'measured - model (g)'\nset key below\n",
                       quote("force error"));
    cmd += "plot ";
    bool first = true;
    for (std::size_t m = 0; m < r.models.size(); ++m) {
      if (!r.models[m].unavailable.empty()) continue;
      cmd += fmt::format("{}{} using 1:($2-${}) with points pt 7 ps 0.35 lc rgb '{}' title {}", first ? "" : ", ",
                         first ? quote(tsv.string()) : "''", 4 + m, colors[m % 5], quote(r.models[m].name));
      first = false;
    }
    cmd += "\nunset multiplot\n";
    plots = cmd;
  }
  std::string script;
  std::vector<std::string> images;
  for (const char* ext : {"png", "svg"}) {
    const std::string out = base + "." + ext;
    script += "reset\n";
    script += std::string(ext) == "png" ? "set terminal pngcairo size 1400,640 noenhanced\n"
                                        : "set terminal svg size 1400,640 noenhanced\n";
    script += "set output " + quote(out) + "\n" + plots + "unset output\n";
    images.push_back(out);
  }
  {
    std::ofstream f(gp);
    if (!f) throw std::runtime_error("cannot write " + gp.string());
    f << script;
  }
  const std::string log = base + ".gnuplot.log";
  const int rc = std::system(("gnuplot " + quote(gp.string()) + " 2> " + quote(log)).c_str());
  if (rc != 0) {
    warnings.push_back(fmt::format("gnuplot failed (exit {}); see {}; the data and the script are {} and {}", rc, log,
                                   tsv.string(), gp.string()));
    images.clear();
  } else {
    std::error_code ec;
    fs::remove(log, ec);
  }
  return images;
}

std::shared_ptr<ExportOptions> addExportOptions(CLI::App* x) {
  auto o = std::make_shared<ExportOptions>();
  x->add_option("--to", o->to,
                "instead of an EEPROM image: fit this autopilot's own thrust model and write its parameter file "
                "(ardupilot: .parm, px4: QGroundControl .params, betaflight: CLI set lines)")
      ->check(CLI::IsMember({"ardupilot", "px4", "betaflight"}));
  x->add_option("-o,--output", o->output, "the parameter file to write (with --to)");
  x->add_option("--auw-g", o->auw_g, "take-off weight (g): writes the hover thrust (MOT_THST_HOVER, MPC_THR_HOVER); needs --motors");
  auto* motors = x->add_option("--motors", o->motors, "motors on the aircraft (hover thrust; PX4 output lines)")
                     ->capture_default_str();
  x->add_option("--cells", o->cells, "battery cells (default: from the largest logged voltage)");
  x->add_option("--esc-range", o->esc_range, "the ESC's calibrated pulse range MIN:MAX (us)")->capture_default_str();
  x->add_option("--esc", o->esc, "Betaflight motor protocol: dshot or pwm")->capture_default_str();
  x->add_option("--bat-v-charged", o->px4_v_charged, "PX4 BAT1_V_CHARGED per cell, for MC_BAT_SCALE_EN")
      ->capture_default_str();
  x->add_option("--px4-prefix", o->px4_prefix, "PX4 output group of the motors (PWM_MAIN, PWM_AUX, ...)")
      ->capture_default_str();
  x->add_option("--plot", o->plot, "with --to: plot base name (writes BASE.png, BASE.svg, BASE.tsv, BASE.gp)");
  for (const char* name : {"--model", "--slot", "--eeprom"})
    if (CLI::Option* opt = x->get_option_no_throw(name)) opt->required(false);
  x->parse_complete_callback([x, o, motors] {
    o->motors_given = motors->count() > 0;
    auto given = [x](const char* name) {
      const CLI::Option* opt = x->get_option_no_throw(name);
      return opt && opt->count() > 0;
    };
    if (o->to.empty()) {
      for (const char* name : {"--model", "--slot", "--eeprom"})
        if (!given(name)) throw CLI::RequiredError(std::string(name) + " (or --to ardupilot|px4|betaflight -o FILE)");
      return;
    }
    if (o->output.empty()) throw CLI::RequiredError("-o FILE (the parameter file --to writes)");
    for (const char* name : {"--slot", "--eeprom"})
      if (given(name))
        throw CLI::ValidationError(name, "writes the board's EEPROM image; --to writes an autopilot's parameter file: "
                                         "use one or the other");
  });
  x->description(x->get_description() + "; or, with --to, fit an autopilot's thrust model and write its parameters");
  x->footer(x->get_footer() +
            "\nAutopilots: thrustcal lab export sweep.csv --to ardupilot -o quad.parm [--auw-g 1450 --motors 4] "
            "[--plot fit]\n  (px4: QGroundControl .params; betaflight: CLI set lines; docs/autopilot.md)");
  return o;
}

int runExport(const ExportOptions& options, const std::vector<std::string>& files, const std::vector<std::string>& maps,
              long motor, const std::string& model) {
  ExportOptions o = options;
  if (o.v2_model.empty()) o.v2_model = model;
  ReadOptions ro;
  for (const auto& m : maps) ro.maps.push_back(parseColumnMap(m));
  Dataset data = readFiles(files, ro);
  if (motor >= 0) data = selectMotor(data, motor);
  o.command_line = "thrustcal lab export";
  for (const auto& f : files) o.command_line += " " + fs::path(f).filename().string();
  for (const auto& m : maps) o.command_line += " --map '" + m + "'";
  o.command_line += " --to " + o.to;
  if (o.auw_g > 0) o.command_line += fmt::format(" --auw-g {:g} --motors {}", o.auw_g, o.motors);
  const ExportReport r = buildExport(data, o);

  const std::string tmp = o.output + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) throw std::runtime_error("cannot write " + o.output + "; check the directory exists and is writable");
    f << r.file_text;
  }
  fs::rename(tmp, o.output);
  for (const auto& n : data.notes) std::fprintf(stderr, "note: %s\n", n.c_str());
  std::fputs(formatReport(r).c_str(), stdout);
  std::printf("\nwrote %s (%zu parameters)\n", o.output.c_str(), r.params.size());
  switch (r.to) {
    case Autopilot::kArduPilot:
      std::printf("load: Mission Planner Config > Full Parameter List > Load from file, or MAVProxy `param load %s`\n",
                  o.output.c_str());
      break;
    case Autopilot::kPx4:
      std::printf("load: QGroundControl Vehicle Setup > Parameters > Tools > Load from file\n");
      break;
    case Autopilot::kBetaflight:
      std::printf("load: paste %s into the Betaflight CLI (it ends with `save`)\n", o.output.c_str());
      break;
  }
  if (!o.plot.empty()) {
    std::vector<std::string> warnings;
    const auto images = writePlot(r, o.plot, warnings);
    if (!images.empty()) std::printf("plot: %s\n", fmt::format("{}", fmt::join(images, " ")).c_str());
    for (const auto& w : warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  }
  return 0;
}

}  // namespace lab::autopilot
