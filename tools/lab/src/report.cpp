// `--report DIR`: the plots (gnuplot script and data, PNG and SVG) and the page's content (the
// ladder, causes, noise floor, parameters); report_page.cpp renders the page.
#include "lab/report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include "report_page.hpp"

namespace lab {

namespace {

namespace fs = std::filesystem;
using report::Block;
using report::toHtml;
using report::toMarkdown;
using report::writeText;

// gnuplot strings in single quotes: the terminals run with `noenhanced`, so only quotes need care
std::string quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') out += "''"; else out += c;
  }
  return out + "'";
}

std::string stepName(const LadderStep& s, std::size_t i) { return i == 0 ? s.spec.text() : "+" + s.added; }

// The rows drawn: all of them, or every k-th (so each run and each part of a sweep keeps its
// share) plus each step's largest errors (so the outliers stay visible).
std::vector<std::size_t> plotRows(const Dataset& data, const std::vector<LadderStep>& steps) {
  const std::size_t n = data.rows();
  std::vector<std::size_t> rows;
  if (n <= kMaxPlotRows) {
    rows.resize(n);
    std::iota(rows.begin(), rows.end(), 0);
    return rows;
  }
  const std::size_t worst = 50;
  std::vector<bool> keep(n, false);
  const std::size_t stride = (n + kMaxPlotRows - worst * steps.size() - 1) / (kMaxPlotRows - worst * steps.size());
  for (std::size_t i = 0; i < n; i += stride) keep[i] = true;
  for (const auto& s : steps) {
    std::vector<std::size_t> idx(n);
    std::iota(idx.begin(), idx.end(), 0);
    const auto& r = s.fit.residual_g;
    std::partial_sort(idx.begin(), idx.begin() + static_cast<long>(worst), idx.end(),
                      [&](std::size_t a, std::size_t b) { return std::fabs(r[a]) > std::fabs(r[b]); });
    for (std::size_t k = 0; k < worst; ++k) keep[idx[k]] = true;
  }
  for (std::size_t i = 0; i < n; ++i)
    if (keep[i]) rows.push_back(i);
  return rows;
}

double quantile(std::vector<double> v, double q) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return 0;
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

struct VerdictStyle {
  int color;          // 0xRRGGBB
  const char* short_text;
};
VerdictStyle styleOf(const LadderStep& s, std::size_t i) {
  if (i == 0) return {0x1f77b4, "start"};
  if (s.earns) return {0x2ca02c, "earns"};
  if (!s.at_bound.empty()) return {0xff7f0e, "no credit (bound)"};
  return {0x999999, "does not earn"};
}

// The variables the residual plots show: the first step's significant causes (up to three),
// else the first two tested ones.
std::vector<std::string> plottedSuspects(const std::vector<LadderStep>& steps) {
  std::vector<std::string> suspects;
  for (const auto& s : steps.front().variables)
    if (s.significant && s.role == Role::kCause && suspects.size() < 3 && s.variable != "run")
      suspects.push_back(s.variable);
  if (suspects.empty())
    for (const auto& s : steps.front().variables)
      if (s.tested && s.role == Role::kCause && suspects.size() < 2 && s.variable != "run")
        suspects.push_back(s.variable);
  return suspects;
}

// Data of the plots: the rows drawn, prediction and residual of every step (data.tsv), and the
// ladder (ladder.tsv).
void writePlotData(const fs::path& dir, const Dataset& data, const std::vector<LadderStep>& steps,
                   const std::vector<std::size_t>& rows, const std::vector<std::string>& suspects) {
  const auto& pwm = data.col("pwm_us");
  const auto& force = data.col("force_g");
  std::string tsv = "# pwm_us force_g";
  for (std::size_t k = 0; k < steps.size(); ++k) tsv += fmt::format(" pred{} resid{}", k, k);
  for (const auto& v : suspects) tsv += " " + v;
  tsv += "\n";
  for (std::size_t i : rows) {
    tsv += fmt::format("{:.6g} {:.6g}", pwm[i], force[i]);
    for (const auto& s : steps) tsv += fmt::format(" {:.6g} {:.6g}", s.fit.predicted_g[i], s.fit.residual_g[i]);
    for (const auto& v : suspects) tsv += fmt::format(" {:.6g}", data.has(v) ? data.col(v)[i] : NAN);
    tsv += "\n";
  }
  writeText(dir / "data.tsv", tsv);
  std::string lad = "# step rmse_g max_g bic \"step: verdict\" color\n";
  for (std::size_t k = 0; k < steps.size(); ++k) {
    const VerdictStyle st = styleOf(steps[k], k);
    std::string name = stepName(steps[k], k) + ": " + st.short_text;
    std::replace(name.begin(), name.end(), '"', '\'');
    lad += fmt::format("{} {:.6g} {:.6g} {:.6g} \"{}\" {}\n", k, steps[k].fit.rmse_g, steps[k].fit.max_g,
                       steps[k].fit.bic, name, st.color);
  }
  writeText(dir / "ladder.tsv", lad);
}

using Plots = std::vector<std::pair<std::string, std::string>>;  // base name, plot commands

// Measured vs model: models first, the measurements last (open circles on top) so both stay
// visible. Points are translucent so their density shows.
void measuredVsModelPlot(Plots& plots, const Dataset& data, const std::vector<LadderStep>& steps,
                         const std::string& data_file, const std::string& sample_note) {
  std::string cmd = fmt::format("set xlabel {}\nset ylabel {}\nset key left top\n", quote(axisLabel(data, "pwm_us")),
                                quote(axisLabel(data, "force_g")));
  cmd += fmt::format("set title {}\n", quote("measured vs model" + sample_note));
  cmd += fmt::format("plot {} using 1:3 with points pt 7 ps 0.5 lc rgb '#60d62728' title {}", data_file,
                     quote("model: " + stepName(steps.front(), 0)));
  if (steps.size() > 1)
    cmd += fmt::format(", '' using 1:{} with points pt 7 ps 0.5 lc rgb '#601f77b4' title {}", 3 + 2 * (steps.size() - 1),
                       quote("model: " + steps.back().spec.text()));
  cmd += ", '' using 1:2 with points pt 6 ps 0.8 lc rgb '#80222222' title 'measured'";
  plots.emplace_back("measured_vs_model", cmd + "\n");
}

// The residual against each suspect, every step in its colour. Robust axis limits (the 0.5 %
// and 99.5 % quantiles of every step's residual, with room), so a few outliers do not squeeze
// the rest flat; what lies beyond is counted.
void residualPlots(Plots& plots, const Dataset& data, const std::vector<LadderStep>& steps,
                   const std::vector<std::size_t>& rows, const std::vector<std::string>& suspects,
                   const std::string& data_file, const std::string& sample_note) {
  std::vector<double> all_res;
  for (const auto& s : steps)
    for (std::size_t i : rows) all_res.push_back(s.fit.residual_g[i]);
  double lo = quantile(all_res, 0.005), hi = quantile(all_res, 0.995);
  const double pad = 0.15 * std::max(hi - lo, 1e-6);
  lo -= pad, hi += pad;
  std::size_t beyond = 0;
  for (double r : all_res) beyond += (r < lo || r > hi) ? 1 : 0;
  const char* colors[] = {"#d62728", "#ff7f0e", "#2ca02c", "#1f77b4", "#9467bd", "#8c564b", "#e377c2"};
  for (std::size_t v = 0; v < suspects.size(); ++v) {
    std::string cmd = fmt::format("set xlabel {}\nset ylabel 'residual: measured - model (g)'\nset key outside right\n",
                                  quote(axisLabel(data, suspects[v])));
    cmd += fmt::format("set yrange [{:.6g}:{:.6g}]\n", lo, hi);
    cmd += fmt::format("set title {}\n",
                       quote("residual vs " + suspects[v] + " as effects are added" + sample_note +
                             (beyond ? fmt::format(", {} beyond the axis", beyond) : std::string())));
    cmd += "plot ";
    const int col = 3 + 2 * static_cast<int>(steps.size()) + static_cast<int>(v);
    for (std::size_t k = 0; k < steps.size(); ++k) {
      std::string color = colors[k % 7];
      color.insert(1, "70");  // translucent
      cmd += fmt::format("{}{} using {}:{} with points pt 7 ps 0.35 lc rgb '{}' title {}", k ? ", " : "",
                         k ? "''" : data_file, col, 4 + 2 * k, color,
                         quote(fmt::format("{} (RMSE {:.3g} g)", stepName(steps[k], k), steps[k].fit.rmse_g)));
    }
    plots.emplace_back("residual_vs_" + suspects[v], cmd + "\n");
  }
}

// The residual of the last step along the drive (the one the verdict judges): the noise floor as
// a band of two standard deviations, the regions where the residual above it concentrates shaded.
void residualAlongDrivePlot(Plots& plots, const Dataset& data, const std::vector<LadderStep>& steps,
                            const std::string& data_file, const std::string& sample_note) {
  const Assessment& a = steps.back().assessment;
  std::string cmd = fmt::format("set xlabel {}\nset ylabel 'residual: measured - model (g)'\nset key below\n",
                                quote(axisLabel(data, "pwm_us")));
  cmd += fmt::format("set title {}\n", quote(fmt::format("residual of {} along the drive (RMSE {:.3g} g){}",
                                                         steps.back().spec.text(), steps.back().fit.rmse_g,
                                                         sample_note)));
  for (std::size_t k = 0; k < a.regions.size(); ++k)
    cmd += fmt::format("set object {} rect from {:.6g}, graph 0 to {:.6g}, graph 1 fc rgb '#fde0c5' fs solid 0.5 "
                       "noborder behind\n",
                       k + 1, a.regions[k].pwm_lo_us, a.regions[k].pwm_hi_us);
  cmd += fmt::format("plot {} using 1:{} with points pt 7 ps 0.4 lc rgb '#801f77b4' title 'residual{}'", data_file,
                     4 + 2 * (steps.size() - 1), a.regions.empty() ? "" : " (shaded: where most of it is)");
  if (a.noise.known())
    cmd += fmt::format(", {:.6g} with lines dt 2 lc rgb '#444444' title {}, {:.6g} with lines dt 2 lc rgb '#444444' "
                       "notitle",
                       2 * a.noise.sigma_g,
                       quote(fmt::format("noise floor {:.3g} g: +-2 SD", a.noise.sigma_g)), -2 * a.noise.sigma_g);
  plots.emplace_back("residual_along_drive", cmd + "\n");
}

void ladderPlot(Plots& plots, const fs::path& dir, std::size_t steps) {
  std::string cmd = "set style fill solid 0.7\nset boxwidth 0.6\nset ylabel 'error (g)'\nset xtics rotate by -20\n";
  cmd += "set key left top\nset title 'the error ladder: green earns its parameters, grey does not, orange gets no "
         "credit (a parameter at a bound)'\nset yrange [0:*]\nset xrange [-0.6:" +
         fmt::format("{}", static_cast<double>(steps) - 0.4) + "]\n";
  cmd += fmt::format("plot {} using 1:2:6:xtic(5) with boxes lc rgb variable title 'RMSE', '' using 1:3 with "
                     "linespoints pt 7 lc rgb '#d62728' title 'max |error|', '' using 1:2:(sprintf('%.3g', $2)) with "
                     "labels offset 0,1 notitle\n",
                     quote((dir / "ladder.tsv").string()));
  plots.emplace_back("ladder", cmd);
}

// Every plot in PNG and SVG through one gnuplot script; false (with a warning, no images)
// when gnuplot failed.
bool drawPlots(const fs::path& dir, const std::string& dir_name, const Plots& plots, ReportFiles& files) {
  std::string script;
  for (const auto& [name, cmd] : plots) {
    for (const char* ext : {"png", "svg"}) {
      const fs::path out = dir / (name + "." + ext);
      script += "reset\n";
      script += std::string(ext) == "png" ? "set terminal pngcairo size 960,600 noenhanced\n"
                                          : "set terminal svg size 960,600 noenhanced\n";
      script += "set output " + quote(out.string()) + "\n" + cmd + "unset output\n";
      files.images.push_back(out.string());
    }
  }
  const fs::path gp = dir / "plots.gp";
  writeText(gp, script);
  const std::string run = "gnuplot " + quote(gp.string()) + " 2> " + quote((dir / "gnuplot.log").string());
  const int rc = std::system(run.c_str());
  if (rc == 0) return true;
  files.warnings.push_back(fmt::format("gnuplot failed (exit {}); see {} — the data and the script are in {}",
                                       rc, (dir / "gnuplot.log").string(), dir_name));
  files.images.clear();
  return false;
}

Block ladderTable(const std::vector<LadderStep>& steps) {
  Block table{Block::Kind::kTable, "", {}, {}, ""};
  table.rows.push_back({"step", "model", "k", "RMSE (g)", "RMSE / noise", "max (g)", "RMSE (% of max force)", "BIC",
                        "dBIC", "verdict"});
  for (std::size_t k = 0; k < steps.size(); ++k) {
    const auto& s = steps[k];
    const NoiseEstimate& n = s.assessment.noise;
    table.rows.push_back({std::to_string(k), "`" + stepName(s, k) + "`", std::to_string(s.fit.k),
                          fmt::format("{:.3f}", s.fit.rmse_g),
                          n.known() ? fmt::format("{:.2f}{}", s.fit.rmse_g / n.sigma_g, s.at_noise_floor ? " (floor)" : "")
                                    : std::string("-"),
                          fmt::format("{:.2f}", s.fit.max_g),
                          fmt::format("{:.2f}", s.fit.rmse_pct), fmt::format("{:.1f}", s.fit.bic),
                          k ? fmt::format("{:.1f}", s.delta_bic) : "", s.verdict});
  }
  return table;
}

// Where the starting model fails: its significant causes, the responses, the residual plots.
void causesSection(std::vector<Block>& page, const std::vector<LadderStep>& steps,
                   const std::vector<std::string>& suspects) {
  page.push_back({Block::Kind::kH2, "Where the starting model fails", {}, {}, ""});
  Block causes{Block::Kind::kList, "", {}, {}, ""};
  std::vector<std::string> responses;
  for (const auto& s : steps.front().variables) {
    if (s.role == Role::kResponse) responses.push_back(s.variable);
    if (!s.significant || s.role != Role::kCause) continue;
    causes.items.push_back(fmt::format("**{}** (score {:.3f}): {}", s.variable, s.score, s.advice));
  }
  if (causes.items.empty())
    page.push_back({Block::Kind::kPara, "No logged cause explains a significant part of the residual.", {}, {}, ""});
  else
    page.push_back(causes);
  if (!responses.empty())
    page.push_back({Block::Kind::kPara,
                    fmt::format("Responses of the motor (they follow the drive; not suspects): {}.",
                                fmt::join(responses, ", ")),
                    {}, {}, ""});
  for (const auto& v : suspects)
    page.push_back({Block::Kind::kImage, "residual vs " + v, {}, {}, "residual_vs_" + v + ".png"});
}

// The last step against the noise floor: the verdict, where the residual is, the findings in
// the responses.
void noiseSection(std::vector<Block>& page, const LadderStep& last) {
  const Assessment& a = last.assessment;
  page.push_back({Block::Kind::kH2, "Against the noise floor", {}, {}, ""});
  page.push_back({Block::Kind::kPara,
                  fmt::format("Noise floor (the measurement noise, estimated from {}): {}. Verdict for `{}`: {}.",
                              a.noise.method == "pure_error" ? "the scatter within repeated set points"
                                                             : "neighbouring rows",
                              describe(a.noise), last.spec.text(),
                              a.verdict_text.empty() ? std::string("not judged") : a.verdict_text),
                  {}, {}, ""});
  if (!a.noise.assumption.empty())
    page.push_back({Block::Kind::kPara, "What the floor assumes: " + a.noise.assumption + ".", {}, {}, ""});
  if (a.lack_of_fit.tested)
    page.push_back({Block::Kind::kPara, "Lack of fit: " + a.lack_of_fit.text + ".", {}, {}, ""});
  Block dynamics{Block::Kind::kList, "", {}, {}, ""};
  for (const auto& d : a.dynamics) dynamics.items.push_back(d.text);
  if (!dynamics.items.empty()) {
    page.push_back({Block::Kind::kPara, "Dynamics (the fitted `lag`):", {}, {}, ""});
    page.push_back(dynamics);
  }
  Block where{Block::Kind::kList, "", {}, {}, ""};
  for (const auto& r : a.regions) where.items.push_back(r.text);
  if (!where.items.empty()) page.push_back(where);
  page.push_back({Block::Kind::kImage, "residual along the drive", {}, {}, "residual_along_drive.png"});
  if (a.evidence.empty()) return;
  Block ev{Block::Kind::kList, "", {}, {}, ""};
  for (const auto& e : a.evidence)
    ev.items.push_back(e.text + (e.effects.empty() ? std::string()
                                                   : fmt::format(" -> `{}` (score {:.3f})", e.effects.front(), e.score)));
  page.push_back({Block::Kind::kPara, "Evidence from the responses (they name causes; they are not suspects):", {}, {}, ""});
  page.push_back(ev);
}

Block paramsTable(const LadderStep& last) {
  Block params{Block::Kind::kTable, "", {}, {}, ""};
  params.rows.push_back({"parameter", "effect", "value", "uncertainty", "unit", ""});
  for (const auto& p : last.fit.params)
    params.rows.push_back({p.name, p.effect, fmt::format("{:.6g}", p.value),
                           std::isfinite(p.sigma) ? fmt::format("{:.2g}", p.sigma) : "", p.unit,
                           p.at_bound ? fmt::format("at its bound {:.4g}", p.bound) : ""});
  return params;
}

// The page, once, for both renderings.
std::vector<Block> reportPage(const Dataset& data, const std::vector<LadderStep>& steps,
                              const std::string& command_line, const std::vector<std::string>& notes,
                              const std::vector<std::size_t>& rows, const std::vector<std::string>& suspects) {
  const bool thinned = rows.size() < data.rows();
  std::vector<Block> page;
  page.push_back({Block::Kind::kH1, "Model lab report", {}, {}, ""});
  page.push_back({Block::Kind::kPara, "Command: `" + command_line + "`", {}, {}, ""});
  page.push_back({Block::Kind::kPara,
                  fmt::format("{} samples in {} run(s){}.", data.rows(), data.runs(),
                              thinned ? fmt::format("; the plots show {} of them (every {}th, and each step's 50 "
                                                    "largest errors)",
                                                    rows.size(), (data.rows() + rows.size() - 1) / rows.size())
                                      : std::string()),
                  {}, {}, ""});
  if (!notes.empty()) page.push_back({Block::Kind::kList, "", notes, {}, ""});
  page.push_back({Block::Kind::kH2, "The error ladder", {}, {}, ""});
  page.push_back(ladderTable(steps));
  page.push_back({Block::Kind::kImage, "ladder", {}, {}, "ladder.png"});
  page.push_back({Block::Kind::kH2, "Measured vs model", {}, {}, ""});
  page.push_back({Block::Kind::kImage, "measured vs model", {}, {}, "measured_vs_model.png"});
  causesSection(page, steps, suspects);
  noiseSection(page, steps.back());
  page.push_back({Block::Kind::kH2, "Fitted parameters of the last step", {}, {}, ""});
  page.push_back(paramsTable(steps.back()));
  page.push_back({Block::Kind::kPara,
                  "Each plot is also written as SVG next to the PNG; `data.tsv` holds the plotted samples with every "
                  "step's prediction and residual; `plots.gp` redraws them (`gnuplot plots.gp`). `report.html` is this "
                  "page with the plots inside, for a browser.",
                  {}, {}, ""});
  return page;
}

}  // namespace

ReportFiles writeReport(const std::string& dir_name, const Dataset& data, const std::vector<LadderStep>& steps,
                        const std::string& command_line, const std::vector<std::string>& notes) {
  ReportFiles files;
  const fs::path dir(dir_name);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw std::runtime_error("cannot create report directory " + dir_name + ": " + ec.message());
  if (steps.empty()) throw std::invalid_argument("nothing to report");

  const std::vector<std::string> suspects = plottedSuspects(steps);
  const std::vector<std::size_t> rows = plotRows(data, steps);
  files.plotted_rows = rows.size();
  const bool thinned = rows.size() < data.rows();
  writePlotData(dir, data, steps, rows, suspects);

  Plots plots;
  const std::string data_file = quote((dir / "data.tsv").string());
  const std::string sample_note =
      thinned ? fmt::format(" ({} of {} samples shown)", rows.size(), data.rows()) : std::string();
  measuredVsModelPlot(plots, data, steps, data_file, sample_note);
  residualPlots(plots, data, steps, rows, suspects, data_file, sample_note);
  residualAlongDrivePlot(plots, data, steps, data_file, sample_note);
  ladderPlot(plots, dir, steps.size());
  const bool drawn = drawPlots(dir, dir_name, plots, files);

  const std::vector<Block> page = reportPage(data, steps, command_line, notes, rows, suspects);
  files.page = (dir / "report.md").string();
  writeText(files.page, toMarkdown(page));
  files.html = (dir / "report.html").string();
  writeText(files.html, toHtml(page, dir, drawn));

  for (const char* f : {"data.tsv", "ladder.tsv", "plots.gp", "report.md", "report.html", "gnuplot.log"})
    if (fs::exists(dir / f)) files.bytes += fs::file_size(dir / f);
  for (const auto& i : files.images)
    if (fs::exists(i)) files.bytes += fs::file_size(i);
  if (files.bytes > 20u * 1000u * 1000u)
    files.warnings.push_back(fmt::format("the report takes {:.1f} MB", files.bytes / 1e6));
  return files;
}

}  // namespace lab
