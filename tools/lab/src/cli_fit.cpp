// `lab diagnose`, `lab ladder` and `lab walk`: run, print as text or JSON, write the report.
#include <fmt/format.h>

#include <cmath>
#include <memory>

#include "cli_common.hpp"

namespace lab::cli {

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
  printAssessmentExtras(d);
  if (!d.regions.empty()) std::printf("where the residual is:\n");
  for (const auto& r : d.regions) std::printf("  - %s\n", r.text.c_str());
  std::printf("verdict: %s\n", d.verdict_text.c_str());
  printNext(d, c);
}

int runDiagnose(const Common& c) {
  std::vector<std::string> warnings;
  const Dataset data = load(c, warnings, /*collapse_warnings=*/false);
  const ModelSpec spec = specOf(c);
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
              data.rows(), data.runs(), floorText(noise).c_str());
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
  printAssessmentExtras(last.assessment);
  for (const auto& r : last.assessment.regions) std::printf("where the residual is: %s\n", r.text.c_str());
  std::printf("verdict: %s\n", last.assessment.verdict_text.c_str());
}

int runLadder(const Common& c, const std::vector<std::string>& adds) {
  std::vector<std::string> warnings;
  const Dataset data = load(c, warnings);
  const ModelSpec spec = specOf(c);
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
  const ModelSpec spec = specOf(c);
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

}  // namespace lab::cli
