#include "lab/analysis.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>

#include "lab/evidence.hpp"
#include "lab/stats.hpp"

namespace lab {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr std::size_t kMaxRankRows = 20000;  // refits of the ranking on evenly spaced rows above

bool startsWith(const std::string& s, const char* p) { return s.rfind(p, 0) == 0; }

std::string lowerCopy(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool isVoltageName(const std::string& v) {
  return v == "vbat_v" || startsWith(v, "vbat") || startsWith(v, "voltage") || v == "v_v" || v == "v";
}

// Parameters of `effect` that the fit left at a bound, in words ("gamma at its bound 0").
std::vector<std::string> boundsOf(const FitResult& fit, const std::string& effect) {
  std::vector<std::string> out;
  for (const auto& p : fit.params)
    if (p.effect == effect && p.at_bound) out.push_back(fmt::format("{} at its bound {:.4g}", p.name, p.bound));
  return out;
}

struct Advice {
  std::vector<std::string> trials;  // effects to refit with, best guess first
  std::string suggest;              // the effect the words name (empty: none to add)
  std::string words;
};

// Why the residual can still follow a variable whose effect is in the model.
std::string stillFollows(const std::string& var, const std::vector<std::string>& effects, const FitResult& fit,
                         const char* other_reason) {
  std::vector<std::string> bounds;
  for (const auto& e : effects)
    for (const auto& b : boundsOf(fit, e)) bounds.push_back(b);
  std::string in;
  for (const auto& e : effects) in += (in.empty() ? "`" : ", `") + e + "`";
  if (!bounds.empty())
    return fmt::format("residual still follows {} although {} {} in the model: {} (the data pull it past its "
                       "range; check the column and the physics before trusting it)",
                       var, in, effects.size() > 1 ? "are" : "is", fmt::join(bounds, ", "));
  return fmt::format("residual still follows {} although {} {} in the model: {}", var, in,
                     effects.size() > 1 ? "are" : "is", other_reason);
}

// What the catalogue says about a cause, given what the model already has. Never suggests an
// effect that is in the model.
Advice adviceFor(const std::string& var, double mean, const ModelSpec& spec, const FitResult& fit, bool have_rho) {
  const std::string v = lowerCopy(var);
  const bool thesis = spec.has("thesis");
  Advice a;
  auto fresh = [&](const char* e) { return !spec.has(e); };
  if (v == "pwm_us") {
    if (fresh("deadband") && !thesis) {
      a.trials = {"deadband"};
      a.suggest = "deadband";
      a.words = "residual follows pwm_us: the curve's shape near the ESC start threshold is off; add `deadband`";
    } else {
      a.words = "residual follows pwm_us: the curve cannot follow the data's shape (an effect that bends the curve "
                "is missing, the force collapses at the top, or the PWM logged is not the PWM the ESC saw)";
    }
  } else if (isVoltageName(v)) {
    if (thesis) {
      a.words = "residual follows " + var + ": the thesis model interpolates between two voltages only";
    } else if (fresh("voltage")) {
      a.trials = {"voltage"};
      a.suggest = "voltage";
      a.words = "residual follows " + var + ": the force follows the motor voltage duty*V, not the PWM alone; add `voltage`";
    } else if (fresh("sag")) {
      a.trials = {"sag"};
      a.suggest = "sag";
      a.words = "residual follows " + var + " although `voltage` is in the model: the motor sees less than the logged "
                "voltage under load (the battery and its wiring sag); add `sag` (it uses current_a when logged)";
    } else {
      a.words = stillFollows(var, {"voltage", "sag"}, fit,
                             "the sag is not linear in the current, or the voltage logged is not the one at the ESC");
    }
  } else if (v == "t_s" || startsWith(v, "time")) {
    for (const char* e : {"drift", "lag"})
      if (fresh(e)) a.trials.push_back(e);
    if (!a.trials.empty()) {
      a.suggest = a.trials.front();
      a.words = "residual changes with time (" + var + "): something drifts (load-cell creep, a warming rig) or the "
                "force trails the command; add `$E`";
    } else {
      a.words = stillFollows(var, {"drift", "lag"}, fit, "the change is not linear in time (warming, a draining pack?)");
    }
  } else if (v == "temp_c" || startsWith(v, "temp")) {
    // thermal uses the temperature itself; density uses it through rho_kg_m3 (ranked there)
    if (fresh("thermal")) {
      a.trials.push_back("thermal");
      a.suggest = "thermal";
      a.words = "residual follows " + var + ": the motor's temperature (copper and magnets) or the air density "
                "changes the force; add `thermal`" +
                std::string(fresh("density") ? ", or `density` if a pressure column is logged" : "");
    } else if (fresh("density")) {
      a.words = stillFollows(var, {"thermal"}, fit, "the air density may change with it: log a pressure column "
                                                    "and add `density`");
    } else {
      a.words = stillFollows(var, {"thermal", "density"}, fit, "the temperature logged is not the motor's");
    }
  } else if ((startsWith(v, "pressure") || startsWith(v, "baro")) && have_rho) {
    a.words = var + " acts through the air density: see rho_kg_m3";
  } else if (startsWith(v, "pressure") || startsWith(v, "baro")) {
    const std::string expr = fmt::format("mul: 1 + a*({} - {:.4g})", var, mean);
    a.suggest = expr;
    a.words = "residual follows " + var + ": the air density changes the force; log the air temperature (temp_c) "
              "too so `density` can use rho = p/(R T), or try `" + expr + "`";
  } else if (v == "rho_kg_m3") {
    if (fresh("density")) {
      a.trials = {"density"};
      a.suggest = "density";
      a.words = "residual follows the air density (" + var + "): thrust is proportional to rho = p/(R T); add `density`";
    } else {
      a.words = stillFollows(var, {"density"}, fit, "the exponent changes differently with the drive");
    }
  } else if (v == "motor") {
    if (fresh("motor")) {
      a.trials = {"motor"};
      a.suggest = "motor";
      a.words = "motors differ from each other (motor and propeller variation); add `motor`";
    } else {
      a.words = stillFollows(var, {"motor"}, fit, "motors differ in the curve's shape, not only in gain and Kv");
    }
  } else if (v == "run") {
    a.words = "runs differ from each other: a per-run condition (motor, voltage, time) is not modelled; look at the "
              "causes above";
  } else if (v == "dpwm_us" || v == "dir") {
    if (fresh("lag")) {
      a.trials = {"lag"};
      a.suggest = "lag";
      a.words = v == "dir" ? "up and down sweeps differ: the force trails the command (motor inertia, a slow load "
                             "cell); add `lag`"
                           : "residual follows the last PWM step (dpwm_us): the force lags the command (motor "
                             "inertia, a slow load cell); add `lag`";
    } else {
      a.words = stillFollows(var, {"lag"}, fit, "up and down differ by more than a first-order lag (hysteresis, "
                                                 "a load cell that creeps)");
    }
  } else {
    const std::string expr = fmt::format("mul: 1 + a*({} - {:.4g})", var, mean);
    a.suggest = expr;
    a.words = "residual follows " + var + ", which no catalogue effect covers; try `" + expr + "`";
  }
  return a;
}

// |Pearson correlation| of two columns.
double correlation(const std::vector<double>& a, const std::vector<double>& b) {
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  const double n = static_cast<double>(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    sa += a[i], sb += b[i], saa += a[i] * a[i], sbb += b[i] * b[i], sab += a[i] * b[i];
  }
  const double va = saa - sa * sa / n, vb = sbb - sb * sb / n;
  if (!(va > 0) || !(vb > 0)) return 0;
  return std::fabs((sab - sa * sb / n) / std::sqrt(va * vb));
}

// Fraction of z's variance explained by the PWM alone (z's mean in each PWM bin).
double explainedByDrive(const std::vector<double>& z, const std::vector<double>& pwm) {
  const auto [lo_it, hi_it] = std::minmax_element(pwm.begin(), pwm.end());
  const double lo = *lo_it, hi = *hi_it;
  if (!(hi > lo)) return 0;
  const int bins = 100;
  std::vector<double> sum(bins, 0), cnt(bins, 0);
  double mean = 0;
  for (std::size_t i = 0; i < z.size(); ++i) {
    const int k = std::min(bins - 1, static_cast<int>((pwm[i] - lo) / (hi - lo) * bins));
    sum[static_cast<std::size_t>(k)] += z[i];
    cnt[static_cast<std::size_t>(k)] += 1;
    mean += z[i];
  }
  mean /= static_cast<double>(z.size());
  double total = 0, within = 0;
  for (std::size_t i = 0; i < z.size(); ++i) {
    const int k = std::min(bins - 1, static_cast<int>((pwm[i] - lo) / (hi - lo) * bins));
    const double m = sum[static_cast<std::size_t>(k)] / cnt[static_cast<std::size_t>(k)];
    total += (z[i] - mean) * (z[i] - mean);
    within += (z[i] - m) * (z[i] - m);
  }
  return total > 0 ? 1.0 - within / total : 1.0;
}

Dataset evenlySpaced(const Dataset& data, std::size_t max_rows) {
  const std::size_t stride = (data.rows() + max_rows - 1) / max_rows;
  std::vector<bool> keep(data.rows(), false);
  for (std::size_t i = 0; i < data.rows(); i += stride) keep[i] = true;
  return data.subset(keep);
}

// A candidate column as the ranking sees it: NaN when it is constant or not logged on every row.
struct Profile {
  bool usable = false;
  bool categorical = false;
  double mean = 0;
};
Profile profileOf(const std::vector<double>& z) {
  std::set<double> distinct;
  bool integral = true, complete = true;
  double sum = 0;
  for (double v : z) {
    if (!std::isfinite(v)) { complete = false; continue; }
    if (distinct.size() <= 17) distinct.insert(v);
    integral = integral && v == std::round(v);
    sum += v;
  }
  Profile p;
  p.usable = distinct.size() >= 2 && complete;
  p.categorical = (integral && distinct.size() <= 16) || distinct.size() <= 3;
  p.mean = sum / static_cast<double>(z.size());
  return p;
}

// The refits that ask how much of the residual a variable explains: the model with each effect
// the variable points to, or, when no catalogue effect covers it, a generic factor in it.
std::vector<std::pair<std::string, ModelSpec>> trialsFor(const Suspect& s, const Advice& a, const ModelSpec& spec,
                                                         const Dataset& data) {
  std::vector<std::pair<std::string, ModelSpec>> trials;
  for (const auto& t : a.trials) {
    try {
      trials.emplace_back(t, combine(spec, parseSpec(t)));
    } catch (const std::invalid_argument&) {
    }
  }
  const std::string name = s.variable;
  const bool probe = a.trials.empty() && name != "pwm_us" &&
                     !((startsWith(lowerCopy(name), "pressure") || startsWith(lowerCopy(name), "baro")) &&
                       data.has("rho_kg_m3"));
  if (probe) {
    ModelSpec p = spec;
    p.probes.push_back({name, s.categorical});
    trials.emplace_back(a.suggest, p);
  }
  return trials;
}

// The added-variable fit: each trial refitted from the model's optimum; the best trial's score
// and p-value count. Returns the trials that could be fitted with their scores, best first.
std::vector<std::pair<double, std::string>> scoreTrials(Suspect& s,
                                                        const std::vector<std::pair<std::string, ModelSpec>>& trials,
                                                        const Dataset& work, const FitResult& fit) {
  const double n = static_cast<double>(work.rows());
  std::vector<std::pair<double, std::string>> scored;
  for (const auto& [label, t] : trials) {
    try {
      const FitResult r = fitModel(work, t, &fit.params, /*warm_only=*/true, /*uncertainties=*/false, fit.rss);
      if (!std::isfinite(r.rss)) continue;
      const double dk = std::max(1, r.k - fit.k);
      const double score =
          fit.rss > 0 ? std::max(0.0, 1.0 - (r.rss / fit.rss) * std::exp(dk * std::log(n) / n)) : 0.0;
      double p = 1.0;
      const double dof = n - r.k;
      if (r.rss > 0 && dof > 0 && fit.rss > r.rss)
        p = fSurvival(((fit.rss - r.rss) / dk) / (r.rss / dof), dk, dof);
      else
        p = fit.rss > r.rss ? 0.0 : 1.0;
      if (!s.tested || score > s.score) {
        s.score = score;
        s.p_value = p;
      }
      s.tested = true;
      scored.emplace_back(score, label);
    } catch (const std::exception&) {
      // this effect cannot be built on these data (a missing column): try the next
    }
  }
  std::stable_sort(scored.begin(), scored.end(), [](const auto& x, const auto& y) { return x.first > y.first; });
  return scored;
}

// One candidate cause: its advice, and its score from the refits.
Suspect rankCause(Suspect s, const Profile& pr, const std::vector<double>& z, const std::vector<double>& pwm,
                  const Dataset& data, const Dataset& work, const FitResult& fit, const ModelSpec& spec) {
  const std::string& name = s.variable;
  const Advice a = adviceFor(name, pr.mean, spec, fit, data.has("rho_kg_m3"));
  s.advice = a.words;
  if ((name == "t_s" || startsWith(lowerCopy(name), "time"))) {
    const double r2 = explainedByDrive(z, pwm);
    if (r2 > 0.9) {
      s.advice = fmt::format("{} moves with the drive in these data (the PWM explains {:.0f} % of it: a ramp), so "
                             "drift cannot be told from the curve's shape here; to test drift, repeat a sweep or "
                             "hold a PWM for a while",
                             name, 100 * r2);
      return s;
    }
  }
  const auto scored = scoreTrials(s, trialsFor(s, a, spec, data), work, fit);
  if (!a.suggest.empty()) {
    for (const auto& sc : scored) s.effects.push_back(sc.second);
    if (s.effects.empty()) s.effects.push_back(a.suggest);
  }
  // the effect the data prefer among the candidates
  const auto at = s.advice.find("$E");
  if (at != std::string::npos) s.advice.replace(at, 2, s.effects.empty() ? a.suggest : s.effects.front());
  return s;
}

// Significance against a Bonferroni level over the tested variables, then the order: causes
// first, tested ones by score; `run` (which file or sweep) is a catch-all after them; then the
// variables not tested.
void orderSuspects(std::vector<Suspect>& out) {
  std::size_t tested = 0;
  for (const auto& s : out) tested += s.tested ? 1 : 0;
  const double alpha = 1e-3 / static_cast<double>(std::max<std::size_t>(tested, 1));
  for (auto& s : out) s.significant = s.tested && s.p_value < alpha && s.score >= 0.01;
  std::stable_sort(out.begin(), out.end(), [](const Suspect& a, const Suspect& b) {
    if (a.significant != b.significant) return a.significant;
    const bool ar = a.variable == "run", br = b.variable == "run";
    if (ar != br) return br;
    if (a.tested != b.tested) return a.tested;
    return a.score > b.score;
  });
}

}  // namespace

Role roleOf(const std::string& name) {
  const std::string v = lowerCopy(name);
  for (const char* word : {"rpm", "speed", "torque", "power", "efficien", "thrust", "force", "weight", "current",
                           "vibration", "accel"})
    if (v.find(word) != std::string::npos) return Role::kResponse;
  if (v == "p_w" || v == "p_mw" || v == "i_a" || v == "i_ma" || startsWith(v, "accx") || startsWith(v, "accy") ||
      startsWith(v, "accz") || startsWith(v, "acc_"))
    return Role::kResponse;
  return Role::kCause;
}

std::vector<Suspect> rankVariables(const Dataset& data_in, const FitResult& fit_in, const ModelSpec& spec) {
  // Big data: the refits run on evenly spaced rows, against the model refitted there.
  Dataset sampled;
  FitResult sampled_fit;
  const bool big = data_in.rows() > kMaxRankRows;
  if (big) {
    sampled = evenlySpaced(data_in, kMaxRankRows);
    sampled_fit = fitModel(sampled, spec, &fit_in.params, /*warm_only=*/true, /*uncertainties=*/false);
  }
  const Dataset& data = big ? sampled : data_in;
  const FitResult& fit = big ? sampled_fit : fit_in;

  std::vector<std::pair<std::string, const std::vector<double>*>> candidates;
  for (std::size_t c = 0; c < data.names.size(); ++c)
    if (data.names[c] != "force_g") candidates.emplace_back(data.names[c], &data.columns[c]);
  std::vector<double> run_column;
  Dataset with_run;
  const Dataset* work = &data;
  if (data.runs() > 1 && !data.has("run")) {
    run_column.assign(data.run.begin(), data.run.end());
    with_run = data;
    with_run.set("run", run_column);
    work = &with_run;
    candidates.emplace_back("run", &run_column);
  }
  const auto& pwm = data.col("pwm_us");
  std::vector<Suspect> out;
  for (const auto& [name, zp] : candidates) {
    const Profile pr = profileOf(*zp);
    if (!pr.usable) continue;
    Suspect s;
    s.variable = name;
    s.categorical = pr.categorical;
    s.role = name == "pwm_us" ? Role::kCause : roleOf(name);
    if (s.role == Role::kCause && name != "pwm_us" && name != "t_s" && !s.categorical &&
        correlation(*zp, pwm) > 0.999)
      s.role = Role::kDriveCopy;
    if (s.role == Role::kResponse)
      s.advice = name + " is a response of the motor (it follows the drive): it shows the residual, it does not "
                        "cause it; not a suspect";
    else if (s.role == Role::kDriveCopy)
      s.advice = name + " is a copy of the drive (it moves with pwm_us): a factor in it would only reshape the curve; "
                        "not a suspect (map one drive column with --map)";
    else
      s = rankCause(s, pr, *zp, pwm, data, *work, fit, spec);
    out.push_back(s);
  }
  orderSuspects(out);
  return out;
}

Holdout parseHoldout(const std::string& text) {
  if (text == "none" || text.empty()) return Holdout::kNone;
  if (text == "runs" || text == "run") return Holdout::kRuns;
  if (text == "voltage" || text == "voltages") return Holdout::kVoltage;
  throw std::invalid_argument("--holdout '" + text + "': expected none, runs or voltage");
}

double holdoutRmse(const Dataset& data, const ModelSpec& spec, Holdout kind, int* groups_out) {
  if (groups_out) *groups_out = 0;
  if (kind == Holdout::kNone) return kNaN;
  std::vector<int> group(data.rows());
  int groups = 0;
  if (kind == Holdout::kRuns) {
    for (std::size_t i = 0; i < data.rows(); ++i) group[i] = data.run[i];
    groups = static_cast<int>(data.runs());
    if (groups < 2)
      throw std::invalid_argument(fmt::format(
          "--holdout runs needs at least two runs to predict one from the others; the data has {} ({}). Give "
          "several files (or a `run` column), or leave --holdout out",
          groups, data.run_labels.empty() ? "no run" : data.run_labels.front()));
  } else {
    if (!data.has("vbat_v")) throw std::invalid_argument("--holdout voltage needs a vbat_v column");
    // a voltage level: the run's mean voltage, rounded to 0.25 V
    std::map<int, std::pair<double, int>> run_v;
    const auto& v = data.col("vbat_v");
    for (std::size_t i = 0; i < data.rows(); ++i) {
      run_v[data.run[i]].first += v[i];
      run_v[data.run[i]].second += 1;
    }
    std::map<long, int> level_id;
    std::map<int, int> run_group;
    for (const auto& [r, s] : run_v) {
      const long level = std::lround(4.0 * s.first / s.second);
      auto it = level_id.emplace(level, static_cast<int>(level_id.size())).first;
      run_group[r] = it->second;
    }
    for (std::size_t i = 0; i < data.rows(); ++i) group[i] = run_group[data.run[i]];
    groups = static_cast<int>(level_id.size());
    if (groups < 2)
      throw std::invalid_argument(fmt::format(
          "--holdout voltage needs runs at two or more voltages (run means 0.25 V apart) to predict one from the "
          "others; the data has {}. Measure at another voltage, or use --holdout runs",
          groups));
  }
  if (groups_out) *groups_out = groups;
  double sse = 0;
  std::size_t count = 0;
  const auto& y = data.col("force_g");
  for (int g = 0; g < groups; ++g) {
    std::vector<bool> train(data.rows()), test(data.rows());
    for (std::size_t i = 0; i < data.rows(); ++i) {
      train[i] = group[i] != g;
      test[i] = group[i] == g;
    }
    const Dataset tr = data.subset(train);
    const Dataset te = data.subset(test);
    if (tr.rows() < 10 || te.rows() == 0) continue;
    Model m(spec, tr);
    m.fit(nullptr, false, false);
    const auto pred = m.predict(te);
    std::size_t k = 0;
    for (std::size_t i = 0; i < data.rows(); ++i) {
      if (!test[i]) continue;
      const double e = y[i] - pred[k++];
      if (std::isfinite(e)) {
        sse += e * e;
        ++count;
      }
    }
  }
  if (count == 0)
    throw std::invalid_argument("--holdout: no group left at least 10 rows to fit on; log more rows per run");
  return std::sqrt(sse / static_cast<double>(count));
}

Diagnosis diagnose(const Dataset& data, const ModelSpec& spec, Holdout holdout) {
  Diagnosis d;
  d.fit = fitModel(data, spec);
  d.variables = rankVariables(data, d.fit, spec);
  d.holdout_rmse_g = holdoutRmse(data, spec, holdout, &d.holdout_groups);
  return d;
}

std::vector<LadderStep> ladder(const Dataset& data, const ModelSpec& base,
                               const std::vector<std::string>& adds, Holdout holdout) {
  std::vector<LadderStep> steps;
  ModelSpec spec = base;
  for (std::size_t s = 0; s <= adds.size(); ++s) {
    LadderStep step;
    ModelSpec added;
    if (s > 0) {
      step.added = adds[s - 1];
      added = parseSpec(adds[s - 1]);
      spec = combine(spec, added);
    }
    step.spec = spec;
    step.fit = steps.empty() ? fitModel(data, spec)
                             : fitModel(data, spec, &steps.back().fit.params, false, true, steps.back().fit.rss);
    // the diagnosis of the first and the last step (the report and the text use those)
    if (s == 0 || s == adds.size()) step.variables = rankVariables(data, step.fit, spec);
    step.holdout_rmse_g = holdoutRmse(data, spec, holdout);
    if (steps.empty()) {
      step.verdict = "start";
    } else {
      step.delta_bic = step.fit.bic - steps.back().fit.bic;
      step.delta_aic = step.fit.aic - steps.back().fit.aic;
      std::vector<std::string> names = added.effects;
      for (const auto& u : added.user) names.push_back((u.multiplicative ? "mul: " : "add: ") + u.expression);
      for (const auto& e : names)
        for (const auto& b : boundsOf(step.fit, e)) step.at_bound.push_back(b);
      const bool falls = step.delta_bic < -2.0;
      step.earns = falls && step.at_bound.empty();
      if (step.earns)
        step.verdict = "earns its parameters";
      else if (!step.at_bound.empty())
        step.verdict = fmt::format("no credit: {}", fmt::join(step.at_bound, ", "));
      else
        step.verdict = "does NOT earn its parameters";
    }
    steps.push_back(std::move(step));
  }
  return steps;
}

std::vector<ForceCollapse> findForceCollapse(const Dataset& data) {
  std::vector<ForceCollapse> out;
  if (!data.has("pwm_us") || !data.has("force_g")) return out;
  const auto rows = rowsOfRuns(data);
  for (std::size_t r = 0; r < rows.size(); ++r) {
    if (rows[r].size() < 8) continue;
    const auto med = binnedMedians(data.col("pwm_us"), data.col("force_g"), rows[r]);  // pwm, median force
    if (med.size() < 4) continue;
    std::size_t peak = 0;
    for (std::size_t k = 1; k < med.size(); ++k)
      if (med[k].second > med[peak].second) peak = k;
    const double drop = std::max(0.03 * med[peak].second, 1e-9);
    if (peak + 1 >= med.size() || !(med[peak].second > 0)) continue;
    // every bin above the peak stays below it, and the top one is down by more than 3 %
    bool down = med.back().second < med[peak].second - drop;
    for (std::size_t k = peak + 1; k < med.size() && down; ++k) down = med[k].second < med[peak].second;
    if (!down) continue;
    out.push_back({data.run_labels[r], med[peak].first, med[peak].second, med.back().first, med.back().second});
  }
  return out;
}

std::string describe(const ForceCollapse& c) {
  return fmt::format("{}: the force falls while the drive rises, from {:.4g} g at {:.0f} us to {:.4g} g at {:.0f} us "
                     "(an ESC or current limit?); a monotone curve cannot follow it: fit below it with --where "
                     "'pwm_us < {:.0f}'",
                     c.run, c.peak_force_g, c.peak_pwm_us, c.top_force_g, c.top_pwm_us, c.peak_pwm_us);
}

}  // namespace lab
