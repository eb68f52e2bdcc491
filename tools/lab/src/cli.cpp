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

namespace lab {

namespace {

using nlohmann::json;

struct Common {
  std::vector<std::string> files;
  std::vector<std::string> maps;
  std::string model;
  bool json_out = false;
  std::string report_dir;
  std::string holdout = "none";
  bool no_motor_split = false;
  std::string where;
};

void addCommon(CLI::App* cmd, Common& c) {
  cmd->add_option("DATA", c.files,
                  "measurement CSV files (project CSV, a captured gather_store log, RCbenchmark/Tyto "
                  "export, or any CSV with --map); one or more runs per file")
      ->required();
  cmd->add_option("--model,-m", c.model,
                  "model SPEC: effects joined with '+', e.g. curve+deadband+voltage, or thesis; "
                  "user effects as 'mul: EXPR' / 'add: EXPR' (see `thrustcal lab effects`)")
      ->required();
  cmd->add_option("--map", c.maps,
                  "column mapping TARGET=[-]SOURCE[*K|/K|+K|-K...], repeatable, e.g. "
                  "--map force_g=weight[g]/4 --map pwm_us=pwm --map 'force_g=-Thrust (N)*101.97'");
  cmd->add_option("--where", c.where,
                  "keep only the rows where EXPR holds, e.g. 'pwm_us < 1840 and dir > 0' (muParser over the "
                  "column names and `run`); the counts kept and dropped are printed");
  cmd->add_option("--holdout", c.holdout,
                  "validation: none, runs (fit without each run, predict it) or voltage (without "
                  "each voltage level)")
      ->capture_default_str();
  cmd->add_option("--report", c.report_dir, "write plots (PNG+SVG) and report.md into this directory");
  cmd->add_flag("--json", c.json_out, "print JSON instead of text");
  cmd->add_flag("--no-motor-split", c.no_motor_split, "one run per file even with a motor column");
}

// Rows selected with --where (the count kept and dropped goes to the notes) and warnings about
// data a fit should not be asked to explain (force falling as the drive rises; `diagnose` reports
// it as evidence instead).
void selectAndCheck(Dataset& d, const std::string& where, std::vector<std::string>& warnings,
                    bool collapse_warnings = true) {
  if (!where.empty()) {
    const std::size_t before = d.rows();
    const RowSelection sel = selectRows(d, where);
    d.notes.push_back(fmt::format("--where '{}': kept {} of {} rows, dropped {}{}", where, sel.kept, before,
                                  sel.dropped,
                                  sel.undefined ? fmt::format(" ({} where it could not be evaluated)", sel.undefined)
                                                : std::string()));
  }
  if (collapse_warnings)
    for (const auto& c : findForceCollapse(d)) warnings.push_back(describe(c));
}

Dataset load(const Common& c, std::vector<std::string>& warnings, bool collapse_warnings = true) {
  ReadOptions ro;
  for (const auto& m : c.maps) ro.maps.push_back(parseColumnMap(m));
  ro.split_by_motor = !c.no_motor_split;
  Dataset d = readFiles(c.files, ro);
  selectAndCheck(d, c.where, warnings, collapse_warnings);
  addDerivedColumns(d);
  return d;
}

json num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json paramsJson(const FitResult& f) {
  json a = json::array();
  for (const auto& p : f.params)
    a.push_back({{"name", p.name}, {"unit", p.unit}, {"effect", p.effect}, {"value", num(p.value)},
                 {"sigma", num(p.sigma)}});
  return a;
}

json suspectsJson(const std::vector<Suspect>& vars, bool significant) {
  json a = json::array();
  for (const auto& s : vars) {
    if (s.role != Role::kCause || !s.tested || s.significant != significant) continue;
    a.push_back({{"variable", s.variable}, {"score", num(s.score)}, {"effects", s.effects},
                 {"p_value", num(s.p_value)}, {"advice", s.advice}});
  }
  return a;
}

// The variables that were not refitted, by reason: responses of the motor, copies of the drive,
// causes that could not be tested here (time in a ramp).
void addUntestedJson(json& j, const std::vector<Suspect>& vars) {
  json responses = json::array(), copies = json::array(), untested = json::array();
  for (const auto& s : vars) {
    if (s.role == Role::kResponse) responses.push_back(s.variable);
    else if (s.role == Role::kDriveCopy) copies.push_back(s.variable);
    else if (!s.tested && s.variable != "pwm_us") untested.push_back({{"variable", s.variable}, {"advice", s.advice}});
  }
  j["responses"] = responses;
  j["drive_copies"] = copies;
  j["not_tested"] = untested;
}

void printUntested(const std::vector<Suspect>& vars) {
  std::string responses, copies;
  for (const auto& s : vars) {
    if (s.role == Role::kResponse) responses += (responses.empty() ? "" : ", ") + s.variable;
    else if (s.role == Role::kDriveCopy) copies += (copies.empty() ? "" : ", ") + s.variable;
    else if (!s.tested && s.variable != "pwm_us") std::printf("not tested: %s\n", s.advice.c_str());
  }
  if (!responses.empty())
    std::printf("responses of the motor (they follow the drive; not suspects): %s\n", responses.c_str());
  if (!copies.empty()) std::printf("copies of the drive (not suspects): %s\n", copies.c_str());
}

void printNotesAndWarnings(const Dataset& d, const std::vector<std::string>& warnings) {
  for (const auto& n : d.notes) std::fprintf(stderr, "note: %s\n", n.c_str());
  for (const auto& w : warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
}

std::string fmtSigma(const Param& p) {
  if (!std::isfinite(p.sigma)) return fmt::format("{:.5g} {}", p.value, p.unit);
  return fmt::format("{:.5g} ± {:.2g} {}", p.value, p.sigma, p.unit);
}

void printFit(const FitResult& f, const NoiseEstimate* noise = nullptr) {
  std::printf("fit: RMSE %.3f g (%.2f %% of the largest force), max %.2f g (%.2f %%), %d parameters, BIC %.1f, AIC %.1f\n",
              f.rmse_g, f.rmse_pct, f.max_g, f.max_pct, f.k, f.bic, f.aic);
  if (noise)
    std::printf("noise floor: %s, from the data (%zu contrasts of neighbouring rows%s)\n", describe(*noise).c_str(),
                noise->contrasts, noise->features ? fmt::format(", {} kinks left out", noise->features).c_str() : "");
  std::printf("parameters:\n");
  int curve = 0;
  for (const auto& p : f.params) {
    if (p.effect == "curve" && p.name != "offset_g") {
      ++curve;
      continue;
    }
    std::printf("  %-20s %-28s (%s)\n", p.name.c_str(), fmtSigma(p).c_str(), p.effect.c_str());
  }
  if (curve) std::printf("  + %d curve coefficients c1..c%d [g] (in --json)\n", curve, curve);
  for (const auto& w : f.warnings) std::printf("  note: %s\n", w.c_str());
}

std::vector<std::string> reportNotes(const Dataset& d, const std::vector<std::string>& warnings) {
  std::vector<std::string> n = d.notes;
  for (const auto& w : warnings) n.push_back("warning: " + w);
  return n;
}

void printReport(const ReportFiles& rep) {
  std::printf("report: %s and %s (%.1f MB in all%s)\n", rep.page.c_str(), rep.html.c_str(), rep.bytes / 1e6,
              rep.images.empty() ? ", no plots" : "");
  if (!rep.images.empty())
    std::printf("  plots: %s ... (%zu files, PNG and SVG)\n", rep.images.front().c_str(), rep.images.size());
}

std::string commandLine(const std::string& sub, const Common& c, const std::vector<std::string>& adds) {
  std::string s = "thrustcal lab " + sub;
  for (const auto& f : c.files) s += " " + f;
  for (const auto& m : c.maps) s += " --map '" + m + "'";
  s += " --model '" + c.model + "'";
  if (!c.where.empty()) s += " --where '" + c.where + "'";
  for (const auto& a : adds) s += " --add '" + a + "'";
  return s;
}

json noiseJson(const NoiseEstimate& n) {
  return {{"method", "neighbouring rows: contrasts of four neighbours orthogonal to a quadratic in the PWM, the "
                     "logged conditions regressed out (docs/lab.md)"},
          {"contrasts", n.contrasts}, {"features_left_out", n.features}, {"dof", num(n.dof)},
          {"conditions", n.conditions}, {"note", n.note}, {"why_not", n.why_not}};
}

json regionsJson(const std::vector<Region>& regions) {
  json a = json::array();
  for (const auto& r : regions)
    a.push_back({{"pwm_lo_us", r.pwm_lo_us}, {"pwm_hi_us", r.pwm_hi_us}, {"vbat_v", num(r.vbat_v)},
                 {"share", num(r.share)}, {"rows_share", num(r.rows_share)}, {"rmse_g", num(r.rmse_g)},
                 {"text", r.text}});
  return a;
}

json evidenceJson(const std::vector<Evidence>& evidence) {
  json a = json::array();
  for (const auto& e : evidence)
    a.push_back({{"kind", e.kind}, {"column", e.column}, {"level", num(e.level)}, {"from_pwm_us", num(e.from_pwm_us)},
                 {"runs", e.runs}, {"cause", e.cause}, {"text", e.text},
                 {"where", e.where.empty() ? json(nullptr) : json(e.where)}, {"effects", e.effects},
                 {"score", num(e.score)}, {"p_value", num(e.p_value)}, {"significant", e.significant},
                 {"advice", e.advice}});
  return a;
}

// The diagnosis's fields beyond the fit: the noise floor, the verdict, where the residual is,
// the evidence and the advice to follow.
void addVerdictJson(json& j, const Assessment& d) {
  const bool known = d.noise.known();
  j["noise_g"] = num(d.noise.sigma_g);
  j["noise_g_ci"] = known ? json::array({d.noise.lo_g, d.noise.hi_g}) : json(nullptr);
  j["noise"] = noiseJson(d.noise);
  j["verdict"] = verdictName(d.verdict);
  j["verdict_text"] = d.verdict_text;
  j["unexplained_g"] = num(d.unexplained_g);
  j["regions"] = regionsJson(d.regions);
  j["evidence"] = evidenceJson(d.evidence);
  j["next"] = {{"where", d.next.where.empty() ? json(nullptr) : json(d.next.where)},
               {"add", d.next.add.empty() ? json(nullptr) : json(d.next.add)},
               {"why", d.next.why}};
}

json diagnosisJson(const Diagnosis& d, const Dataset& data, const Common& c, const std::vector<std::string>& warnings,
                   const ReportFiles& rep) {
  json j = {{"model", d.fit.model}, {"rmse_g", num(d.fit.rmse_g)}, {"n", d.fit.n},
            {"max_g", num(d.fit.max_g)}, {"rmse_pct", num(d.fit.rmse_pct)}, {"max_pct", num(d.fit.max_pct)},
            {"k", d.fit.k}, {"aic", num(d.fit.aic)}, {"bic", num(d.fit.bic)}, {"runs", data.runs()},
            {"params", paramsJson(d.fit)}, {"suspects", suspectsJson(d.variables, true)},
            {"not_significant", suspectsJson(d.variables, false)}, {"notes", data.notes}};
  std::vector<std::string> all_warnings = warnings;
  all_warnings.insert(all_warnings.end(), d.fit.warnings.begin(), d.fit.warnings.end());
  j["warnings"] = all_warnings;
  addUntestedJson(j, d.variables);
  addVerdictJson(j, d);
  if (c.holdout != "none")
    j["holdout"] = {{"kind", c.holdout}, {"groups", d.holdout_groups}, {"rmse_g", num(d.holdout_rmse_g)}};
  if (!rep.page.empty()) j["report"] = {{"page", rep.page}, {"html", rep.html}, {"images", rep.images}, {"bytes", rep.bytes}};
  return j;
}

void printCauses(const Diagnosis& d) {
  std::printf("where it fails (causes ranked by how much of the residual they explain):\n");
  int k = 0;
  for (const auto& s : d.variables) {
    if (!s.significant || s.role != Role::kCause) continue;
    std::printf("  %d. %-16s score %.3f (p %.1e)%s\n     %s\n", ++k, s.variable.c_str(), s.score, s.p_value,
                s.effects.empty() ? "" : fmt::format(" -> {}", fmt::join(s.effects, ", ")).c_str(), s.advice.c_str());
  }
  if (k == 0) std::printf("  no logged variable explains a significant part of the residual\n");
  std::string quiet;
  for (const auto& s : d.variables)
    if (!s.significant && s.tested && s.role == Role::kCause) quiet += (quiet.empty() ? "" : ", ") + s.variable;
  if (!quiet.empty()) std::printf("not significant: %s\n", quiet.c_str());
}

void printEvidence(const Diagnosis& d) {
  if (d.evidence.empty()) return;
  std::printf("evidence from the responses (they name causes; they are not suspects):\n");
  for (const auto& e : d.evidence) {
    std::printf("  - %s\n", e.text.c_str());
    if (!e.effects.empty())
      std::printf("    -> %s (score %.3f, %s): %s\n", fmt::format("{}", fmt::join(e.effects, ", ")).c_str(), e.score,
                  e.significant ? "significant" : "not significant", e.advice.c_str());
    else if (!e.advice.empty())
      std::printf("    %s\n", e.advice.c_str());
  }
}

// The command that follows the advice.
void printNext(const Diagnosis& d, const Common& c) {
  if (d.next.where.empty() && d.next.add.empty()) return;
  std::string files, maps;
  for (const auto& f : c.files) files += f + " ";
  for (const auto& m : c.maps) maps += " --map '" + m + "'";
  if (!d.next.where.empty()) {
    const std::string where = c.where.empty() ? d.next.where : "(" + c.where + ") and " + d.next.where;
    std::printf("next: thrustcal lab diagnose %s--model '%s'%s --where '%s'\n", files.c_str(), c.model.c_str(),
                maps.c_str(), where.c_str());
    return;
  }
  if (!c.where.empty()) maps += " --where '" + c.where + "'";
  std::printf("next: thrustcal lab ladder %s--model '%s'%s --add '%s'\n", files.c_str(), c.model.c_str(), maps.c_str(),
              d.next.add.c_str());
}

void printDiagnosis(const Diagnosis& d, const Dataset& data, const Common& c) {
  std::printf("model %s on %zu samples in %zu run(s)\n", d.fit.model.c_str(), d.fit.n, data.runs());
  printFit(d.fit, &d.noise);
  if (!d.noise.note.empty()) std::printf("  note: noise floor: %s\n", d.noise.note.c_str());
  if (c.holdout != "none")
    std::printf("hold-out (%s, %d groups): RMSE %.3f g on data the fit did not see\n", c.holdout.c_str(),
                d.holdout_groups, d.holdout_rmse_g);
  printCauses(d);
  printUntested(d.variables);
  printEvidence(d);
  if (!d.regions.empty()) std::printf("where the residual is:\n");
  for (const auto& r : d.regions) std::printf("  - %s\n", r.text.c_str());
  std::printf("verdict: %s\n", d.verdict_text.c_str());
  printNext(d, c);
}

int runDiagnose(const Common& c) {
  std::vector<std::string> warnings;
  const Dataset data = load(c, warnings, /*collapse_warnings=*/false);
  const ModelSpec spec = parseSpec(c.model);
  const Diagnosis d = diagnose(data, spec, parseHoldout(c.holdout));
  ReportFiles rep;
  if (!c.report_dir.empty()) {
    LadderStep step;
    step.spec = spec;
    step.fit = d.fit;
    step.variables = d.variables;
    step.holdout_rmse_g = d.holdout_rmse_g;
    step.verdict = "start";
    step.assessment = d;
    step.at_noise_floor = d.verdict == Verdict::kAtNoiseFloor;
    rep = writeReport(c.report_dir, data, {step}, commandLine("diagnose", c, {}), reportNotes(data, warnings));
  }
  if (c.json_out) {
    std::cout << diagnosisJson(d, data, c, warnings, rep).dump(2) << "\n";
    return 0;
  }
  printNotesAndWarnings(data, warnings);
  printDiagnosis(d, data, c);
  if (!rep.page.empty()) printReport(rep);
  for (const auto& w : rep.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  return 0;
}

json ladderJson(const std::vector<LadderStep>& steps, const Dataset& data, const Common& c,
                const std::vector<std::string>& warnings, const ReportFiles& rep) {
  json s = json::array();
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const auto& st = steps[i];
    json j = {{"model", st.spec.text()}, {"added", st.added}, {"rmse_g", num(st.fit.rmse_g)},
              {"max_g", num(st.fit.max_g)}, {"rmse_pct", num(st.fit.rmse_pct)}, {"n", st.fit.n},
              {"k", st.fit.k}, {"aic", num(st.fit.aic)}, {"bic", num(st.fit.bic)},
              {"delta_bic", i ? num(st.delta_bic) : json(nullptr)}, {"delta_aic", i ? num(st.delta_aic) : json(nullptr)},
              {"earns", i ? json(st.earns) : json(nullptr)}, {"verdict", st.verdict},
              {"at_noise_floor", st.at_noise_floor}, {"at_bound", st.at_bound}, {"params", paramsJson(st.fit)},
              {"suspects", suspectsJson(st.variables, true)}, {"warnings", st.fit.warnings}};
    if (c.holdout != "none") j["holdout_rmse_g"] = num(st.holdout_rmse_g);
    s.push_back(j);
  }
  json out = {{"steps", s}, {"notes", data.notes}, {"warnings", warnings}};
  addUntestedJson(out, steps.back().variables);
  addVerdictJson(out, steps.back().assessment);  // noise_g, and the last step's verdict
  if (!rep.page.empty()) out["report"] = {{"page", rep.page}, {"html", rep.html}, {"images", rep.images}, {"bytes", rep.bytes}};
  return out;
}

void printLadder(const std::vector<LadderStep>& steps, const Dataset& data, const Common& c) {
  const NoiseEstimate& noise = steps.back().assessment.noise;
  std::printf("error ladder on %zu samples in %zu run(s); BIC = n ln(RSS/n) + k ln n, an effect earns its\n"
              "parameters when BIC falls by more than 2; noise floor %s\n\n",
              data.rows(), data.runs(), describe(noise).c_str());
  std::printf("%-4s %-34s %4s %10s %7s %9s %8s %11s %9s  %s\n", "step", "model", "k", "RMSE g", "/noise", "max g",
              "RMSE %", "BIC", "dBIC", "verdict");
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const auto& st = steps[i];
    const std::string name = i == 0 ? st.spec.text() : "+" + st.added;
    std::printf("%-4zu %-34s %4d %10.3f %7s %9.2f %8.2f %11.1f %9s  %s%s\n", i, name.c_str(), st.fit.k, st.fit.rmse_g,
                noise.known() ? fmt::format("{:.2f}", st.fit.rmse_g / noise.sigma_g).c_str() : "-", st.fit.max_g,
                st.fit.rmse_pct, st.fit.bic, i ? fmt::format("{:.1f}", st.delta_bic).c_str() : "", st.verdict.c_str(),
                st.at_noise_floor ? " (at the noise floor)" : "");
    if (c.holdout != "none") std::printf("     hold-out (%s) RMSE %.3f g\n", c.holdout.c_str(), st.holdout_rmse_g);
  }
  const auto& last = steps.back();
  std::printf("\nlast step, %s:\n", last.spec.text().c_str());
  printFit(last.fit, &noise);
  int k = 0;
  for (const auto& s : last.variables) {
    if (!s.significant || s.role != Role::kCause || k >= 3) continue;
    if (k++ == 0) std::printf("still in the residual:\n");
    std::printf("  %-16s score %.3f -> %s\n", s.variable.c_str(), s.score, s.advice.c_str());
  }
  printUntested(last.variables);
  for (const auto& r : last.assessment.regions) std::printf("where the residual is: %s\n", r.text.c_str());
  std::printf("verdict: %s\n", last.assessment.verdict_text.c_str());
}

int runLadder(const Common& c, const std::vector<std::string>& adds) {
  std::vector<std::string> warnings;
  const Dataset data = load(c, warnings);
  const ModelSpec spec = parseSpec(c.model);
  for (const auto& a : adds) parseSpec(a);  // fail early on a typo
  const auto steps = ladder(data, spec, adds, parseHoldout(c.holdout));
  ReportFiles rep;
  if (!c.report_dir.empty())
    rep = writeReport(c.report_dir, data, steps, commandLine("ladder", c, adds), reportNotes(data, warnings));
  if (c.json_out) {
    std::cout << ladderJson(steps, data, c, warnings, rep).dump(2) << "\n";
    return 0;
  }
  printNotesAndWarnings(data, warnings);
  printLadder(steps, data, c);
  if (!rep.page.empty()) printReport(rep);
  for (const auto& w : rep.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  return 0;
}

json walkJson(const Walk& w, const Common& c, const std::vector<std::string>& warnings, const ReportFiles& rep) {
  json steps = json::array();
  for (const auto& s : w.steps)
    steps.push_back({{"model", s.model}, {"rows", s.rows}, {"rmse_g", num(s.rmse_g)}, {"noise_g", num(s.noise.sigma_g)},
                     {"verdict", verdictName(s.verdict)}, {"verdict_text", s.verdict_text},
                     {"advice", {{"where", s.advice.where.empty() ? json(nullptr) : json(s.advice.where)},
                                 {"add", s.advice.add.empty() ? json(nullptr) : json(s.advice.add)},
                                 {"why", s.advice.why}}},
                     {"outcome", s.outcome}});
  json out = {{"walk", steps}, {"where", w.where.empty() ? json(nullptr) : json(w.where)}, {"adds", w.adds},
              {"stop", w.stop}, {"ladder", ladderJson(w.ladder, w.data, c, warnings, rep)}};
  out["noise_g"] = out["ladder"]["noise_g"];
  out["verdict"] = out["ladder"]["verdict"];
  return out;
}

void printWalk(const Walk& w, const Common& c) {
  std::printf("following the diagnosis from %s: diagnose, do what it advises (drop rows that do not measure the\n"
              "force, or add the effect that explains most), again, until the fit is at the noise floor or the\n"
              "advice does not earn its parameters\n\n",
              c.model.c_str());
  std::printf("%-4s %-40s %6s %9s %7s  %-15s %s\n", "step", "model", "rows", "RMSE g", "/noise", "verdict", "advice -> outcome");
  for (std::size_t i = 0; i < w.steps.size(); ++i) {
    const auto& s = w.steps[i];
    std::printf("%-4zu %-40s %6zu %9.3f %7s  %-15s %s\n", i + 1, s.model.c_str(), s.rows, s.rmse_g,
                s.noise.known() ? fmt::format("{:.2f}", s.rmse_g / s.noise.sigma_g).c_str() : "-",
                verdictName(s.verdict), s.outcome.c_str());
  }
  std::printf("\nstop: %s\n\n", w.stop.c_str());
  std::string files, maps;
  for (const auto& f : c.files) files += f + " ";
  for (const auto& m : c.maps) maps += " --map '" + m + "'";
  if (!w.where.empty()) maps += " --where '" + w.where + "'";
  for (const auto& a : w.adds) maps += " --add '" + a + "'";
  std::printf("the ladder it walked, on the rows kept (by hand: thrustcal lab ladder %s--model '%s'%s):\n\n",
              files.c_str(), c.model.c_str(), maps.c_str());
}

int runWalk(const Common& c, int max_adds) {
  std::vector<std::string> warnings;
  const Dataset data = load(c, warnings, /*collapse_warnings=*/false);
  const ModelSpec spec = parseSpec(c.model);
  if (max_adds < 1) throw std::invalid_argument("--max-adds must be 1 or more");
  const Walk w = walk(data, spec, max_adds, parseHoldout(c.holdout));
  ReportFiles rep;
  Common as_ladder = c;
  as_ladder.where = w.where.empty() ? c.where : (c.where.empty() ? w.where : "(" + c.where + ") and " + w.where);
  if (!c.report_dir.empty())
    rep = writeReport(c.report_dir, w.data, w.ladder, commandLine("ladder", as_ladder, w.adds),
                      reportNotes(w.data, warnings));
  if (c.json_out) {
    std::cout << walkJson(w, c, warnings, rep).dump(2) << "\n";
    return 0;
  }
  printNotesAndWarnings(data, warnings);
  printWalk(w, as_ladder);
  printLadder(w.ladder, w.data, as_ladder);
  if (!rep.page.empty()) printReport(rep);
  for (const auto& wn : rep.warnings) std::fprintf(stderr, "warning: %s\n", wn.c_str());
  return 0;
}

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

template <typename F>
int guarded(F f) {
  try {
    return f();
  } catch (const InputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
  }
  return 2;
}

void addDiagnose(CLI::App* lab) {
  auto diag = std::make_shared<Common>();
  auto* d = lab->add_subcommand("diagnose", "fit a model, then rank the variables that explain what it misses");
  addCommon(d, *diag);
  d->footer("Example: thrustcal lab diagnose sweep.csv --model curve+deadband --json\n"
            "JSON: {\"rmse_g\": x, \"n\": N, \"suspects\": [{\"variable\": ..., \"score\": s, \"effects\": [...]}, ...]}");
  d->callback([diag] {
    const int rc = guarded([&] { return runDiagnose(*diag); });
    if (rc) throw CLI::RuntimeError(rc);
  });
}

void addLadder(CLI::App* lab) {
  auto lad = std::make_shared<Common>();
  auto adds = std::make_shared<std::vector<std::string>>();
  auto* l = lab->add_subcommand("ladder", "the error ladder: one step per added effect, with RMSE, max error and BIC");
  addCommon(l, *lad);
  l->add_option("--add,-a", *adds, "effect(s) to add, one step each (repeatable; a step may be a+b)")->required();
  l->footer("Example: thrustcal lab ladder sweep.csv --model curve --add deadband --add voltage --report out/\n"
            "JSON: {\"steps\": [{\"model\": ..., \"rmse_g\": x, \"bic\": b, ...}, ...]}");
  l->callback([lad, adds] {
    const int rc = guarded([&] { return runLadder(*lad, *adds); });
    if (rc) throw CLI::RuntimeError(rc);
  });
}

void addWalk(CLI::App* lab) {
  auto opts = std::make_shared<Common>();
  auto max_adds = std::make_shared<int>(8);
  auto* w = lab->add_subcommand("walk", "follow the diagnosis's advice to the end: diagnose, drop the rows it says do "
                                        "not measure the force or add the effect it advises, again, until the fit is at "
                                        "the noise floor or the advice does not earn its parameters");
  addCommon(w, *opts);
  w->add_option("--max-adds", *max_adds, "add at most this many effects")->capture_default_str();
  w->footer("Example: thrustcal lab walk sweep*.csv --model curve --report out/\n"
            "JSON: {\"walk\": [{\"model\", \"rmse_g\", \"noise_g\", \"verdict\", \"advice\", \"outcome\"}, ...], "
            "\"where\", \"adds\", \"stop\", \"ladder\": {as lab ladder --json}, \"noise_g\", \"verdict\"}");
  w->callback([opts, max_adds] {
    const int rc = guarded([&] { return runWalk(*opts, *max_adds); });
    if (rc) throw CLI::RuntimeError(rc);
  });
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
