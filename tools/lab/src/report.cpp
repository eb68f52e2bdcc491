#include "lab/report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace lab {

namespace {

namespace fs = std::filesystem;

void writeText(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary);
  if (!out) throw std::runtime_error("cannot write " + p.string() + "; check the directory is writable");
  out << text;
}

std::string quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') out += "''"; else out += c;
  }
  return out + "'";
}

// Labels: the terminals run with `noenhanced`, so only quotes need care.
std::string label(const std::string& s) { return quote(s); }

std::string stepName(const LadderStep& s, std::size_t i) {
  return i == 0 ? s.spec.text() : "+" + s.added;
}

}  // namespace

ReportFiles writeReport(const std::string& dir_name, const Dataset& data,
                        const std::vector<LadderStep>& steps, const std::string& command_line) {
  ReportFiles files;
  const fs::path dir(dir_name);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw std::runtime_error("cannot create report directory " + dir_name + ": " + ec.message());
  if (steps.empty()) throw std::invalid_argument("nothing to report");

  // Data: one row per sample, prediction and residual of every step.
  const auto& pwm = data.col("pwm_us");
  const auto& force = data.col("force_g");
  std::vector<std::string> suspects;
  for (const auto& s : steps.front().variables)
    if (s.significant && suspects.size() < 3 && s.variable != "run") suspects.push_back(s.variable);
  if (suspects.empty())
    for (const auto& s : steps.front().variables)
      if (suspects.size() < 2 && s.variable != "run") suspects.push_back(s.variable);
  {
    std::string tsv = "# pwm_us force_g";
    for (std::size_t k = 0; k < steps.size(); ++k) tsv += fmt::format(" pred{} resid{}", k, k);
    for (const auto& v : suspects) tsv += " " + v;
    tsv += "\n";
    for (std::size_t i = 0; i < data.rows(); ++i) {
      tsv += fmt::format("{:.6g} {:.6g}", pwm[i], force[i]);
      for (const auto& s : steps)
        tsv += fmt::format(" {:.6g} {:.6g}", s.fit.predicted_g[i], s.fit.residual_g[i]);
      for (const auto& v : suspects) tsv += fmt::format(" {:.6g}", data.has(v) ? data.col(v)[i] : NAN);
      tsv += "\n";
    }
    writeText(dir / "data.tsv", tsv);
    std::string lad = "# step rmse_g max_g bic\n";
    for (std::size_t k = 0; k < steps.size(); ++k)
      lad += fmt::format("{} {:.6g} {:.6g} {:.6g} \"{}\"\n", k, steps[k].fit.rmse_g, steps[k].fit.max_g,
                         steps[k].fit.bic, stepName(steps[k], k));
    writeText(dir / "ladder.tsv", lad);
  }

  // gnuplot script: every plot in PNG and SVG.
  std::vector<std::pair<std::string, std::string>> plots;  // base name, plot commands
  const std::string data_file = quote((dir / "data.tsv").string());
  {
    std::string cmd = "set xlabel 'PWM (us)'\nset ylabel 'force (g)'\nset key left top\n";
    cmd += fmt::format("set title {}\n", label("measured vs model"));
    // models first, the measurements last (open circles on top) so both stay visible
    cmd += fmt::format("plot {} using 1:3 with points pt 7 ps 0.5 lc rgb '#d62728' title {}", data_file,
                       label("model: " + stepName(steps.front(), 0)));
    if (steps.size() > 1)
      cmd += fmt::format(", '' using 1:{} with points pt 7 ps 0.5 lc rgb '#1f77b4' title {}",
                         3 + 2 * (steps.size() - 1), label("model: " + steps.back().spec.text()));
    cmd += ", '' using 1:2 with points pt 6 ps 0.9 lc rgb '#222222' title 'measured'";
    plots.emplace_back("measured_vs_model", cmd + "\n");
  }
  const char* colors[] = {"#d62728", "#ff7f0e", "#2ca02c", "#1f77b4", "#9467bd", "#8c564b", "#e377c2"};
  for (std::size_t v = 0; v < suspects.size(); ++v) {
    std::string cmd = fmt::format("set xlabel {}\nset ylabel 'residual (g)'\nset key outside right\n", label(suspects[v]));
    cmd += fmt::format("set title {}\n", label("residual vs " + suspects[v] + " as effects are added"));
    cmd += "plot ";
    const int col = 3 + 2 * static_cast<int>(steps.size()) + static_cast<int>(v);
    for (std::size_t k = 0; k < steps.size(); ++k) {
      cmd += fmt::format("{}{} using {}:{} with points pt 7 ps 0.35 lc rgb '{}' title {}",
                         k ? ", " : "", k ? "''" : data_file, col, 4 + 2 * k, colors[k % 7],
                         label(fmt::format("{} (RMSE {:.2f} g)", stepName(steps[k], k), steps[k].fit.rmse_g)));
    }
    plots.emplace_back("residual_vs_" + suspects[v], cmd + "\n");
  }
  {
    std::string cmd = "set style fill solid 0.6\nset boxwidth 0.6\nset ylabel 'error (g)'\nset xtics rotate by -20\n";
    cmd += "set key left top\nset title 'the error ladder'\nset yrange [0:*]\n";
    cmd += fmt::format("plot {} using 1:2:xtic(5) with boxes lc rgb '#1f77b4' title 'RMSE', '' using 1:3 with linespoints pt 7 lc rgb '#d62728' title 'max |error|', '' using 1:2:(sprintf('%.2f', $2)) with labels offset 0,1 notitle\n",
                       quote((dir / "ladder.tsv").string()));
    plots.emplace_back("ladder", cmd);
  }
  std::string script;
  for (const auto& [name, cmd] : plots) {
    for (const char* ext : {"png", "svg"}) {
      const fs::path out = dir / (name + "." + ext);
      script += "reset\n";
      script += std::string(ext) == "png" ? "set terminal pngcairo size 900,560 noenhanced\n"
                                          : "set terminal svg size 900,560 noenhanced\n";
      script += "set output " + quote(out.string()) + "\n" + cmd + "unset output\n";
      files.images.push_back(out.string());
    }
  }
  const fs::path gp = dir / "plots.gp";
  writeText(gp, script);
  const std::string run = "gnuplot " + quote(gp.string()) + " 2> " + quote((dir / "gnuplot.log").string());
  const int rc = std::system(run.c_str());
  if (rc != 0) {
    files.warnings.push_back(fmt::format("gnuplot failed (exit {}); see {} — the data and the script are in {}",
                                         rc, (dir / "gnuplot.log").string(), dir_name));
    files.images.clear();
  }

  // The page.
  std::string md = "# Model lab report\n\n";
  md += "Command: `" + command_line + "`\n\n";
  md += fmt::format("{} samples in {} run(s).\n\n", data.rows(), data.runs());
  md += "## The error ladder\n\n| step | model | k | RMSE (g) | max (g) | RMSE (% of max force) | BIC | dBIC | verdict |\n|---|---|---|---|---|---|---|---|---|\n";
  for (std::size_t k = 0; k < steps.size(); ++k) {
    const auto& s = steps[k];
    md += fmt::format("| {} | `{}` | {} | {:.3f} | {:.2f} | {:.2f} | {:.1f} | {} | {} |\n", k, stepName(s, k), s.fit.k,
                      s.fit.rmse_g, s.fit.max_g, s.fit.rmse_pct, s.fit.bic,
                      k ? fmt::format("{:.1f}", s.delta_bic) : "",
                      k ? (s.earns ? "earns its parameters" : "does not earn its parameters") : "start");
  }
  md += "\n![ladder](ladder.png)\n\n## Measured vs model\n\n![measured vs model](measured_vs_model.png)\n\n";
  md += "## Where the starting model fails\n\n";
  int shown = 0;
  for (const auto& s : steps.front().variables) {
    if (!s.significant) continue;
    md += fmt::format("{}. **{}** (score {:.3f}): {}\n", ++shown, s.variable, s.score, s.advice);
  }
  if (shown == 0) md += "No variable explains a significant part of the residual.\n";
  md += "\n";
  for (const auto& v : suspects)
    md += fmt::format("![residual vs {0}](residual_vs_{0}.png)\n\n", v);
  md += "## Fitted parameters of the last step\n\n| parameter | effect | value | uncertainty | unit |\n|---|---|---|---|---|\n";
  for (const auto& p : steps.back().fit.params)
    md += fmt::format("| {} | {} | {:.6g} | {:.2g} | {} |\n", p.name, p.effect, p.value, p.sigma, p.unit);
  md += "\nEach plot is also written as SVG next to the PNG; `data.tsv` holds every sample, prediction and residual.\n";
  files.page = (dir / "report.md").string();
  writeText(files.page, md);
  return files;
}

}  // namespace lab
