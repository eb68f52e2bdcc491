#include "lab/analysis.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>

#include "lab/stats.hpp"

namespace lab {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool startsWith(const std::string& s, const char* p) { return s.rfind(p, 0) == 0; }

std::string lowerCopy(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool isOutcomeName(const std::string& v);

struct Advice {
  std::vector<std::string> effects;
  std::string words;
};

Advice adviceFor(const std::string& var, double mean, const ModelSpec& spec) {
  const std::string v = lowerCopy(var);
  Advice a;
  auto pick = [&](std::vector<std::string> effects) {
    std::vector<std::string> missing;
    for (const auto& e : effects)
      if (!spec.has(e)) missing.push_back(e);
    a.effects = missing.empty() ? effects : missing;
    return !missing.empty();
  };
  const std::string first_missing_or = "";
  if (v == "pwm_us") {
    const bool fresh = pick({"deadband", "curve"});
    a.words = fresh ? "residual follows pwm_us: the curve's shape near the ESC start threshold is off; add `deadband`"
                    : "residual follows pwm_us: the curve cannot follow the data's shape (an effect that bends the curve is missing, or the PWM logged is not the PWM the ESC saw)";
  } else if (v == "vbat_v" || startsWith(v, "vbat") || v == "v_v" || startsWith(v, "voltage")) {
    if (!spec.has("voltage") && !spec.has("thesis")) {
      pick({"voltage", "sag"});
      a.words = "residual follows " + var + ": the force follows the motor voltage duty*V, not the PWM alone; add `voltage`";
    } else {
      pick({"sag", "voltage"});
      a.words = "residual follows " + var + ": the motor sees a different voltage than the one logged (the battery sags under load); add `sag`";
    }
  } else if (v == "current_a" || startsWith(v, "current") || v == "i_a") {
    pick({"sag"});
    a.words = "residual grows with " + var + ": the battery sags under load; add `sag`";
  } else if (v == "t_s" || startsWith(v, "time")) {
    pick({"drift", "thermal", "lag"});
    a.words = "residual changes with time (" + var + "): something drifts (load-cell creep, a warming rig); add `drift`";
  } else if (v == "temp_c" || startsWith(v, "temp")) {
    pick({"thermal", "density"});
    a.words = "residual follows " + var + ": the motor's temperature (copper and magnets) or the air density changes the force; add `thermal`, or `density` if a pressure column is logged";
  } else if (v == "rho_kg_m3" || startsWith(v, "pressure") || startsWith(v, "baro")) {
    pick({"density"});
    a.words = "residual follows the air density (" + var + "): thrust is proportional to rho = p/(R T); add `density`";
  } else if (v == "motor") {
    pick({"motor"});
    a.words = "motors differ from each other (motor and propeller variation); add `motor`";
  } else if (v == "run") {
    pick({"motor", "voltage", "drift"});
    a.words = "runs differ from each other: a per-run condition (motor, voltage, time) is not modelled; look at the next suspects";
  } else if (v == "dpwm_us") {
    pick({"lag"});
    a.words = "residual follows the last PWM step (dpwm_us): the force lags the command (motor inertia, a slow load cell); add `lag`";
  } else if (v == "dir") {
    pick({"lag"});
    a.words = "up and down sweeps differ: the motor speed lags the command; add `lag`";
  } else if (isOutcomeName(v)) {
    pick({"voltage", "sag", "density"});
    a.words = var + " is the motor's response, not a condition: it follows whatever the drive model misses, so it is not ranked as a suspect";
  } else {
    const std::string expr = fmt::format("mul: 1 + a*({} - {:.4g})", var, mean);
    a.effects = {expr};
    a.words = "residual follows " + var + ", which no catalogue effect covers; try `" + expr + "`";
  }
  return a;
}

bool isOutcomeName(const std::string& v) { return isOutcome(v); }

// Catalogue effects that use this variable, in the order to try them.
std::vector<std::string> trialsFor(const std::string& var, const ModelSpec& spec, const Dataset& data) {
  const std::string v = lowerCopy(var);
  std::vector<std::string> want;
  if (v == "pwm_us") want = {"deadband"};
  else if (v == "vbat_v") want = {"voltage"};
  else if (v == "current_a") want = {spec.has("voltage") ? "sag" : "voltage+sag"};
  else if (v == "t_s") want = {"drift", "lag"};
  else if (v == "temp_c") want = {"thermal"};
  else if (v == "rho_kg_m3") want = {"density"};  // pressure alone: probed (rho is the physics)
  else if (v == "motor") want = {"motor"};
  else if (v == "dir" || v == "dpwm_us") want = {"lag"};
  std::vector<std::string> out;
  for (const auto& w : want) {
    const ModelSpec e = parseSpec(w);
    bool fresh = false;
    for (const auto& name : e.effects) fresh = fresh || !spec.has(name);
    if (fresh && !(spec.has("thesis") && (w.find("voltage") != std::string::npos || w == "sag" || w == "deadband")))
      out.push_back(w);
  }
  (void)data;
  return out;
}

}  // namespace

// The motor's responses: speed, torque, power, another thrust or force reading. Each is a thrust
// meter in disguise, so it would "explain" any residual; they are scored, never suspects.
bool isOutcome(const std::string& name) {
  const std::string v = lowerCopy(name);
  for (const char* word : {"rpm", "speed", "torque", "power", "efficien", "thrust", "force", "weight"})
    if (v.find(word) != std::string::npos) return true;
  return v == "p_w" || v == "p_mw";
}

std::vector<Suspect> rankVariables(const Dataset& data, const FitResult& fit, const ModelSpec& spec) {
  std::vector<std::pair<std::string, std::vector<double>>> candidates;
  for (std::size_t c = 0; c < data.names.size(); ++c)
    if (data.names[c] != "force_g") candidates.emplace_back(data.names[c], data.columns[c]);
  Dataset work = data;
  if (data.runs() > 1 && !data.has("run")) {
    std::vector<double> run(data.run.begin(), data.run.end());
    work.set("run", run);
    candidates.emplace_back("run", run);
  }
  const double n = static_cast<double>(fit.n);
  std::vector<Suspect> out;
  for (const auto& [name, z] : candidates) {
    std::set<double> distinct;
    bool integral = true, complete = true;
    double sum = 0;
    for (double v : z) {
      if (!std::isfinite(v)) { complete = false; continue; }
      if (distinct.size() <= 17) distinct.insert(v);
      integral = integral && v == std::round(v);
      sum += v;
    }
    if (distinct.size() < 2 || !complete) continue;
    Suspect s;
    s.variable = name;
    s.outcome = isOutcome(name);
    s.categorical = (integral && distinct.size() <= 16) || distinct.size() <= 3;
    const Advice a = adviceFor(name, sum / static_cast<double>(z.size()), spec);
    s.effects = a.effects;
    s.advice = a.words;
    // The added-variable fit: refit the model with the effect this variable points to (or a
    // generic factor in it) and see how much of the residual goes away.
    std::vector<ModelSpec> trials;
    for (const auto& t : trialsFor(name, spec, data)) trials.push_back(combine(spec, parseSpec(t)));
    // pwm_us is the curve's own input: once the catalogue's PWM effects are in, a generic
    // factor in it would only reshape the curve, so it is not probed.
    if (lowerCopy(name) != "pwm_us") {
      ModelSpec probe = spec;
      probe.probes.push_back({name, s.categorical});
      trials.push_back(probe);
    }
    bool done = s.outcome;  // the motor's response: not refitted, not ranked
    for (const auto& t : trials) {
      if (done) break;
      try {
        const FitResult r = fitModel(work, t, &fit.params, /*warm_only=*/true);
        if (!std::isfinite(r.rss)) continue;
        const double dk = std::max(1, r.k - fit.k);
        s.score = fit.rss > 0 ? std::max(0.0, 1.0 - (r.rss / fit.rss) * std::exp(dk * std::log(n) / n)) : 0.0;
        const double dof = n - r.k;
        if (r.rss > 0 && dof > 0 && fit.rss > r.rss)
          s.p_value = fSurvival(((fit.rss - r.rss) / dk) / (r.rss / dof), dk, dof);
        else
          s.p_value = fit.rss > r.rss ? 0.0 : 1.0;
        done = true;
      } catch (const std::exception&) {
        // this effect cannot be built on these data (a missing column): try the next
      }
    }
    out.push_back(s);
  }
  const double alpha = 1e-3 / std::max<std::size_t>(out.size(), 1);
  for (auto& s : out) s.significant = s.p_value < alpha && s.score >= 0.01 && !s.outcome;
  // Physical variables first; `run` (which file or sweep) is a catch-all, listed after them.
  std::stable_sort(out.begin(), out.end(), [](const Suspect& a, const Suspect& b) {
    if (a.significant != b.significant) return a.significant;
    const bool ar = a.variable == "run", br = b.variable == "run";
    if (ar != br) return br;
    return a.score > b.score;
  });
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
  }
  if (groups_out) *groups_out = groups;
  if (groups < 2) return kNaN;
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
    m.fit();
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
  return count ? std::sqrt(sse / static_cast<double>(count)) : kNaN;
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
    if (s > 0) {
      step.added = adds[s - 1];
      spec = combine(spec, parseSpec(adds[s - 1]));
    }
    step.spec = spec;
    step.fit = fitModel(data, spec, steps.empty() ? nullptr : &steps.back().fit.params);
    // the diagnosis of the first and the last step (the report and the text use those)
    if (s == 0 || s == adds.size()) step.variables = rankVariables(data, step.fit, spec);
    step.holdout_rmse_g = holdoutRmse(data, spec, holdout);
    if (!steps.empty()) {
      step.delta_bic = step.fit.bic - steps.back().fit.bic;
      step.delta_aic = step.fit.aic - steps.back().fit.aic;
      step.earns = step.delta_bic < -2.0;
    }
    steps.push_back(std::move(step));
  }
  return steps;
}

}  // namespace lab
