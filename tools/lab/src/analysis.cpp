#include "lab/analysis.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>

#include "lab/effect.hpp"
#include "lab/evidence.hpp"
#include "lab/stats.hpp"
#include "csv_reader.hpp"

namespace lab {

namespace {

constexpr std::size_t kMaxRankRows = 20000;  // refits of the ranking on evenly spaced rows above

bool startsWith(const std::string& s, const char* p) { return s.rfind(p, 0) == 0; }

// What the registry says about a variable or a finding, given what the model already has.
struct Advice {
  std::vector<std::string> trials;           // effects to refit with, in registry order (the data pick)
  std::map<std::string, std::string> words_for;  // each trial's advice, if the data pick it
  std::string generic;                       // a factor to probe when no effect applies ("": none)
  std::string words;                         // the advice before the data pick
};

// A column name against an entry's patterns: exact, or a prefix ending in '*'; any case.
bool matches(const std::string& name, const std::vector<std::string>& patterns) {
  const std::string v = csv::lower(name);
  for (const auto& p : patterns) {
    if (!p.empty() && p.back() == '*' ? startsWith(v, p.substr(0, p.size() - 1).c_str()) : v == p) return true;
  }
  return false;
}

// The SPEC's base (the default one when it names none).
const effects::EffectDef* baseOf(const ModelSpec& spec) {
  for (const auto& e : spec.effects)
    if (const auto* d = effects::find(e); d && d->role == effects::Role::kBase) return d;
  for (const auto* d : effects::registry())
    if (d->role == effects::Role::kBase) return d;
  return nullptr;
}

bool inModel(const effects::EffectDef& d, const ModelSpec& spec) { return spec.has(d.name) || baseOf(spec) == &d; }

// An effect the model can add: not in it, what it needs is there, and it fits this base.
bool addable(const effects::EffectDef& d, const ModelSpec& spec) {
  if (d.role != effects::Role::kEffect || inModel(d, spec)) return false;
  if (!d.needs.empty() && !spec.has(d.needs)) return false;
  return !(d.shapes_curve && baseOf(spec) != baseOf(ModelSpec()));
}

std::string quoted(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "`" : ", `") + n + "`";
  return s;
}

// Why the residual can still follow a variable whose effects are in the model: a parameter
// pulled to a bound, else what each of them says it cannot do.
std::string stillFollows(const std::string& var, const std::vector<const effects::EffectDef*>& in, const FitResult& fit) {
  std::vector<std::string> names, bounds, reasons;
  for (const auto* d : in) {
    names.push_back(d->name);
    for (const auto& b : boundsOf(fit, d->name)) bounds.push_back(b);
    if (!d->suggests.still.empty()) reasons.push_back(d->suggests.still);
  }
  const char* verb = in.size() > 1 ? "are" : "is";
  if (!bounds.empty())
    return fmt::format("residual still follows {} although {} {} in the model: {} (the data pull it past its "
                       "range; check the column and the physics before trusting it)",
                       var, quoted(names), verb, fmt::join(bounds, ", "));
  return fmt::format("residual still follows {} although {} {} in the model: {}", var, quoted(names), verb,
                     fmt::join(reasons, "; "));
}

// The advice of the entries that `kind` (a variable's name, or an evidence kind when
// `evidence`) points at. Never suggests an effect that is in the model.
Advice adviceFor(const std::string& var, const std::string& lead, const ModelSpec& spec, const FitResult& fit,
                 bool evidence) {
  Advice a;
  std::vector<const effects::EffectDef*> in, other_base;
  for (const auto* d : effects::registry()) {
    if (!matches(var, evidence ? d->suggests.evidence : d->suggests.variables)) continue;
    if (inModel(*d, spec)) {
      in.push_back(d);
    } else if (addable(*d, spec)) {
      a.trials.push_back(d->name);
      const std::string although = d->needs.empty() ? "" : fmt::format(" although `{}` is in the model", d->needs);
      a.words_for[d->name] = lead + although + ": " + d->suggests.advice;
    } else if (d->shapes_curve && d->role == effects::Role::kEffect) {
      other_base.push_back(d);
    }
  }
  if (!a.trials.empty()) {
    a.words = a.words_for[a.trials.front()];
  } else if (!in.empty() && !evidence) {
    a.words = stillFollows(var, in, fit);
  } else if (!other_base.empty()) {
    std::vector<std::string> names;
    for (const auto* d : other_base) names.push_back(d->name);
    a.words = fmt::format("{}: {} shape the `{}` base, which this model (`{}`) does not use; compare with a model on "
                          "that base",
                          lead, quoted(names), baseOf(ModelSpec())->name, baseOf(spec)->name);
  }
  return a;
}

// A variable no entry covers: a generic factor in it is what can be tried.
void genericAdvice(Advice& a, const std::string& var, double mean, bool categorical) {
  const effects::EffectDef* mul = nullptr;
  for (const auto* d : effects::registry())
    if (d->role == effects::Role::kExpression && d->multiplicative) mul = d;
  if (var == "run") {
    a.words = "runs differ from each other: a per-run condition (motor, voltage, time) is not modelled; look at the "
              "causes above";
    return;  // the catch-all: probed, never an effect to add
  }
  a.generic = categorical ? std::string() : fmt::format("{} 1 + a*({} - {:.4g})", mul ? mul->prefix : "mul:", var, mean);
  a.words = categorical ? fmt::format("residual follows {}, which no catalogue effect covers: its levels differ", var)
                        : fmt::format("residual follows {}, which no catalogue effect covers; try `{}`", var, a.generic);
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
std::vector<std::pair<std::string, ModelSpec>> trialsFor(const Suspect& s, const Advice& a, const ModelSpec& spec) {
  std::vector<std::pair<std::string, ModelSpec>> trials;
  for (const auto& t : a.trials) {
    try {
      trials.emplace_back(t, combine(spec, parseSpec(t)));
    } catch (const std::invalid_argument&) {
    }
  }
  if (a.trials.empty() && s.variable != "pwm_us") {
    ModelSpec p = spec;
    p.probes.push_back({s.variable, s.categorical});
    trials.emplace_back(a.generic, p);
  }
  return trials;
}

// The added-variable fit: each trial refitted from the model's optimum; the best trial's score
// and p-value count. Returns the trials that could be fitted with their scores, best first.
std::vector<std::pair<double, std::string>> scoreTrials(Suspect& s,
                                                        const std::vector<std::pair<std::string, ModelSpec>>& trials,
                                                        const Dataset& work, const FitResult& fit, bool quick = true) {
  const double n = static_cast<double>(work.rows());
  std::vector<std::pair<double, std::string>> scored;
  for (const auto& [label, t] : trials) {
    try {
      const FitResult r = fitModel(work, t, &fit.params, /*warm_only=*/quick, /*uncertainties=*/false, fit.rss);
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
  const std::string lname = csv::lower(name);
  if ((startsWith(lname, "pressure") || startsWith(lname, "baro")) && data.has("rho_kg_m3")) {
    s.advice = name + " acts through the air density: see rho_kg_m3";
    return s;
  }
  if (name == "t_s" || startsWith(lname, "time")) {
    const double r2 = explainedByDrive(z, pwm);
    if (r2 > 0.9) {
      s.advice = fmt::format("{} moves with the drive in these data (the PWM explains {:.0f} % of it: a ramp), so a "
                             "change with time cannot be told from the curve's shape here; to test it, repeat a sweep "
                             "or hold a PWM for a while",
                             name, 100 * r2);
      return s;
    }
  }
  Advice a = adviceFor(name, "residual follows " + name, spec, fit, false);
  if (a.trials.empty() && a.words.empty()) genericAdvice(a, name, pr.mean, s.categorical);
  s.advice = a.words;
  const auto scored = scoreTrials(s, trialsFor(s, a, spec), work, fit);
  for (const auto& sc : scored)
    if (!sc.second.empty()) s.effects.push_back(sc.second);
  // the effect the data prefer among the candidates
  if (!s.effects.empty() && a.words_for.count(s.effects.front())) s.advice = a.words_for[s.effects.front()];
  return s;
}

// The significance level of one test among `tested` (Bonferroni).
double alphaFor(std::size_t tested) { return 1e-3 / static_cast<double>(std::max<std::size_t>(tested, 1)); }

// Significance against a Bonferroni level over the tested variables, then the order: causes
// first, tested ones by score; `run` (which file or sweep) is a catch-all after them; then the
// variables not tested.
void orderSuspects(std::vector<Suspect>& out) {
  std::size_t tested = 0;
  for (const auto& s : out) tested += s.tested ? 1 : 0;
  const double alpha = alphaFor(tested);
  for (auto& s : out) s.significant = s.tested && s.p_value < alpha && s.score >= 0.01;
  std::stable_sort(out.begin(), out.end(), [](const Suspect& a, const Suspect& b) {
    if (a.significant != b.significant) return a.significant;
    const bool ar = a.variable == "run", br = b.variable == "run";
    if (ar != br) return br;
    if (a.tested != b.tested) return a.tested;
    return a.score > b.score;
  });
}

// The rows the refits of a ranking run on: all of them, or on big data evenly spaced ones with
// the model refitted there from its optimum.
struct RefitRows {
  Dataset sampled;
  FitResult sampled_fit;
  bool big;
  const Dataset& data;
  const FitResult& fit;
  RefitRows(const Dataset& d, const FitResult& f, const ModelSpec& spec)
      : big(d.rows() > kMaxRankRows),
        data(big ? (sampled = evenlySpaced(d, kMaxRankRows)) : d),
        fit(big ? (sampled_fit = fitModel(sampled, spec, &f.params, /*warm_only=*/true, /*uncertainties=*/false)) : f) {}
};

}  // namespace

void scoreEvidence(const Dataset& data_in, const FitResult& fit_in, const ModelSpec& spec,
                   std::vector<Evidence>& evidence, std::size_t tested) {
  const RefitRows rows(data_in, fit_in, spec);
  const double alpha = alphaFor(tested + evidence.size());
  for (auto& e : evidence) {
    Advice a = adviceFor(e.kind, e.cause, spec, rows.fit, true);
    e.advice = a.words;
    if (a.trials.empty()) continue;
    Suspect s;
    s.variable = e.kind;
    std::vector<std::pair<std::string, ModelSpec>> trials;
    for (const auto& t : a.trials) trials.emplace_back(t, combine(spec, parseSpec(t)));
    // a finding's effects are few: each gets the full search (a cold start too), as the ladder
    for (const auto& sc : scoreTrials(s, trials, rows.data, rows.fit, /*quick=*/false)) e.effects.push_back(sc.second);
    e.score = s.score;
    e.p_value = s.p_value;
    e.significant = s.tested && s.p_value < alpha && s.score >= 0.01;
    if (!e.effects.empty()) e.advice = a.words_for[e.effects.front()];
  }
}

Role roleOf(const std::string& name) {
  const std::string v = csv::lower(name);
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
  const RefitRows rows(data_in, fit_in, spec);
  const Dataset& data = rows.data;
  const FitResult& fit = rows.fit;

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

}  // namespace lab
