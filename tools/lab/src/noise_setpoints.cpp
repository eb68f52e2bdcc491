// The noise floor where a log repeats a set point: the pooled scatter of the readings within each
// set point's steady part (pure error), with the noise's correlation between successive samples
// measured, and the lack-of-fit F test of a model against it. See noise.hpp.
//
// A set point's readings settle from the step into it: fitted as an exponential decay toward its
// level, the steady part starts where the decay is under half the noise; the scatter is taken
// about the fitted curve there (a tail of the decay longer than the hold does not count as noise).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "lab/noise.hpp"
#include "lab/stats.hpp"
#include "lab/steps.hpp"
#include "noise_rows.hpp"

namespace lab {

namespace {

constexpr std::size_t kMinSteadyRows = 8;     // of them, steady
constexpr double kSteadyShare = 0.5;          // steady once the settling is under this share of the noise
constexpr int kSettlingGrid = 40;             // time constants tried for a set point's settling
constexpr std::size_t kMinPureDof = 30;       // pooled degrees of freedom before pure error is used

// A set point's settling: its readings as level + amplitude * exp(-k / tau) over the block's
// samples k (the response to the step into it), tau from a geometric grid, level and amplitude
// by least squares.
struct Settling {
  double level = 0, amplitude = 0, tau = 1, sigma = 0;
  double at(std::size_t k) const { return level + amplitude * std::exp(-static_cast<double>(k) / tau); }
};

Settling settlingOf(const std::vector<double>& y) {
  const std::size_t n = y.size();
  Settling best;
  double best_rss = -1;
  for (int g = 0; g <= kSettlingGrid; ++g) {
    const double tau = 0.5 * std::pow(static_cast<double>(n), static_cast<double>(g) / kSettlingGrid);
    double s1 = 0, se = 0, see = 0, sy = 0, sey = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const double ek = std::exp(-static_cast<double>(k) / tau);
      s1 += 1, se += ek, see += ek * ek, sy += y[k], sey += ek * y[k];
    }
    const double det = s1 * see - se * se;
    if (!(det > 1e-12 * s1 * see)) continue;
    Settling c;
    c.tau = tau;
    c.level = (see * sy - se * sey) / det;
    c.amplitude = (s1 * sey - se * sy) / det;
    double rss = 0;
    for (std::size_t k = 0; k < n; ++k) rss += (y[k] - c.at(k)) * (y[k] - c.at(k));
    if (best_rss < 0 || rss < best_rss) best_rss = rss, best = c;
  }
  best.sigma = std::sqrt(std::max(best_rss, 0.0) / static_cast<double>(n - 3));
  return best;
}

// Where the steady part starts: once the fitted settling is under half the noise.
std::size_t steadyStart(const Settling& s, std::size_t n) {
  const double a = std::fabs(s.amplitude);
  if (!(a > kSteadyShare * s.sigma)) return 0;
  return std::min(n, static_cast<std::size_t>(std::ceil(s.tau * std::log(a / (kSteadyShare * s.sigma)))));
}

}  // namespace

NoiseEstimate pureErrorNoise(const Dataset& data) {
  NoiseEstimate out;
  out.method = "pure_error";
  if (!data.has("pwm_us") || !data.has("force_g")) {
    out.why_not = "the data have no pwm_us or force_g";
    return out;
  }
  const auto& f = data.col("force_g");
  const auto blocks = setpointBlocks(data);
  out.setpoint_of_row.assign(data.rows(), -1);
  double ss = 0, c1 = 0, sd2 = 0, dof = 0;
  for (const auto& b : blocks) {
    std::vector<double> y;
    for (std::size_t i : b) y.push_back(f[i]);
    const Settling settling = settlingOf(y);
    const std::size_t start = steadyStart(settling, y.size());
    out.setpoint_rows += b.size();
    if (b.size() - start < kMinSteadyRows) continue;
    // the steady rows about the settling curve (what is left of it there is under half the noise)
    std::vector<double> e;
    for (std::size_t k = start; k < y.size(); ++k) e.push_back(y[k] - settling.at(k));
    double mean = 0;
    for (double v : e) mean += v / static_cast<double>(e.size());
    for (std::size_t k = 0; k < e.size(); ++k) {
      ss += (e[k] - mean) * (e[k] - mean);
      if (k + 1 < e.size()) {
        c1 += (e[k] - mean) * (e[k + 1] - mean);
        sd2 += (e[k + 1] - e[k]) * (e[k + 1] - e[k]);
      }
      out.setpoint_of_row[b[start + k]] = static_cast<int>(out.setpoints);
    }
    ++out.setpoints;
    out.steady_rows += e.size();
    dof += static_cast<double>(e.size() - 1);
  }
  if (out.setpoints < 2 || dof < static_cast<double>(kMinPureDof) || !(ss > 0)) {
    out.why_not = fmt::format("no repeated set points: {} block(s) of at least {} rows at one PWM with {} steady "
                              "rows each",
                              out.setpoints, kMinSetpointRows, kMinSteadyRows);
    out.setpoint_of_row.clear();
    return out;
  }
  // The samples of a set point correlate (a filter, vibration): the scatter about a set point's own
  // mean misses the variance of that mean, (1 + r) / (1 - r) / n of the noise's for an AR(1) noise.
  out.lag1 = std::clamp(c1 / ss, 0.0, noise_rows::kMaxLag1);
  const double vif = (1 + out.lag1) / (1 - out.lag1);
  const double rows_minus_means = dof + static_cast<double>(out.setpoints) * (1 - vif);
  out.sigma_g = std::sqrt(ss / std::max(rows_minus_means, 1.0));
  out.successive_g = std::sqrt(sd2 / (2 * dof));
  // a variance from correlated samples carries fewer degrees of freedom: (1 - r^2) / (1 + r^2)
  out.dof = dof * (1 - out.lag1 * out.lag1) / (1 + out.lag1 * out.lag1);
  out.lo_g = out.sigma_g * std::sqrt(out.dof / chiSquareQuantile(0.975, out.dof));
  out.hi_g = out.sigma_g * std::sqrt(out.dof / chiSquareQuantile(0.025, out.dof));
  out.assumption = fmt::format(
      "the force is steady within each set point's steady part ({} rows of {} in {} set points: the settling at "
      "the start of each left out until it is under half the noise, fitted as an exponential decay, and what is left "
      "of it taken out), so the scatter there is the noise; successive samples correlate (lag-1 autocorrelation "
      "{:.2f}), taken into account as an AR(1) noise",
      out.steady_rows, out.setpoint_rows, out.setpoints, out.lag1);
  return out;
}

LackOfFit lackOfFit(const NoiseEstimate& noise, const std::vector<double>& residual_g, int params) {
  LackOfFit lof;
  if (noise.method != "pure_error" || !noise.known() || noise.setpoint_of_row.size() != residual_g.size()) {
    lof.why_not = "no repeated set points";
    return lof;
  }
  std::vector<double> sum(noise.setpoints, 0.0), count(noise.setpoints, 0.0);
  for (std::size_t i = 0; i < residual_g.size(); ++i) {
    const int b = noise.setpoint_of_row[i];
    if (b < 0 || !std::isfinite(residual_g[i])) continue;
    sum[static_cast<std::size_t>(b)] += residual_g[i];
    count[static_cast<std::size_t>(b)] += 1;
  }
  // Under the model, a set point's mean residual has the variance of a mean of correlated samples.
  const double vif = (1 + noise.lag1) / (1 - noise.lag1);
  double between = 0, weighted = 0, inverse_counts = 0;
  for (std::size_t b = 0; b < sum.size(); ++b) {
    if (count[b] == 0) continue;
    const double mean = sum[b] / count[b];
    weighted += count[b] * mean * mean;
    between += mean * mean;
    inverse_counts += 1 / count[b];
  }
  lof.setpoint_rms_g = std::sqrt(between / static_cast<double>(noise.setpoints));
  lof.dof1 = static_cast<double>(noise.setpoints) - params;
  lof.dof2 = noise.dof;
  if (lof.dof1 < 1) {
    lof.why_not = fmt::format("{} set points for {} parameters: nothing left to test the fit with", noise.setpoints,
                              params);
    return lof;
  }
  lof.tested = true;
  lof.f = weighted / lof.dof1 / (noise.sigma_g * noise.sigma_g * vif);
  lof.p_value = fSurvival(lof.f, lof.dof1, lof.dof2);
  lof.significant = lof.p_value < kLackOfFitAlpha;
  // what the means miss beyond what their noise explains
  const double m = static_cast<double>(noise.setpoints);
  const double noise_of_means = noise.sigma_g * noise.sigma_g * vif * inverse_counts / m;
  lof.excess_g = std::sqrt(std::max(0.0, between / m - noise_of_means));
  lof.text = fmt::format("the set points' mean readings miss the model by {:.3g} g RMS (lack of fit F = {:.3g} "
                         "with {:.0f} and {:.0f} dof, p = {:.2g}): {}",
                         lof.setpoint_rms_g, lof.f, lof.dof1, lof.dof2, lof.p_value,
                         lof.significant ? "more than the noise explains" : "within the noise");
  return lof;
}

}  // namespace lab
