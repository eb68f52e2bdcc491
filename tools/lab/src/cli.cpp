// `thrustcal lab`: the commands registered, and those that do not fit and judge a model
// (export, effects, generate; diagnose, ladder and walk are cli_fit.cpp).
#include "lab/cli.hpp"
#include "lab/effect.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <filesystem>

#include "hex/intel_hex.hpp"

#include "lab/analysis.hpp"
#include "lab/autopilot_export.hpp"
#include "lab/dataset.hpp"
#include "lab/export.hpp"
#include "lab/generate.hpp"
#include "lab/model.hpp"
#include "lab/report.hpp"
#include "cli_common.hpp"

namespace lab {

namespace {

using cli::addDiagnose;
using cli::addLadder;
using cli::addWalk;
using cli::guarded;
using cli::selectAndCheck;

struct ExportArgs {
  std::vector<std::string> files;
  std::vector<std::string> maps;
  std::string model;
  int slot = -1;
  std::string eeprom;
  long motor = -1;
  std::string where;
  double max_error_pct = kDefaultMaxErrorPct;
};

int runExport(const ExportArgs& a) {
  const ModelSpec spec = parseSpec(a.model);
  checkExportable(spec, a.motor >= 0);  // refuse before reading anything
  if (a.slot < 0 || a.slot >= kEepromSlots)
    throw std::invalid_argument(fmt::format("--slot {}: the EEPROM holds slots 0..{}", a.slot, kEepromSlots - 1));
  ReadOptions ro;
  for (const auto& m : a.maps) ro.maps.push_back(parseColumnMap(m));
  Dataset data = readFiles(a.files, ro);
  std::vector<std::string> warnings;
  selectAndCheck(data, a.where, warnings);  // a force collapse is refused by exportModel
  if (a.motor >= 0) data = selectMotor(data, a.motor);
  const bool existed = std::filesystem::exists(a.eeprom);
  std::vector<uint8_t> image = existed ? hex::readIntelHexFile(a.eeprom, kEepromBytes)
                                       : std::vector<uint8_t>(kEepromBytes, 0xFF);
  const ExportResult r = exportModel(data, spec, static_cast<uint8_t>(a.slot), image, a.max_error_pct);
  if (r.write.status == tc::WriteV2Status::kWritten || !existed) {
    const std::string tmp = a.eeprom + ".tmp";
    hex::writeIntelHexFile(tmp, image);
    std::filesystem::rename(tmp, a.eeprom);
  }
  for (const auto& n : data.notes) std::fprintf(stderr, "note: %s\n", n.c_str());
  const tc::ModelV2& m = r.model;
  std::printf("model %s on %zu samples in %zu run(s): lab fit RMSE %.3f g, max %.2f g\n", r.fit.model.c_str(),
              r.fit.n, data.runs(), r.fit.rmse_g, r.fit.max_g);
  if (r.write.status == tc::WriteV2Status::kUnchanged)
    std::printf("slot %d copy %c, sequence %u already holds this model: nothing written to %s\n", a.slot,
                r.write.copy ? 'B' : 'A', r.write.sequence, a.eeprom.c_str());
  else
    std::printf("wrote slot %d copy %c, sequence %u (%u bytes changed) into %s (%s %zu-byte EEPROM image)\n",
                a.slot, r.write.copy ? 'B' : 'A', r.write.sequence, r.write.bytes_changed, a.eeprom.c_str(),
                existed ? "existing" : "new, erased", static_cast<std::size_t>(kEepromBytes));
  std::printf("  knots %u (%u every %.1f g, then every %.1f g), start threshold %.2f us, max force %.1f g, "
              "resting voltage %.2f V, sag at max force %.2f V\n",
              m.knots, m.fine_knots, m.step_dg / 10.0, m.coarse_step_dg / 10.0, m.start_q4_us / 16.0,
              m.maxForceDg() / 10.0, m.rest_mv / 1000.0, m.sag_10mv[m.knots - 1] * 10 / 1000.0);
  std::printf("  the record flown at the data's PWMs and motor voltages: RMSE %.3f g (max %.2f g) against the "
              "measured force, %.3f g (max %.2f g) against the lab model\n",
              r.v2_rmse_g, r.v2_max_g, r.v2_vs_lab_rmse_g, r.v2_vs_lab_max_g);
  for (const auto& n : r.notes) std::printf("  note: %s\n", n.c_str());
  // not avrdude -U eeprom:w: its verify fails on every stock Mega2560 (docs/board.md)
  std::printf("to the board: thrustcal board eeprom put --port PORT %s\n", a.eeprom.c_str());
  return 0;
}

// Export's data selection and the error a fit may have on its own data.
void addExportChecks(CLI::App* x, ExportArgs& ex) {
  x->add_option("--where", ex.where, "keep only the rows where EXPR holds, e.g. 'pwm_us < 1840' (as for diagnose)");
  x->add_option("--max-error-pct", ex.max_error_pct,
                "refuse a fit whose RMS error on its own data, or whose record flown at the data's PWMs, exceeds "
                "this percentage of the largest force")
      ->capture_default_str();
}

// Wraps `text` at `width` columns, continuation lines indented by `indent` spaces.
std::string wrap(const std::string& text, std::size_t width, std::size_t indent) {
  std::string out, line;
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t end = text.find(' ', pos);
    if (end == std::string::npos) end = text.size();
    const std::string word = text.substr(pos, end - pos);
    if (!line.empty() && line.size() + 1 + word.size() > width) {
      out += line + "\n" + std::string(indent, ' ');
      line.clear();
    }
    line += (line.empty() ? "" : " ") + word;
    pos = end + 1;
  }
  return out + line;
}

std::string effectsText() {
  std::string s = "Effects (a model SPEC joins them with '+', e.g. curve+deadband+voltage):\n";
  for (const auto& e : effectCatalogue()) {
    s += "\n  " + e.name + "\n";
    s += "    physics:    " + wrap(e.physics, 82, 16) + "\n";
    s += "    columns:    " + wrap(e.columns, 82, 16) + "\n";
    s += "    parameters: " + wrap(e.parameters, 82, 16) + "\n";
  }
  s += "\nData columns: pwm_us and force_g are required; t_s, motor, vbat_v, current_a, rpm, temp_c,\n"
       "dir are known; any other numeric column is a candidate variable for the diagnosis (a cause;\n"
       "current, speed, torque, power, vibration are the motor's responses: listed, never suspects).\n"
       "RCbenchmark/Tyto exports are read as they come (trailing commas, µs, N/kgf/gf/lbf/ozf, App\n"
       "message), each known column renamed to the lab's name and unit; other CSVs need --map, e.g.\n"
       "the Crazyflie data: --map force_g=weight[g]/4 --map pwm_us=pwm --map vbat_v=vbat[V]\n"
       "Every note of the reader is printed (stderr) and in --json (\"notes\").\n";
  return s;
}


void addExport(CLI::App* lab) {
  auto ex = std::make_shared<ExportArgs>();
  auto* x = lab->add_subcommand(
      "export", "fit a model and write it as the firmware's model v2 record into an EEPROM image (Intel HEX) "
                "that read_run flies");
  x->add_option("DATA", ex->files, "measurement CSV files (as for diagnose)")->required();
  x->add_option("--model,-m", ex->model,
                "model SPEC of what the firmware can run: curve, deadband, voltage, sag (e.g. "
                "curve+deadband+voltage+sag); other effects are refused")
      ->required();
  x->add_option("--slot", ex->slot, "motor slot 0..3 to write")->required();
  x->add_option("--eeprom", ex->eeprom,
                "EEPROM image (Intel HEX): updated in place when it exists (other slots kept), else "
                "created erased")
      ->required();
  x->add_option("--motor", ex->motor, "use only this motor's rows (data with a motor column)");
  addExportChecks(x, *ex);
  x->add_option("--map", ex->maps, "column mapping TARGET=SOURCE[*K|/K|+K|-K...], repeatable");
  x->footer("Example: thrustcal lab export sag.csv --model curve+deadband+voltage+sag --slot 0 --eeprom board.hex\n"
            "Then: thrustcal board eeprom put --port PORT board.hex (docs/board.md)");
  const auto ap = autopilot::addExportOptions(x);  // --to ardupilot|px4|betaflight -o FILE
  x->callback([ex, ap] {
    const int rc = guarded([&] {
      return ap->to.empty() ? runExport(*ex) : autopilot::runExport(*ap, ex->files, ex->maps, ex->motor, ex->model);
    });
    if (rc) throw CLI::RuntimeError(rc);
  });
}

void addEffects(CLI::App* lab) {
  auto* e = lab->add_subcommand("effects", "document every effect: physics, columns, parameters with units");
  auto markdown = std::make_shared<bool>(false);
  e->add_flag("--markdown", *markdown, "print docs/lab.md's effect table instead (names, columns, parameters)");
  e->callback([markdown] { std::fputs((*markdown ? effects::markdownTable() : effectsText()).c_str(), stdout); });
}

// `generate`: the data set in the project's CSV or a thrust stand's layout, to a file or stdout.
int runGenerate(const GenerateOptions& gen, const std::string& out, const std::string& layout,
                const StandLayout& stand) {
  std::vector<std::string> comments;
  const Dataset d = generate(gen, &comments);
  std::string csv;
  if (layout == "project") {
    csv = toCsv(d, comments);
  } else if (layout.rfind("rcbenchmark-", 0) == 0) {
    StandLayout l = stand;
    l.series = layout.substr(12);
    csv = toStandCsv(d, l);
  } else {
    throw std::invalid_argument("--layout '" + layout + "': project, rcbenchmark-1520 or rcbenchmark-1585");
  }
  if (out.empty()) {
    std::fputs(csv.c_str(), stdout);
    return 0;
  }
  std::ofstream f(out, std::ios::binary);
  if (!f) throw std::runtime_error("cannot write " + out);
  f << csv;
  std::fprintf(stderr, "wrote %s (%zu samples, %zu runs)\n", out.c_str(), d.rows(), d.runs());
  for (std::size_t i = 1; i < comments.size(); ++i) std::fprintf(stderr, "  %s\n", comments[i].c_str());
  return 0;
}

void addGenerate(CLI::App* lab) {
  auto gen = std::make_shared<GenerateOptions>();
  auto out = std::make_shared<std::string>();
  auto* g = lab->add_subcommand("generate", "write a synthetic bench log from the plant model with a hidden effect");
  std::string hidden_help = "hidden effect:";
  for (const auto& h : hiddenEffects()) hidden_help += "\n  " + h.name + ": " + h.description;
  g->add_option("--hidden", gen->hidden, hidden_help)->capture_default_str();
  g->add_option("--noise-g", gen->noise_g, "load-cell noise, one standard deviation (g)")->capture_default_str();
  g->add_option("--seed", gen->seed, "random seed (parts, noise)")->capture_default_str();
  g->add_option("--preset", gen->preset, "plant preset (motor + propeller)")->capture_default_str();
  g->add_option("--output,-o", *out, "CSV file to write (default: standard output)");
  g->add_option("--log-hz", gen->log_hz, "log rows at this rate while each PWM point settles (0: one row per point)")
      ->capture_default_str();
  g->add_option("--settle-s", gen->settle_s, "seconds per PWM point (0: the hidden effect's default)")
      ->capture_default_str();
  g->add_flag("--bench-filter", gen->bench_filter,
              "read the force through the plant's load-cell low-pass (three 30 ms stages), as a bench does");
  g->add_option("--noise-lag1", gen->noise_lag1,
                "the noise's lag-1 autocorrelation from row to row (AR(1): a filtered reading), 0..0.95")
      ->capture_default_str();
  auto layout = std::make_shared<std::string>("project");
  auto stand = std::make_shared<StandLayout>();
  g->add_option("--layout", *layout,
                "file layout: project (the lab's CSV), rcbenchmark-1520 or rcbenchmark-1585 (an RCbenchmark / Tyto "
                "export as its software writes it: trailing commas, µs, App message)")
      ->capture_default_str();
  g->add_option("--thrust-unit", stand->thrust_unit, "thrust unit of an RCbenchmark layout: N, kgf, gf, lbf, ozf")
      ->capture_default_str();
  g->add_option("--torque-unit", stand->torque_unit, "torque unit of the 1585 layout: N·m or ozf·in")
      ->capture_default_str();
  g->add_flag("--negative-thrust", stand->negative_thrust, "log thrust negative (a stand pulling the other way)");
  g->callback([gen, out, layout, stand] {
    const int rc = guarded([&] { return runGenerate(*gen, *out, *layout, *stand); });
    if (rc) throw CLI::RuntimeError(rc);
  });
}

}  // namespace

void registerCommands(CLI::App& app) {
  auto* lab = app.add_subcommand(
      "lab",
      "model lab: compare the force model with measurements, see where it fails, find the missing "
      "effect, add it, watch the error fall");
  lab->require_subcommand(1);
  lab->footer(effectsText());
  addDiagnose(lab);
  addLadder(lab);
  addWalk(lab);
  addExport(lab);
  addEffects(lab);
  addGenerate(lab);
}

}  // namespace lab
