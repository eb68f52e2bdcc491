// `lab export --to ...`: the comparison printed, the plot, and the command's options and run.
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

namespace fs = std::filesystem;

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

