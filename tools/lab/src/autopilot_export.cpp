// `lab export --to ...`: the export built: the rows, the autopilot's model fitted (with and
// without a voltage term), at its defaults, per motor, and against thrustcal's model v2.
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
#include "autopilot_fitted.hpp"

namespace lab::autopilot {

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

}  // namespace lab::autopilot
