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
  } else if (v == "dir") {
    pick({"lag"});
    a.words = "up and down sweeps differ: the motor speed lags the command; add `lag`";
  } else if (startsWith(v, "rpm") || v.find("speed") != std::string::npos) {
    pick({"voltage", "sag", "density"});
    a.words = var + " is the motor's response, not a condition: it follows whatever the drive model misses, so it is not ranked as a suspect";
  } else {
    const std::string expr = fmt::format("mul: 1 + a*({} - {:.4g})", var, mean);
    a.effects = {expr};
    a.words = "residual follows " + var + ", which no catalogue effect covers; try `" + expr + "`";
  }
  return a;
}

// R^2 and p-value of the residual regressed on X (with intercept in X) against the null design X0.
void nestedTest(const Eigen::MatrixXd& X0, const Eigen::MatrixXd& X1, const Eigen::VectorXd& r,
                double& score, double& p) {
  const double n = static_cast<double>(r.size());
  auto rssOf = [&](const Eigen::MatrixXd& X) {
    const Eigen::VectorXd b = X.colPivHouseholderQr().solve(r);
    return (r - X * b).squaredNorm();
  };
  const double rss0 = rssOf(X0);
  const double rss1 = rssOf(X1);
  const double q = static_cast<double>(X1.cols() - X0.cols());
  const double dof = n - static_cast<double>(X1.cols());
  // The fraction of the residual explained, penalised for the variable's degrees of freedom the
  // way BIC is (1 - exp(dBIC / n)): a variable with many levels (run) does not outrank one
  // with few (motor) that explains as much.
  score = rss0 > 0 ? std::max(0.0, 1.0 - (rss1 / rss0) * std::exp(q * std::log(n) / n)) : 0.0;
  if (dof <= 0 || q <= 0 || rss1 <= 0) {
    p = rss1 <= 0 && rss0 > 0 ? 0.0 : 1.0;
    return;
  }
  const double F = ((rss0 - rss1) / q) / (rss1 / dof);
  p = fSurvival(F, q, dof);
}

}  // namespace

bool isOutcome(const std::string& name) {
  const std::string v = lowerCopy(name);
  return startsWith(v, "rpm") || v.find("speed") != std::string::npos;
}

std::vector<Suspect> rankVariables(const Dataset& data, const FitResult& fit, const ModelSpec& spec) {
  std::vector<std::pair<std::string, std::vector<double>>> candidates;
  for (std::size_t c = 0; c < data.names.size(); ++c)
    if (data.names[c] != "force_g" && data.names[c] != "run") candidates.emplace_back(data.names[c], data.columns[c]);
  if (data.runs() > 1) {
    std::vector<double> run(data.run.begin(), data.run.end());
    candidates.emplace_back("run", run);
  }
  const Eigen::Index n_all = static_cast<Eigen::Index>(data.rows());
  double fscale = 0;
  for (double v : fit.predicted_g)
    if (std::isfinite(v)) fscale = std::max(fscale, std::abs(v));
  if (fscale <= 0) fscale = 1;

  std::vector<Suspect> out;
  for (const auto& [name, z] : candidates) {
    std::vector<Eigen::Index> rows;
    for (Eigen::Index i = 0; i < n_all; ++i)
      if (std::isfinite(z[static_cast<std::size_t>(i)]) && std::isfinite(fit.residual_g[static_cast<std::size_t>(i)]))
        rows.push_back(i);
    if (rows.size() < 12) continue;
    std::set<double> distinct;
    bool integral = true;
    double sum = 0;
    for (auto i : rows) {
      const double v = z[static_cast<std::size_t>(i)];
      if (distinct.size() <= 17) distinct.insert(v);
      integral = integral && v == std::round(v);
      sum += v;
    }
    if (distinct.size() < 2) continue;
    const Eigen::Index n = static_cast<Eigen::Index>(rows.size());
    const double mean = sum / static_cast<double>(n);
    Eigen::VectorXd r(n), f(n), zz(n);
    for (Eigen::Index k = 0; k < n; ++k) {
      const auto i = static_cast<std::size_t>(rows[static_cast<std::size_t>(k)]);
      r[k] = fit.residual_g[i];
      f[k] = fit.predicted_g[i] / fscale;
      zz[k] = z[i];
    }
    Suspect s;
    s.variable = name;
    s.outcome = isOutcome(name);
    const bool categorical = (integral && distinct.size() <= 16) || distinct.size() <= 3;
    s.categorical = categorical;
    Eigen::MatrixXd X0(n, 2);
    X0.col(0).setOnes();
    X0.col(1) = f;
    Eigen::MatrixXd X1;
    if (categorical) {
      // per level its own offset and its own gain on the predicted force
      std::vector<double> levels(distinct.begin(), distinct.end());
      const Eigen::Index g = static_cast<Eigen::Index>(levels.size());
      if (n < 3 * g) continue;
      X1.resize(n, 3 * g);
      X1.setZero();
      for (Eigen::Index k = 0; k < n; ++k) {
        const auto li = std::lower_bound(levels.begin(), levels.end(), zz[k]) - levels.begin();
        X1(k, li) = 1;
        X1(k, g + li) = f[k];
        X1(k, 2 * g + li) = f[k] * f[k];
      }
    } else {
      double var = 0;
      for (Eigen::Index k = 0; k < n; ++k) var += (zz[k] - mean) * (zz[k] - mean);
      const double sd = std::sqrt(var / static_cast<double>(n));
      if (!(sd > 0)) continue;
      const Eigen::VectorXd u = (zz.array() - mean) / sd;
      // additive (cubic in z) and multiplicative (force times quadratic in z) dependence
      // r ~ A(z) + f B(z) + f^2 C(z): additive (cubic), multiplicative (quadratic) and a
      // multiplicative part that grows with the force (linear)
      X1.resize(n, 8);
      X1.col(0).setOnes();
      X1.col(1) = f;
      X1.col(2) = u;
      X1.col(3) = u.cwiseProduct(u);
      X1.col(4) = X1.col(3).cwiseProduct(u);
      X1.col(5) = f.cwiseProduct(u);
      X1.col(6) = f.cwiseProduct(X1.col(3));
      X1.col(7) = f.cwiseProduct(f).cwiseProduct(u);
    }
    nestedTest(X0, X1, r, s.score, s.p_value);
    const Advice a = adviceFor(name, mean, spec);
    s.effects = a.effects;
    s.advice = a.words;
    out.push_back(s);
  }
  const double alpha = 1e-3 / std::max<std::size_t>(out.size(), 1);
  for (auto& s : out) s.significant = s.p_value < alpha && s.score >= 0.01 && !s.outcome;
  std::stable_sort(out.begin(), out.end(), [](const Suspect& a, const Suspect& b) {
    if (a.significant != b.significant) return a.significant;
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
    step.fit = fitModel(data, spec);
    step.variables = rankVariables(data, step.fit, spec);
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
