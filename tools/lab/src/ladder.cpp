// The diagnosis and the ladder as a whole: a fit, its ranked variables and its assessment; the
// ladder that adds effects one by one, each judged by BIC and its parameters' bounds; hold-out
// validation; and the force that falls while the drive rises.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

#include "lab/analysis.hpp"
#include "lab/stats.hpp"

namespace lab {

namespace {

constexpr double kNoScore = std::numeric_limits<double>::quiet_NaN();  // no hold-out asked

}  // namespace

std::vector<std::string> boundsOf(const FitResult& fit, const std::string& effect) {
  std::vector<std::string> out;
  for (const auto& p : fit.params)
    if (p.effect == effect && p.at_bound) out.push_back(fmt::format("{} at its bound {:.4g}", p.name, p.bound));
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
  if (kind == Holdout::kNone) return kNoScore;
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
  static_cast<Assessment&>(d) = assess(data, spec, d.fit, d.variables);
  d.holdout_rmse_g = holdoutRmse(data, spec, holdout, &d.holdout_groups);
  return d;
}

LadderStep addStep(const Dataset& data, const LadderStep& prev, const std::string& add, Holdout holdout) {
  LadderStep step;
  step.added = add;
  const ModelSpec added = parseSpec(add);
  step.spec = combine(prev.spec, added);
  step.fit = fitModel(data, step.spec, &prev.fit.params, false, true, prev.fit.rss);
  step.holdout_rmse_g = holdoutRmse(data, step.spec, holdout);
  step.delta_bic = step.fit.bic - prev.fit.bic;
  step.delta_aic = step.fit.aic - prev.fit.aic;
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
  return step;
}

std::vector<LadderStep> ladder(const Dataset& data, const ModelSpec& base,
                               const std::vector<std::string>& adds, Holdout holdout) {
  std::vector<LadderStep> steps;
  const NoiseEstimate noise = estimateNoise(data);
  for (std::size_t s = 0; s <= adds.size(); ++s) {
    LadderStep step;
    if (s == 0) {
      step.spec = base;
      step.fit = fitModel(data, base);
      step.holdout_rmse_g = holdoutRmse(data, base, holdout);
      step.verdict = "start";
    } else {
      step = addStep(data, steps.back(), adds[s - 1], holdout);
    }
    // the diagnosis of the first and the last step (the report and the text use those)
    if (s == 0 || s == adds.size()) step.variables = rankVariables(data, step.fit, step.spec);
    step.at_noise_floor = atNoiseFloor(noise, step.fit);
    step.assessment.noise = noise;
    if (s == adds.size()) step.assessment = assess(data, step.spec, step.fit, step.variables, &noise);
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
                     "(a current limit, a saturated ESC or a stall: `thrustcal lab diagnose` tells which from the "
                     "current and the speed); a curve that only rises cannot follow it: model the limit, or fit below "
                     "it with --where 'pwm_us < {:.0f}'",
                     c.run, c.peak_force_g, c.peak_pwm_us, c.top_force_g, c.top_pwm_us, c.peak_pwm_us);
}

}  // namespace lab
