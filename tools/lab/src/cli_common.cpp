#include "cli_common.hpp"

#include <fmt/format.h>

#include <cmath>

namespace lab::cli {

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
  cmd->add_option("--fix", c.fixes,
                  "hold a parameter at a known value instead of fitting it, NAME=VALUE, repeatable (a bench's own "
                  "filter: --fix tau_cell_s=0.03 --fix cell_stages=3)");
  cmd->add_flag("--no-motor-split", c.no_motor_split, "one run per file even with a motor column");
}

// Rows selected with --where (the count kept and dropped goes to the notes) and warnings about
// data a fit should not be asked to explain (force falling as the drive rises; `diagnose` reports
// it as evidence instead).
void selectAndCheck(Dataset& d, const std::string& where, std::vector<std::string>& warnings,
                    bool collapse_warnings) {
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

Dataset load(const Common& c, std::vector<std::string>& warnings, bool collapse_warnings) {
  ReadOptions ro;
  for (const auto& m : c.maps) ro.maps.push_back(parseColumnMap(m));
  ro.split_by_motor = !c.no_motor_split;
  Dataset d = readFiles(c.files, ro);
  selectAndCheck(d, c.where, warnings, collapse_warnings);
  addDerivedColumns(d);
  return d;
}

ModelSpec specOf(const Common& c) {
  ModelSpec spec = parseSpec(c.model);
  for (const auto& f : c.fixes) fixParameter(spec, f);
  return spec;
}

json num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json paramsJson(const FitResult& f) {
  json a = json::array();
  for (const auto& p : f.params)
    a.push_back({{"name", p.name}, {"unit", p.unit}, {"effect", p.effect}, {"value", num(p.value)},
                 {"sigma", num(p.sigma)}, {"fixed", p.fixed}});
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

void printFit(const FitResult& f, const NoiseEstimate* noise) {
  std::printf("fit: RMSE %.3f g (%.2f %% of the largest force), max %.2f g (%.2f %%), %d parameters, BIC %.1f, AIC %.1f\n",
              f.rmse_g, f.rmse_pct, f.max_g, f.max_pct, f.k, f.bic, f.aic);
  if (noise) std::printf("noise floor: %s\n", floorText(*noise).c_str());
  std::printf("parameters:\n");
  int curve = 0;
  for (const auto& p : f.params) {
    if (p.effect == "curve" && p.name != "offset_g") {
      ++curve;
      continue;
    }
    std::printf("  %-20s %-28s (%s%s)\n", p.name.c_str(), fmtSigma(p).c_str(), p.effect.c_str(), p.fixed ? ", held" : "");
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
  for (const auto& f : c.fixes) s += " --fix '" + f + "'";
  for (const auto& a : adds) s += " --add '" + a + "'";
  return s;
}

std::string floorText(const NoiseEstimate& n) {
  if (!n.known()) return describe(n);
  if (n.method == "pure_error")
    return fmt::format("{}, pure error: the scatter within {} set points' steady parts ({} of their {} rows), "
                       "lag-1 autocorrelation {:.2f} (successive differences alone {:.3g} g, neighbouring rows as if "
                       "independent {:.3g} g)",
                       describe(n), n.setpoints, n.steady_rows, n.setpoint_rows, n.lag1, n.successive_g,
                       n.uncorrected_g);
  return fmt::format("{}, from the data ({} contrasts of neighbouring rows{}), lag-1 autocorrelation {:.2f}{}",
                     describe(n), n.contrasts, n.features ? fmt::format(", {} kinks left out", n.features) : "",
                     n.lag1, n.lag1 > 0 ? fmt::format(" ({:.3g} g as if independent)", n.uncorrected_g) : "");
}

json noiseJson(const NoiseEstimate& n) {
  const bool pure = n.method == "pure_error";
  return {{"method", pure ? "pure error: the pooled scatter within repeated set points' steady parts, corrected for "
                            "correlated samples (docs/lab.md)"
                          : "neighbouring rows: contrasts of four neighbours orthogonal to a quadratic in the PWM, the "
                            "logged conditions regressed out, corrected for correlated samples (docs/lab.md)"},
          {"estimator", n.method}, {"assumption", n.assumption}, {"lag1", num(n.lag1)},
          {"uncorrected_g", num(n.uncorrected_g)}, {"successive_g", num(n.successive_g)},
          {"setpoints", n.setpoints}, {"steady_rows", n.steady_rows}, {"setpoint_rows", n.setpoint_rows},
          {"contrasts", n.contrasts}, {"features_left_out", n.features}, {"dof", num(n.dof)},
          {"conditions", n.conditions}, {"note", n.note}, {"why_not", n.why_not}};
}

json lackOfFitJson(const LackOfFit& l) {
  return {{"tested", l.tested}, {"f", num(l.f)}, {"dof1", l.dof1}, {"dof2", num(l.dof2)}, {"p_value", num(l.p_value)},
          {"significant", l.significant}, {"setpoint_rms_g", num(l.setpoint_rms_g)}, {"excess_g", num(l.excess_g)},
          {"text", l.text}, {"why_not", l.why_not}};
}

json dynamicsJson(const std::vector<MotorDynamics>& dynamics) {
  json a = json::array();
  for (const auto& d : dynamics)
    a.push_back({{"motor", d.motor.empty() ? json(nullptr) : json(d.motor)}, {"tau_up_s", num(d.tau_up_s)},
                 {"tau_up_sigma_s", num(d.tau_up_sigma_s)}, {"tau_down_s", num(d.tau_down_s)},
                 {"tau_down_sigma_s", num(d.tau_down_sigma_s)},
                 {"spin_down", d.asymmetry > 0 ? "slower" : d.asymmetry < 0 ? "faster" : "alike"}, {"text", d.text}});
  return a;
}

void printAssessmentExtras(const Assessment& a) {
  if (a.lack_of_fit.tested) std::printf("lack of fit: %s\n", a.lack_of_fit.text.c_str());
  for (const auto& d : a.dynamics) std::printf("dynamics: %s\n", d.text.c_str());
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
  j["noise"]["lack_of_fit"] = lackOfFitJson(d.lack_of_fit);
  j["dynamics"] = dynamicsJson(d.dynamics);
  j["verdict"] = verdictName(d.verdict);
  j["verdict_text"] = d.verdict_text;
  j["unexplained_g"] = num(d.unexplained_g);
  j["regions"] = regionsJson(d.regions);
  j["evidence"] = evidenceJson(d.evidence);
  j["next"] = {{"where", d.next.where.empty() ? json(nullptr) : json(d.next.where)},
               {"add", d.next.add.empty() ? json(nullptr) : json(d.next.add)},
               {"why", d.next.why}};
}

}  // namespace lab::cli
