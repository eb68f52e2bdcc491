// The swap experiment's step-response figures (sim/step_metrics.hpp) against responses whose
// figures are known in closed form: a first-order lag, an underdamped second-order system, and
// responses that never settle (NaN, never a guess).
#include "sim/step_metrics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <stdexcept>
#include <vector>

namespace {

constexpr double kStepPi = 3.14159265358979323846;

// A response sampled every `dt_s` from -0.2 s (at y = 0 before the step) to `end_s`.
struct StepSeries {
  std::vector<double> t, y;
};
StepSeries sampledStep(const std::function<double(double)>& after, double end_s, double dt_s = 0.001) {
  StepSeries s;
  const long n_before = std::lround(0.2 / dt_s), n_after = std::lround(end_s / dt_s);
  for (long i = -n_before; i <= n_after; ++i) {
    const double t = static_cast<double>(i) * dt_s;
    s.t.push_back(t);
    s.y.push_back(t < 0 ? 0.0 : after(t));
  }
  return s;
}

// The first time `f` (rising from below `level` at t = 0) reaches `level`, by bisection between
// `lo` and `hi` (f(lo) < level <= f(hi)).
double stepCrossing(const std::function<double(double)>& f, double level, double lo, double hi) {
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (f(mid) < level ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

TEST(StepMetrics, FirstOrderLagHasItsClosedFormFigures) {
  // given: 10 (1 - e^(-t / tau)), tau = 0.1 s, 3 s long (the final value is 10 to 1e-12)
  const double tau = 0.1;
  const auto f = [tau](double t) { return 10.0 * (1.0 - std::exp(-t / tau)); };
  const StepSeries s = sampledStep(f, 3.0);
  sim::StepSpec spec;
  spec.y0 = 0;
  spec.target = 10;
  // when
  const sim::StepMetrics m = sim::stepMetrics(s.t, s.y, spec);
  // then: rise 10-90 % = tau ln 9, no overshoot, 2 % settling = tau ln 50, no error left,
  // ITAE = integral of t 10 e^(-t/tau) = 10 tau^2
  EXPECT_NEAR(m.final_value, 10.0, 1e-9);
  EXPECT_NEAR(m.rise_s, tau * std::log(9.0), 1e-5);
  EXPECT_NEAR(m.overshoot_pct, 0.0, 1e-6);  // the final value is a mean: 1e-11 below the end
  EXPECT_NEAR(m.settling_s, tau * std::log(50.0), 1e-4);
  EXPECT_NEAR(m.sse, 0.0, 1e-9);
  EXPECT_NEAR(m.itae, 10.0 * tau * tau, 1e-5);
  EXPECT_NEAR(m.peak, 10.0, 1e-9);
}

TEST(StepMetrics, SecondOrderOvershootRiseAndSettlingAreTheSystemsOwn) {
  // given: a unit step of w^2 / (s^2 + 2 zeta w s + w^2), zeta 0.5, w 10 rad/s, 8 s long;
  // its overshoot is exp(-pi zeta / sqrt(1 - zeta^2)) = 16.3 %
  const double zeta = 0.5, w = 10.0, wd = w * std::sqrt(1 - zeta * zeta);
  const auto f = [=](double t) {
    return 1.0 - std::exp(-zeta * w * t) / std::sqrt(1 - zeta * zeta) * std::sin(wd * t + std::acos(zeta));
  };
  const StepSeries s = sampledStep(f, 8.0);
  sim::StepSpec spec;
  spec.target = 1.0;
  // when
  const sim::StepMetrics m = sim::stepMetrics(s.t, s.y, spec);
  // then: the overshoot and peak in closed form; the rise time from the function itself (first
  // crossings of 0.1 and 0.9 before the peak at pi / wd)
  const double overshoot = std::exp(-kStepPi * zeta / std::sqrt(1 - zeta * zeta));
  EXPECT_NEAR(m.overshoot_pct, 100.0 * overshoot, 0.01);
  EXPECT_NEAR(m.peak, 1.0 + overshoot, 1e-4);
  const double peak_t = kStepPi / wd;
  EXPECT_NEAR(m.rise_s, stepCrossing(f, 0.9, 0, peak_t) - stepCrossing(f, 0.1, 0, peak_t), 1e-5);
  // the 2 % band is last entered where the function itself last leaves it (found on a 10 us
  // grid), before the envelope e^(-zeta w t) / sqrt(1 - zeta^2) falls to 2 % (0.811 s)
  double last_out = 0;
  for (double t = 0; t < 3.0; t += 1e-5)
    if (std::fabs(f(t) - 1.0) > 0.02) last_out = t;
  EXPECT_NEAR(m.settling_s, last_out, 1e-3);
  EXPECT_LT(m.settling_s, std::log(1.0 / (0.02 * std::sqrt(1 - zeta * zeta))) / (zeta * w));
  for (std::size_t i = 0; i < s.t.size(); ++i) {
    if (s.t[i] > m.settling_s + 0.002) {
      ASSERT_LE(std::fabs(s.y[i] - m.final_value), 0.02 + 1e-9) << s.t[i];
    }
  }
  EXPECT_NEAR(m.sse, 0.0, 1e-6);
}

TEST(StepMetrics, SteadyStateErrorIsWhatTheLoopLeavesOfTheCommand) {
  // given: a lag that ends at 8.3 when 10 was commanded (a PD loop against a pendulum)
  const StepSeries s = sampledStep([](double t) { return 8.3 * (1.0 - std::exp(-t / 0.05)); }, 2.0);
  sim::StepSpec spec;
  spec.target = 10;
  // when
  const sim::StepMetrics m = sim::stepMetrics(s.t, s.y, spec);
  // then: sse against the command; rise and settling against the response's own final value
  EXPECT_NEAR(m.sse, 1.7, 1e-6);
  EXPECT_NEAR(m.rise_s, 0.05 * std::log(9.0), 1e-5);
  EXPECT_NEAR(m.settling_s, 0.05 * std::log(50.0), 1e-4);
  // ITAE integrates |10 - y|: the 1.7 left grows as t^2 / 2 over the 2 s
  EXPECT_GT(m.itae, 1.7 * 2.0 * 2.0 / 2.0);
}

TEST(StepMetrics, AResponseThatNeverSettlesHasNoSettlingTime) {
  // given: a lag with a 2 Hz oscillation of amplitude 2 that never dies, ending on a crest, and
  // a ramp that never stops
  const StepSeries ringing = sampledStep(
      [](double t) {
        return 10.0 * (1.0 - std::exp(-t / 0.1)) + 2.0 * std::sin(2 * kStepPi * 2.0 * t + kStepPi / 2);
      },
      2.0);
  const StepSeries ramp = sampledStep([](double t) { return 10.0 * t; }, 2.0);
  sim::StepSpec spec;
  spec.target = 10;
  // when
  const sim::StepMetrics m_ringing = sim::stepMetrics(ringing.t, ringing.y, spec);
  const sim::StepMetrics m_ramp = sim::stepMetrics(ramp.t, ramp.y, spec);
  // then: NaN, never a guess; the other figures still there
  EXPECT_TRUE(std::isnan(m_ringing.settling_s));
  EXPECT_TRUE(std::isnan(m_ramp.settling_s));
  EXPECT_GT(m_ringing.overshoot_pct, 0.0);
  EXPECT_FALSE(std::isnan(m_ramp.rise_s));
}

TEST(StepMetrics, RefusesSeriesItCannotMeasure) {
  sim::StepSpec spec;
  spec.target = 1;
  EXPECT_THROW(sim::stepMetrics({0, 1, 2}, {0, 1}, spec), std::invalid_argument);           // unequal
  EXPECT_THROW(sim::stepMetrics({0, 2, 1, 3}, {0, 1, 1, 1}, spec), std::invalid_argument);  // unordered
  EXPECT_THROW(sim::stepMetrics({-1, 0, 1}, {0, 1, 1}, spec), std::invalid_argument);  // 2 after the step
  EXPECT_THROW(sim::stepMetrics({0, 1, 2, 3}, {0, 0, 0, 0}, spec), std::invalid_argument);  // no step
}

TEST(StepMetrics, MeanSpreadIsTheSpreadOfTheChannelsMeans) {
  // given: four pulses, motor 2 10 us above the rest on average in the window, noise around it
  const std::vector<double> t = {-0.3, -0.2, -0.1, 0.0, 0.1};
  const std::vector<std::vector<double>> rows = {{0, 0, 0, 0},
                                                 {1500, 1502, 1510, 1500},
                                                 {1500, 1498, 1510, 1500},
                                                 {1500, 1500, 1510, 1500},
                                                 {0, 0, 0, 0}};
  // when / then: the rows at -0.3 and 0.1 are outside [-0.25, 0]
  EXPECT_DOUBLE_EQ(sim::meanSpread(t, rows, -0.25, 0.0), 10.0);
  EXPECT_THROW(sim::meanSpread(t, rows, 1.0, 2.0), std::invalid_argument);
}

}  // namespace
