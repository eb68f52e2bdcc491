#include "lab/export.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "thrustcal/model_v2.hpp"

namespace lab {

namespace {

// Why each effect the record has no term for cannot be exported, and what to do instead.
const char* refusalReason(const std::string& effect) {
  if (effect == "drift")
    return "read_run has no clock-dependent term (the record holds no time); fit without it, or "
           "re-zero the load cell and measure again";
  if (effect == "lag")
    return "read_run sets the steady-state PWM for a force and the record holds no time constant; "
           "fit without it (the steady-state curve is what the board needs)";
  if (effect == "thermal")
    return "the board reads no motor temperature and the record holds no temperature term; fit "
           "without it, on data taken at the temperature you fly at";
  if (effect == "density")
    return "the board has no air-density input and the record holds no density term; fit without "
           "it, on data taken in the air you fly in";
  if (effect == "motor")
    return "a record holds one motor; pick one motor's rows with --motor N and export each motor "
           "into its own slot";
  if (effect == "thesis")
    return "the thesis model is the v1 record, which gather_store writes on the board; export a "
           "curve model, e.g. curve+deadband+voltage+sag";
  return nullptr;
}

// EEPROM image as the Storage type record_v2.hpp's templates need.
std::vector<uint8_t>* g_image = nullptr;
struct ImageStorage {
  static uint8_t readByte(uint16_t addr) { return (*g_image)[addr]; }
  static void updateByte(uint16_t addr, uint8_t value) { (*g_image)[addr] = value; }
};

double rms(const std::vector<double>& e) {
  double s = 0;
  std::size_t n = 0;
  for (double v : e)
    if (std::isfinite(v)) s += v * v, ++n;
  return n ? std::sqrt(s / static_cast<double>(n)) : NAN;
}
double maxAbs(const std::vector<double>& e) {
  double m = 0;
  for (double v : e)
    if (std::isfinite(v)) m = std::max(m, std::fabs(v));
  return m;
}

double param(const FitResult& f, const char* name, double fallback) {
  for (const auto& p : f.params)
    if (p.name == name) return p.value;
  return fallback;
}

}  // namespace

void checkExportable(const ModelSpec& spec, bool motor_selected) {
  for (const auto& e : spec.effects) {
    if (e == "curve" || e == "deadband" || e == "voltage" || e == "sag") continue;
    if (e == "motor" && motor_selected) continue;
    const char* why = refusalReason(e);
    throw std::invalid_argument(
        fmt::format("cannot export `{}`: {}", e, why ? why : "the firmware's model v2 has no such term"));
  }
  if (!spec.user.empty())
    throw std::invalid_argument(fmt::format(
        "cannot export `{}: {}`: the firmware evaluates no expressions (the record holds a curve, a "
        "start threshold and a sag table); fit without it",
        spec.user.front().multiplicative ? "mul" : "add", spec.user.front().expression));
}

Dataset selectMotor(const Dataset& data, long motor_id) {
  if (!data.has("motor"))
    throw std::invalid_argument("--motor needs a `motor` column; the data has none (one motor per file: drop --motor)");
  const auto& m = data.col("motor");
  std::vector<bool> keep(data.rows());
  bool any = false;
  for (std::size_t i = 0; i < keep.size(); ++i) any |= keep[i] = std::lround(m[i]) == motor_id;
  if (!any) throw std::invalid_argument(fmt::format("--motor {}: no row of the data has motor {}", motor_id, motor_id));
  return data.subset(keep);
}

ExportResult exportModel(const Dataset& data, const ModelSpec& spec_in, uint8_t slot,
                         std::vector<uint8_t>& eeprom) {
  if (slot >= kEepromSlots)
    throw std::invalid_argument(fmt::format("--slot {}: the EEPROM holds slots 0..{}", slot, kEepromSlots - 1));
  if (eeprom.size() != kEepromBytes)
    throw std::invalid_argument(fmt::format("the EEPROM image has {} bytes, expected {}", eeprom.size(), kEepromBytes));
  if (data.has("motor")) {
    const auto& m = data.col("motor");
    for (double v : m)
      if (std::lround(v) != std::lround(m.front()))
        throw std::invalid_argument(
            "the data hold several motors and a record is one motor's: choose one with --motor N");
  }
  ModelSpec spec = spec_in;
  checkExportable(spec, true);
  spec.effects.erase(std::remove(spec.effects.begin(), spec.effects.end(), "motor"), spec.effects.end());
  if (!data.has("vbat_v"))
    throw std::invalid_argument(
        "export needs the battery voltage (vbat_v): the firmware's drive is (pwm - start) * V; "
        "log it (or --map vbat_v=...) and fit again");
  for (double v : data.col("vbat_v"))
    if (!std::isfinite(v)) throw std::invalid_argument("export needs vbat_v on every row; some rows have none");

  ExportResult r;
  Model model(spec, data);
  r.fit = model.fit();
  r.start_us = model.startUs();
  r.gamma = spec.has("voltage") ? param(r.fit, "gamma", 1.0) : 1.0;
  const auto& vb = data.col("vbat_v");
  const auto& pw = data.col("pwm_us");
  r.rest_v = *std::max_element(vb.begin(), vb.end());
  if (!spec.has("voltage"))
    r.notes.push_back("the model has no `voltage`: the firmware scales the drive with the bus voltage "
                      "anyway (gamma 1); add `voltage` so the lab model says the same");
  else if (std::fabs(r.gamma - 1.0) > 0.05)
    r.notes.push_back(fmt::format("gamma {:.3f}: the firmware's drive is (pwm - start) * V (gamma 1); away "
                                  "from {:.2f} V the export follows the firmware's physics, not the fit",
                                  r.gamma, r.rest_v));
  const double pmax = *std::max_element(pw.begin(), pw.end());
  if (!(pmax > r.start_us + 10))
    throw std::invalid_argument(fmt::format("the fitted start threshold {:.1f} us is at the data's top PWM "
                                            "{:.1f} us: no curve to export", r.start_us, pmax));

  // The curve: a PWM sweep at the resting voltage, nothing else on the battery.
  const std::size_t n = 256;
  Dataset sweep;
  std::vector<double> p(n), zero(n, 0.0), v(n, r.rest_v);
  for (std::size_t i = 0; i < n; ++i)
    p[i] = r.start_us + (pmax - r.start_us) * static_cast<double>(i + 1) / static_cast<double>(n);
  sweep.run.assign(n, 0);
  sweep.run_labels = {"export sweep"};
  sweep.set("pwm_us", p);
  sweep.set("force_g", zero);
  sweep.set("vbat_v", v);
  if (data.has("current_a")) sweep.set("current_a", zero);
  if (data.has("motor")) sweep.set("motor", std::vector<double>(n, data.col("motor").front()));
  const std::vector<double> f_lab = model.predict(sweep);
  const std::vector<double> v_motor = model.motorVoltage(sweep);

  // The battery sag the monitor sees at each point of the curve (for command steps).
  const double r_sag = spec.has("sag") ? param(r.fit, "r_sag_ohm", NAN) : NAN;
  double amps_per_g15 = 0;  // this motor's current ~ c * force^1.5, intercept = the rest of the frame
  if (std::isfinite(r_sag) && data.has("current_a")) {
    const auto& cur = data.col("current_a");
    const auto& f = data.col("force_g");
    double s1 = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (std::size_t i = 0; i < data.rows(); ++i) {
      const double x = std::pow(std::max(f[i], 0.0), 1.5);
      s1 += 1, sx += x, sy += cur[i], sxx += x * x, sxy += x * cur[i];
    }
    const double det = s1 * sxx - sx * sx;
    if (det > 0) amps_per_g15 = std::max(0.0, (s1 * sxy - sx * sy) / det);
  }

  // The record covers the forces the data reached: above them the lab curve is extrapolated
  // (the firmware reports saturation there instead).
  const std::vector<double> lab_pred = model.predict(data);
  double reached = 0;
  for (double f : lab_pred)
    if (std::isfinite(f)) reached = std::max(reached, f);
  std::vector<double> drive, force, sag;
  double fmax = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(f_lab[i]) || !std::isfinite(v_motor[i])) continue;
    if (f_lab[i] > reached) {
      // close the curve exactly at the largest force reached
      if (!drive.empty() && force.back() < reached) {
        const double t = (reached - force.back()) / (f_lab[i] - force.back());
        const double d = drive.back() + t * ((p[i] - r.start_us) * v_motor[i] - drive.back());
        const double s = sag.back();
        drive.push_back(d);
        force.push_back(reached);
        sag.push_back(s);
      }
      break;
    }
    fmax = std::max(fmax, std::max(f_lab[i], 0.0));  // monotone, as the record needs
    drive.push_back((p[i] - r.start_us) * v_motor[i]);
    force.push_back(fmax);
    if (std::isfinite(r_sag))
      sag.push_back(1000.0 * r_sag * amps_per_g15 * std::pow(fmax, 1.5));
    else
      sag.push_back(1000.0 * (r.rest_v - v_motor[i]));
  }
  tc::ModelV2 m;
  if (drive.size() < 2 ||
      !tc::modelV2FromCurve(m, r.start_us, drive.data(), force.data(), static_cast<uint16_t>(drive.size()),
                            1000.0 * r.rest_v, sag.data()))
    throw std::invalid_argument(fmt::format(
        "the fitted curve does not fit a v2 record (start {:.1f} us must lie in 800..1800, resting voltage "
        "{:.2f} V in 6..17.5, largest force {:.1f} g at least 13.2 and at most 6553.5)",
        r.start_us, r.rest_v, fmax));
  r.model = m;

  // Faithful? Fly the record at every row's PWM and the voltage the monitor reads there.
  const std::vector<double> vrow = model.motorVoltage(data);
  const auto& meas = data.col("force_g");
  std::vector<double> e_meas(data.rows()), e_lab(data.rows());
  r.v2_force_g.resize(data.rows());
  for (std::size_t i = 0; i < data.rows(); ++i) {
    const double mv = std::clamp(1000.0 * vrow[i], 0.0, 65535.0);
    const double pwm = std::clamp(pw[i], 0.0, 65535.0);
    r.v2_force_g[i] = tc::forceForPwmDg(m, static_cast<uint16_t>(std::lround(pwm)),
                                        static_cast<uint16_t>(std::lround(mv))) / 10.0;
    e_meas[i] = meas[i] - r.v2_force_g[i];
    e_lab[i] = lab_pred[i] - r.v2_force_g[i];
  }
  r.v2_rmse_g = rms(e_meas);
  r.v2_max_g = maxAbs(e_meas);
  r.v2_vs_lab_rmse_g = rms(e_lab);
  r.v2_vs_lab_max_g = maxAbs(e_lab);
  if (r.v2_vs_lab_rmse_g > std::max(2.0, 0.005 * fmax))
    r.notes.push_back(fmt::format(
        "the record departs from the lab model by {:.1f} g RMS ({:.1f} % of {:.0f} g): the fit needs what "
        "the firmware does not do (gamma far from 1?); fit curve+deadband+voltage+sag and check gamma",
        r.v2_vs_lab_rmse_g, 100.0 * r.v2_vs_lab_rmse_g / fmax, fmax));

  std::vector<uint8_t> work = eeprom;
  g_image = &work;
  r.write = tc::writeModelV2<ImageStorage>(slot, m);
  g_image = nullptr;
  if (r.write.status != tc::WriteV2Status::kWritten && r.write.status != tc::WriteV2Status::kUnchanged)
    throw std::runtime_error(fmt::format("writing the v2 record into slot {} failed: {}", slot,
                                         tc::writeV2StatusText(r.write.status)));
  eeprom.swap(work);
  return r;
}

}  // namespace lab
