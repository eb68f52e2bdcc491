#include "lab/export.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

#include "lab/analysis.hpp"
#include "lab/effect.hpp"

#include "thrustcal/eeprom_image.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/model_v2_curve.hpp"
// The record's limits are core's (thrustcal/record_limits.hpp, "never fly a record that cannot
// be right"); until that header exists in this tree the values core's model_v2.cpp checks today
// stand in, so the messages follow core either way.
#if __has_include("thrustcal/record_limits.hpp")
#include "thrustcal/record_limits.hpp"
#define LAB_CORE_RECORD_LIMITS 1
#endif

namespace lab {

namespace {

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

// Refusals: what failed, its value, the limit (and where it comes from), what to do.
[[noreturn]] void refuse(const std::string& what) { throw std::invalid_argument("cannot export: " + what); }

}  // namespace

RecordLimitsForExport recordLimits() {
  RecordLimitsForExport l;
#ifdef LAB_CORE_RECORD_LIMITS
  l.start_min_us = tc::kStartMinUs;
  l.start_max_us = tc::kStartMaxUs;
  l.rest_min_v = tc::kPackMinMv / 1000.0;
  l.rest_max_v = tc::kPackMaxMv / 1000.0;
  l.force_min_g = tc::kRecordMinForceG;
  l.force_max_g = tc::kRecordMaxForceG;
  l.pwm_min_us = tc::kThrottleMinUs;
  l.pwm_max_us = tc::kThrottleMaxUs;
  l.max_sag_pct = tc::kMaxSagPercent;
  l.source = "core's thrustcal/record_limits.hpp";
#else
  l.source = "core's model_v2.cpp (ModelV2::finalize)";
#endif
  return l;
}

void checkExportData(const Dataset& data) {
  const RecordLimitsForExport lim = recordLimits();
  const auto& pw = data.col("pwm_us");
  std::size_t outside = 0;
  double worst = 0;
  for (double p : pw) {
    if (!std::isfinite(p)) refuse("pwm_us holds a value that is not a number; the reader should have refused it");
    if (p < lim.pwm_min_us || p > lim.pwm_max_us) {
      if (!outside || std::fabs(p - 1500) > std::fabs(worst - 1500)) worst = p;
      ++outside;
    }
  }
  if (outside)
    refuse(fmt::format("{} row(s) have pwm_us outside the ESC pulse range {:.0f}..{:.0f} us (e.g. {:.6g} us; limit "
                       "from {}): the record maps force to servo pulses. If the drive is not in microseconds, map "
                       "it (--map pwm_us=...); else drop those rows (--where 'pwm_us >= {:.0f} and pwm_us <= {:.0f}')",
                       outside, lim.pwm_min_us, lim.pwm_max_us, worst, lim.source, lim.pwm_min_us, lim.pwm_max_us));
  std::set<long> levels;
  for (double p : pw) levels.insert(std::lround(p));
  const std::size_t min_rows = 20;
  if (data.rows() < min_rows || levels.size() < kMinExportPwmLevels)
    refuse(fmt::format("{} rows at {} distinct PWMs are too few for a record that will fly (at least {} rows at {} "
                       "PWMs): measure a whole sweep, start to full throttle",
                       data.rows(), levels.size(), min_rows, kMinExportPwmLevels));
}

void checkExportable(const ModelSpec& spec, bool motor_selected) {
  // what a record can hold is each effect's registry entry (effects/<effect>.cpp)
  for (const auto& e : spec.effects) {
    const effects::EffectDef* d = effects::find(e);
    if (d && d->exports == effects::Export::kInRecord) continue;
    if (d && d->exports == effects::Export::kOneMotor && motor_selected) continue;
    throw std::invalid_argument(fmt::format("cannot export `{}`: {}", e,
                                            d && !d->export_note.empty() ? d->export_note
                                                                         : "the firmware's model v2 has no such term"));
  }
  for (const auto& u : spec.user)
    for (const auto* d : effects::registry())
      if (d->role == effects::Role::kExpression && d->multiplicative == u.multiplicative)
        throw std::invalid_argument(fmt::format("cannot export `{} {}`: {}", d->prefix, u.expression, d->export_note));
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

namespace {

// The arguments and data an export starts from; returns the SPEC fitted (without `motor`:
// the data hold one motor).
ModelSpec checkExportInputs(const Dataset& data, const ModelSpec& spec_in, uint8_t slot,
                            const std::vector<uint8_t>& eeprom) {
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
  checkExportData(data);
  const auto collapses = findForceCollapse(data);
  if (!collapses.empty()) refuse(describe(collapses.front()));
  return spec;
}

// A fit that cannot be right on its own data: not finite, or far from it.
void checkFit(const ExportResult& r, double max_error_pct, double top_force) {
  for (const auto& p : r.fit.params)
    if (!std::isfinite(p.value))
      refuse(fmt::format("the fit's {} is not a number; the data cannot carry this model", p.name));
  if (!std::isfinite(r.fit.rmse_g)) refuse("the fit's error is not a number; check the data (thrustcal lab diagnose)");
  if (r.fit.rmse_g > max_error_pct / 100.0 * top_force)
    refuse(fmt::format("the fit misses its own data by {:.3g} g RMS, {:.2f} % of the largest force {:.4g} g (limit "
                       "--max-error-pct {:.3g} %): the model lacks something the data show or the data hold "
                       "something a record should not (run `thrustcal lab diagnose` on them; cut bad rows with "
                       "--where)",
                       r.fit.rmse_g, 100.0 * r.fit.rmse_g / top_force, top_force, max_error_pct));
}

// The start threshold, the voltage exponent and the resting voltage the record takes from the
// fit, with their notes and refusals. Returns the data's top PWM.
double startAndVoltage(ExportResult& r, const Model& model, const ModelSpec& spec, const Dataset& data,
                       const RecordLimitsForExport& lim) {
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
#ifdef LAB_CORE_RECORD_LIMITS
  if (r.rest_v * 1000.0 > tc::kDefaultFullScaleMv)
    r.notes.push_back(fmt::format(
        "the record holds a resting voltage of {:.2f} V; the battery monitor reads up to {:.2f} V with the default "
        "divider ({} k / {} k): set the board's divider for this pack before flying, or read_run refuses the record",
        r.rest_v, tc::kDefaultFullScaleMv / 1000.0, tc::kDefaultDividerTopOhm / 1000, tc::kDefaultDividerBottomOhm / 1000));
#endif
  const double pmax = *std::max_element(pw.begin(), pw.end());
  if (!(pmax > r.start_us + 10))
    refuse(fmt::format("the fitted start threshold {:.1f} us is at the data's top PWM {:.1f} us: no curve to "
                       "export; measure up to full throttle", r.start_us, pmax));
  if (r.start_us < lim.start_min_us || r.start_us > lim.start_max_us)
    refuse(fmt::format("the ESC start threshold {:.1f} us is outside {:.0f}..{:.0f} us (limit from {}): {}", r.start_us,
                       lim.start_min_us, lim.start_max_us, lim.source,
                       r.start_us < lim.start_min_us
                           ? "the motor would push at the stop pulse; fit with `deadband` (and check the ESC's "
                             "calibration), or drop the rows below the start"
                           : "the ESC starts too late (check its throttle calibration) or the fit went wrong; fit "
                             "with `deadband` on data from the stop pulse up"));
  if (r.rest_v < lim.rest_min_v || r.rest_v > lim.rest_max_v)
    refuse(fmt::format("the resting voltage {:.2f} V is outside the pack range {:.1f}..{:.1f} V (limit from {}): "
                       "check the voltage column's unit (--map vbat_v=...) and the pack",
                       r.rest_v, lim.rest_min_v, lim.rest_max_v, lim.source));
  return pmax;
}

// The curve a record holds: drive (pwm - start) * V_motor, force, and the battery sag (mV) the
// monitor sees at each point.
struct RecordCurve {
  std::vector<double> drive, force, sag;
  double fmax = 0;
  double r_sag = NAN;  // the fit's source resistance (NaN: no `sag`)
};

// This motor's current ~ c * force^1.5 (the intercept is the rest of the frame), for the sag at
// each point of the curve; 0 when it cannot be estimated.
double ampsPerG15(const Dataset& data, double r_sag) {
  double amps_per_g15 = 0;
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
  return amps_per_g15;
}

// The curve: a PWM sweep at the resting voltage, nothing else on the battery. It covers the
// forces the data reached (`lab_pred`): above them the lab curve is extrapolated (the firmware
// reports saturation there instead).
RecordCurve recordCurve(const Model& model, const ModelSpec& spec, const Dataset& data, const ExportResult& r,
                        double pmax, const std::vector<double>& lab_pred) {
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

  RecordCurve c;
  c.r_sag = spec.has("sag") ? param(r.fit, "r_sag_ohm", NAN) : NAN;
  const double amps_per_g15 = ampsPerG15(data, c.r_sag);
  double reached = 0;
  for (double f : lab_pred)
    if (std::isfinite(f)) reached = std::max(reached, f);
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(f_lab[i]) || !std::isfinite(v_motor[i])) continue;
    if (f_lab[i] > reached) {
      // close the curve exactly at the largest force reached
      if (!c.drive.empty() && c.force.back() < reached) {
        const double t = (reached - c.force.back()) / (f_lab[i] - c.force.back());
        const double d = c.drive.back() + t * ((p[i] - r.start_us) * v_motor[i] - c.drive.back());
        const double s = c.sag.back();
        c.drive.push_back(d);
        c.force.push_back(reached);
        c.sag.push_back(s);
      }
      break;
    }
    c.fmax = std::max(c.fmax, std::max(f_lab[i], 0.0));  // monotone, as the record needs
    c.drive.push_back((p[i] - r.start_us) * v_motor[i]);
    c.force.push_back(c.fmax);
    if (std::isfinite(c.r_sag))
      c.sag.push_back(1000.0 * c.r_sag * amps_per_g15 * std::pow(c.fmax, 1.5));
    else
      c.sag.push_back(1000.0 * (r.rest_v - v_motor[i]));
  }
  return c;
}

// The curve as core's record: refused outside the record's limits.
tc::ModelV2 recordOf(const RecordCurve& c, const ExportResult& r, const RecordLimitsForExport& lim) {
  const double fmax = c.fmax;
  if (fmax < lim.force_min_g || fmax > lim.force_max_g)
    refuse(fmt::format("the largest force {:.4g} g is outside {:.4g}..{:.4g} g (limit from {}): {}", fmax,
                       lim.force_min_g, lim.force_max_g, lim.source,
                       fmax < lim.force_min_g ? "the motor barely pushed; check the load cell's tare and unit "
                                                "(--map force_g=...) and measure to full throttle"
                                              : "check the force column's unit (N or kgf logged as grams?)"));
  for (std::size_t i = 0; i < c.sag.size(); ++i)
    if (c.sag[i] > lim.max_sag_pct / 100.0 * 1000.0 * r.rest_v)
      refuse(fmt::format("the battery sag at {:.4g} g is {:.2f} V, more than {:.0f} % of the resting {:.2f} V (limit "
                         "from {}): a wiring or supply fault, or a sag fit gone wrong (r_sag_ohm {:.3g})",
                         c.force[i], c.sag[i] / 1000.0, lim.max_sag_pct, r.rest_v, lim.source, c.r_sag));
  tc::ModelV2 m;
  if (c.drive.size() < 2 ||
      !tc::modelV2FromCurve(m, r.start_us, c.drive.data(), c.force.data(), static_cast<uint16_t>(c.drive.size()),
                            1000.0 * r.rest_v, c.sag.data()))
    refuse(fmt::format("core's modelV2FromCurve refused the curve (start {:.1f} us, resting voltage {:.2f} V, largest "
                       "force {:.4g} g, {} points): a limit of the record not checked above; please report it with "
                       "the data",
                       r.start_us, r.rest_v, fmax, c.drive.size()));
  return m;
}

// Faithful? Fly the record at every row's PWM and the voltage the monitor reads there.
void flyRecord(ExportResult& r, const Model& model, const Dataset& data, const std::vector<double>& lab_pred,
               double max_error_pct, double top_force, double fmax) {
  const tc::ModelV2& m = r.model;
  const std::vector<double> vrow = model.motorVoltage(data);
  const auto& meas = data.col("force_g");
  const auto& pw = data.col("pwm_us");
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
  if (r.v2_rmse_g > max_error_pct / 100.0 * top_force)
    refuse(fmt::format("the record, flown at the data's PWMs and voltages, misses the measured force by {:.3g} g RMS, "
                       "{:.2f} % of the largest force {:.4g} g (limit --max-error-pct {:.3g} %; the lab fit alone: "
                       "{:.3g} g): {}",
                       r.v2_rmse_g, 100.0 * r.v2_rmse_g / top_force, top_force, max_error_pct, r.fit.rmse_g,
                       std::fabs(r.gamma - 1.0) > 0.05
                           ? fmt::format("the fit needs what the firmware does not do (gamma {:.3f}, the firmware's "
                                         "is 1); fit curve+deadband+voltage+sag and check gamma",
                                         r.gamma)
                           : std::string("export the model the ladder ends with, or measure again")));
  if (r.v2_vs_lab_rmse_g > std::max(2.0, 0.005 * fmax))
    r.notes.push_back(fmt::format(
        "the record departs from the lab model by {:.1f} g RMS ({:.1f} % of {:.0f} g): the fit needs what "
        "the firmware does not do (gamma far from 1?); fit curve+deadband+voltage+sag and check gamma",
        r.v2_vs_lab_rmse_g, 100.0 * r.v2_vs_lab_rmse_g / fmax, fmax));
}

}  // namespace

ExportResult exportModel(const Dataset& data, const ModelSpec& spec_in, uint8_t slot,
                         std::vector<uint8_t>& eeprom, double max_error_pct) {
  const ModelSpec spec = checkExportInputs(data, spec_in, slot, eeprom);
  const RecordLimitsForExport lim = recordLimits();
  ExportResult r;
  Model model(spec, data);
  r.fit = model.fit();
  const double top_force = [&] {
    double m = 0;
    for (double f : data.col("force_g")) m = std::max(m, f);
    return m;
  }();
  checkFit(r, max_error_pct, top_force);
  const double pmax = startAndVoltage(r, model, spec, data, lim);
  const std::vector<double> lab_pred = model.predict(data);
  const RecordCurve curve = recordCurve(model, spec, data, r, pmax, lab_pred);
  r.model = recordOf(curve, r, lim);
  flyRecord(r, model, data, lab_pred, max_error_pct, top_force, curve.fmax);

  std::vector<uint8_t> work = eeprom;
  {
    const tc::EepromImage::Use use(work);
    r.write = tc::writeModelV2<tc::EepromImage>(slot, r.model);
  }
  if (r.write.status != tc::WriteV2Status::kWritten && r.write.status != tc::WriteV2Status::kUnchanged)
    throw std::runtime_error(fmt::format("writing the v2 record into slot {} failed: {}", slot,
                                         tc::writeV2StatusText(r.write.status)));
  eeprom.swap(work);
  return r;
}

}  // namespace lab
