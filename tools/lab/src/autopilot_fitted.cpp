#include "autopilot_fitted.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <set>
#include <stdexcept>

namespace lab::autopilot {

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

}  // namespace lab::autopilot
