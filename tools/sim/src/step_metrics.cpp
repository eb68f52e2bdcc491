// Step-response figures: see sim/step_metrics.hpp.
#include "sim/step_metrics.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace sim {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void checkSeries(const std::vector<double>& t_s, const std::vector<double>& y) {
  if (t_s.size() != y.size())
    throw std::invalid_argument(fmt::format("step metrics: {} times but {} values", t_s.size(), y.size()));
  std::size_t after = 0;
  for (std::size_t i = 0; i < t_s.size(); ++i) {
    if (i && !(t_s[i] > t_s[i - 1]))
      throw std::invalid_argument(fmt::format(
          "step metrics: time does not increase at sample {} ({} after {})", i, t_s[i], t_s[i - 1]));
    after += t_s[i] >= 0;
  }
  if (after < 3)
    throw std::invalid_argument(
        fmt::format("step metrics: {} samples after the step; at least 3 needed", after));
}

// The time the response first reaches `level` going in direction `dir` (+1 up, -1 down), from
// t >= 0; NaN when it never does.
double firstCrossing(const std::vector<double>& t, const std::vector<double>& y, double level, double dir) {
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (t[i] < 0 || dir * (y[i] - level) < 0) continue;
    if (i == 0) return t[i];
    const double before = y[i - 1];
    const double at = dir * (before - level) < 0
                          ? t[i - 1] + (t[i] - t[i - 1]) * (level - before) / (y[i] - before)
                          : t[i - 1];
    return std::max(at, 0.0);
  }
  return kNaN;
}

// When |y - final| enters the band for good (interpolated); 0 if it never leaves it after the
// step, NaN if it is outside at the end.
double settlingTime(const std::vector<double>& t, const std::vector<double>& y, double final_value,
                    double band) {
  std::size_t last_out = t.size();
  for (std::size_t i = 0; i < t.size(); ++i)
    if (t[i] >= 0 && std::fabs(y[i] - final_value) > band) last_out = i;
  if (last_out == t.size()) return 0.0;
  if (last_out + 1 == t.size()) return kNaN;
  const double e0 = std::fabs(y[last_out] - final_value), e1 = std::fabs(y[last_out + 1] - final_value);
  const double frac = e0 > e1 ? (e0 - band) / (e0 - e1) : 1.0;
  return t[last_out] + (t[last_out + 1] - t[last_out]) * std::clamp(frac, 0.0, 1.0);
}

// The integral of t |target - y| dt from t = 0 (trapezoids; the first interval clipped at 0).
double itaeOf(const std::vector<double>& t, const std::vector<double>& y, double target) {
  double sum = 0;
  for (std::size_t i = 1; i < t.size(); ++i) {
    if (t[i] <= 0) continue;
    const double ta = std::max(t[i - 1], 0.0);
    const double fa = ta * std::fabs(target - y[i - 1]), fb = t[i] * std::fabs(target - y[i]);
    sum += 0.5 * (fa + fb) * (t[i] - ta);
  }
  return sum;
}

}  // namespace

StepMetrics stepMetrics(const std::vector<double>& t_s, const std::vector<double>& y, const StepSpec& spec) {
  checkSeries(t_s, y);
  StepMetrics m;
  const double t_end = t_s.back();
  double sum = 0;
  int n = 0;
  for (std::size_t i = 0; i < t_s.size(); ++i)
    if (t_s[i] >= 0 && t_s[i] >= t_end - spec.final_window_s) sum += y[i], ++n;
  m.final_value = sum / n;
  const double amplitude = m.final_value - spec.y0;
  if (amplitude == 0)
    throw std::invalid_argument("step metrics: the response ends where it started (no step)");
  const double dir = amplitude > 0 ? 1.0 : -1.0;
  const double lo = firstCrossing(t_s, y, spec.y0 + spec.rise_low * amplitude, dir);
  const double hi = firstCrossing(t_s, y, spec.y0 + spec.rise_high * amplitude, dir);
  m.rise_s = hi - lo;  // NaN when either never came
  m.peak = spec.y0;
  for (std::size_t i = 0; i < t_s.size(); ++i)
    if (t_s[i] >= 0 && dir * (y[i] - m.peak) > 0) m.peak = y[i];
  m.overshoot_pct = std::max(0.0, 100.0 * (m.peak - m.final_value) / amplitude);
  m.settling_s = settlingTime(t_s, y, m.final_value, spec.settle_band * std::fabs(amplitude));
  m.sse = std::fabs(spec.target - m.final_value);
  m.itae = itaeOf(t_s, y, spec.target);
  return m;
}

double meanSpread(const std::vector<double>& t_s, const std::vector<std::vector<double>>& rows, double from_s,
                  double to_s) {
  std::vector<double> sum;
  int n = 0;
  for (std::size_t i = 0; i < t_s.size() && i < rows.size(); ++i) {
    if (t_s[i] < from_s || t_s[i] > to_s) continue;
    if (sum.empty()) sum.assign(rows[i].size(), 0.0);
    for (std::size_t c = 0; c < sum.size(); ++c) sum[c] += rows[i].at(c);
    ++n;
  }
  if (n == 0 || sum.empty())
    throw std::invalid_argument(
        fmt::format("no sample between {:.3f} s and {:.3f} s for the pulse spread", from_s, to_s));
  const auto [lo, hi] = std::minmax_element(sum.begin(), sum.end());
  return (*hi - *lo) / n;
}

}  // namespace sim
