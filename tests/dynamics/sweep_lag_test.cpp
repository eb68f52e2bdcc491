// The fast sweep's lag correction (thrustcal/sweep_lag.hpp, issue 26 item 2) against a sweep
// integrated here step by step: the force a curve in pulse width, the motor a first-order lag,
// the load cell three first-order stages, read a fixed settle time after each ESC edge (with the
// frame's jitter in when the edge comes). Independent of lagTail's closed form.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "thrustcal/sweep_lag.hpp"

namespace {

tc::MotorDynamics dynamicsOf(float tau_lo_s, float tau_hi_s) {
  tc::MotorDynamics d;
  d.points = 5;
  d.lo_dg = 1000;
  d.hi_dg = 4000;
  d.up_lo_01ms = tc::secondsTo01ms(tau_lo_s);
  d.up_hi_01ms = tc::secondsTo01ms(tau_hi_s);
  d.down_lo_01ms = d.up_lo_01ms;
  d.down_hi_01ms = d.up_hi_01ms;
  return d;
}

tc::BenchResponse thesisCell() {
  tc::BenchResponse b;
  b.stages = 3;
  b.tau_01ms = 300;
  return b;
}

// Force (g) at pulse width pwm_us: zero below 1100 us, then a quadratic to ~500 g at 1800 us.
double forceAt(int pwm_us) {
  const double x = (pwm_us - 1100) / 700.0;
  return x <= 0 ? 0.0 : 500.0 * x * x;
}

struct Reading {
  double edge_s, read_s, true_g, read_g;
  int pwm_us;
};

// The sweep 1100..1800 us in 10 us steps, `settle_s` per step; Euler at 0.05 ms.
std::vector<Reading> integrateSweep(const tc::MotorDynamics& d, double settle_s) {
  const double dt = 5e-5, tb = 0.030;
  double motor = 0, c1 = 0, c2 = 0, c3 = 0, t = 0;
  std::vector<Reading> out;
  int k = 0;
  for (int pwm = 1100; pwm <= 1800; pwm += 10, ++k) {
    const double edge = t + 0.001 * (k % 7) * 2.5;  // the next frame's edge: 0..15 ms later
    const double target = forceAt(pwm);
    const double end = t + settle_s;
    for (; t < end; t += dt) {
      if (t >= edge) {
        // the speed lags with the law's tau; force = speed^2, so the force's small-step lag is tau/2
        // in speed terms: integrate the speed and square it
        const double tau = d.tauUpS(static_cast<float>(motor > 1 ? motor : 1));
        double w = std::sqrt(motor);
        w += dt / tau * (std::sqrt(target) - w);
        motor = w * w;
      }
      c1 += dt / tb * (motor - c1);
      c2 += dt / tb * (c1 - c2);
      c3 += dt / tb * (c2 - c3);
    }
    out.push_back({edge, t, target, c3, pwm});
  }
  return out;
}

struct Errors {
  double raw_max_pct = 0, corrected_max_pct = 0;
};

Errors correctAndCompare(const std::vector<Reading>& sweep, const tc::MotorDynamics& d) {
  tc::SweepLagCorrector c;
  c.start(d, thesisCell());
  std::vector<tc::SweepPointV2> corrected;
  tc::SweepPointV2 p;
  for (const Reading& r : sweep) {
    const tc::SweepPointV2 raw{static_cast<uint16_t>(r.pwm_us), static_cast<int16_t>(std::lround(r.read_g * 10)), 11000};
    if (c.push(static_cast<float>(r.edge_s), static_cast<float>(r.read_s), raw, p)) corrected.push_back(p);
  }
  EXPECT_TRUE(c.finish(p));
  corrected.push_back(p);
  EXPECT_FALSE(c.finish(p));
  EXPECT_EQ(corrected.size(), sweep.size());
  Errors e;
  for (std::size_t i = 0; i < sweep.size(); ++i) {
    if (sweep[i].true_g < 100 || i + 1 == sweep.size()) continue;  // 100 g up; the last has no slope after it
    EXPECT_EQ(corrected[i].pwm_us, sweep[i].pwm_us);
    e.raw_max_pct = std::max(e.raw_max_pct, 100 * std::fabs(sweep[i].read_g / sweep[i].true_g - 1));
    e.corrected_max_pct = std::max(e.corrected_max_pct, 100 * std::fabs(corrected[i].force_dg / 10.0 / sweep[i].true_g - 1));
  }
  return e;
}

}  // namespace

TEST(SweepLag, TailIsOneAtTheEdgeFallsMonotonicallyAndItsAreaIsTheMeanDelay) {
  const tc::BenchResponse cell = thesisCell();
  for (float tau : {0.020f, 0.030f, 0.032f, 0.080f, 0.150f}) {
    SCOPED_TRACE(tau);
    EXPECT_FLOAT_EQ(tc::lagTail(0.0f, tau, cell), 1.0f);
    float last = 1.0f, area = 0.0f;
    const float dt = 1e-4f;
    for (float t = dt / 2; t < 3.0f; t += dt) {
      const float g = tc::lagTail(t, tau, cell);
      EXPECT_LE(g, last + 1e-6f);
      last = g;
      area += g * dt;
    }
    // the area under 1 - g is the path's mean delay: the motor's tau and the cell's 3 x 30 ms
    EXPECT_NEAR(area, tau + 0.090f, 0.002f);
  }
  // without a bench response: the motor alone
  EXPECT_NEAR(tc::lagTail(0.08f, 0.08f, tc::BenchResponse()), std::exp(-1.0f), 1e-6f);
}

TEST(SweepLag, Corrects200And100MsSweepsToWithinAFractionOfAPercent) {
  const tc::MotorDynamics d = dynamicsOf(0.090f, 0.075f);
  for (double settle_s : {0.2, 0.1}) {
    SCOPED_TRACE(settle_s);
    const Errors e = correctAndCompare(integrateSweep(d, settle_s), d);
    // the raw readings trail the motor by several percent, the corrected by a fraction of one
    EXPECT_GT(e.raw_max_pct, 2.0);
    EXPECT_LT(e.corrected_max_pct, settle_s > 0.15 ? 0.3 : 1.0) << "raw " << e.raw_max_pct << " %";
  }
}

TEST(SweepLag, WithoutDynamicsNothingMoves) {
  const tc::MotorDynamics none;
  tc::SweepLagCorrector c;
  c.start(none, thesisCell());
  tc::SweepPointV2 out;
  EXPECT_FALSE(c.push(0.00f, 0.2f, {1500, 2000, 11000}, out));
  ASSERT_TRUE(c.push(0.21f, 0.4f, {1510, 2100, 11000}, out));
  EXPECT_EQ(out.force_dg, 2000);
  ASSERT_TRUE(c.finish(out));
  EXPECT_EQ(out.force_dg, 2100);
  EXPECT_EQ(c.largestCorrectionDg(), 0);
}
