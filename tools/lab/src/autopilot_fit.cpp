// Least-squares fits of the three autopilots' thrust models (lab/autopilot.hpp).
//
// Every model is full_g * fraction(pwm, V) with the autopilot's own fraction(). The full thrust
// comes out of a linear solve; for ArduPilot and PX4 so does the curve parameter (for fixed
// endpoints their force is linear in (full (1 - e), full e)), constrained to the parameter's
// range; the endpoints are searched (grid, then golden section, or for integer parameters a
// pattern search). Betaflight's inverse curve is not linear in thrust_linear: it is searched
// the same way, each value with its best motor_idle. Where the data cannot tell two endpoint values apart (no row above the top one), the
// autopilot's default wins the tie.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "lab/autopilot.hpp"

namespace lab::autopilot {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTieTolerance = 1e-3;  // relative RSS within which a default endpoint wins

double roundTo(double v, double step) { return std::round(v / step) * step; }

// Golden-section minimum of f on [a, b].
template <typename F>
double golden(double a, double b, F f, int iterations = 40) {
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double x1 = b - g * (b - a), x2 = a + g * (b - a);
  double f1 = f(x1), f2 = f(x2);
  for (int i = 0; i < iterations; ++i) {
    if (f1 < f2) {
      b = x2, x2 = x1, f2 = f1, x1 = b - g * (b - a), f1 = f(x1);
    } else {
      a = x1, x1 = x2, f1 = f2, x2 = a + g * (b - a), f2 = f(x2);
    }
  }
  return 0.5 * (a + b);
}

// The integer in [lo, hi] where f is smallest: every `step`-th value, then a pattern search
// around the best with the step halved down to 1.
template <typename F>
int argminInt(int lo, int hi, int step, F f) {
  int best = lo;
  double best_f = kInf;
  auto visit = [&](int v) {
    if (v < lo || v > hi) return;
    const double fv = f(v);
    if (fv < best_f) best_f = fv, best = v;
  };
  for (int v = lo; v <= hi; v += step) visit(v);
  visit(hi);
  for (int s = step / 2; s >= 1; s /= 2) {
    const int centre = best;
    visit(centre - s);
    visit(centre + s);
    if (best != centre) s *= 2;  // moved: try the same step again from there
  }
  return best;
}

// Weighted normal equations of force ~ c1 u1 + c2 u2.
struct Lin2 {
  double s11 = 0, s12 = 0, s22 = 0, b1 = 0, b2 = 0, ff = 0;
  void add(double w, double u1, double u2, double f) {
    s11 += w * u1 * u1, s12 += w * u1 * u2, s22 += w * u2 * u2;
    b1 += w * u1 * f, b2 += w * u2 * f, ff += w * f * f;
  }
  double rss(double c1, double c2) const {
    return ff - 2 * (c1 * b1 + c2 * b2) + c1 * c1 * s11 + 2 * c1 * c2 * s12 + c2 * c2 * s22;
  }
};

struct Lin2Solution {
  double rss = kInf, c1 = 0, c2 = 0;
};

// Least squares with (c1, c2) in the cone spanned by the rays r1 and r2 (both edges included).
Lin2Solution solveInCone(const Lin2& m, double r1a, double r1b, double r2a, double r2b) {
  Lin2Solution best;
  best.rss = m.ff;  // c = 0
  // inside: the unconstrained solution, if it lies between the rays
  const double det = m.s11 * m.s22 - m.s12 * m.s12;
  if (det > 1e-12 * std::max(1.0, m.s11 * m.s22)) {
    const double c1 = (m.s22 * m.b1 - m.s12 * m.b2) / det;
    const double c2 = (m.s11 * m.b2 - m.s12 * m.b1) / det;
    // c = a r1 + b r2 with a, b >= 0
    const double rdet = r1a * r2b - r1b * r2a;
    const double a = (c1 * r2b - c2 * r2a) / rdet, b = (r1a * c2 - r1b * c1) / rdet;
    if (a >= 0 && b >= 0) {
      const double r = m.rss(c1, c2);
      if (r < best.rss) best = {r, c1, c2};
    }
  }
  for (const auto& [ra, rb] : {std::pair<double, double>{r1a, r1b}, {r2a, r2b}}) {
    const double den = ra * ra * m.s11 + 2 * ra * rb * m.s12 + rb * rb * m.s22;
    const double num = ra * m.b1 + rb * m.b2;
    if (!(den > 0) || !(num > 0)) continue;
    const double k = num / den;
    const double r = m.rss(k * ra, k * rb);
    if (r < best.rss) best = {r, k * ra, k * rb};
  }
  best.rss = std::max(best.rss, 0.0);
  return best;
}

void checkRows(const std::vector<Row>& rows, const char* what) {
  int used = 0;
  for (const Row& r : rows)
    if (r.weight > 0 && std::isfinite(r.pwm_us) && std::isfinite(r.force_g)) ++used;
  if (used < 3)
    throw std::invalid_argument(fmt::format("{} fit: {} usable rows, need at least 3", what, used));
}

bool haveVoltage(const std::vector<Row>& rows, const FitSetup& setup) {
  if (!setup.use_voltage || setup.cells <= 0) return false;
  for (const Row& r : rows)
    if (!std::isfinite(r.vbat_v)) return false;
  return !rows.empty();
}

}  // namespace

Scaled bestScale(const std::vector<Row>& rows, const std::function<double(const Row&)>& fraction) {
  std::vector<double> g(rows.size());
  double sfg = 0, sgg = 0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    g[i] = fraction(rows[i]);
    if (!(rows[i].weight > 0) || !std::isfinite(g[i]) || !std::isfinite(rows[i].force_g)) continue;
    sfg += rows[i].weight * rows[i].force_g * g[i];
    sgg += rows[i].weight * g[i] * g[i];
  }
  Scaled s;
  s.full_g = sgg > 0 ? sfg / sgg : 0.0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (!(rows[i].weight > 0) || !std::isfinite(g[i]) || !std::isfinite(rows[i].force_g)) continue;
    const double e = rows[i].force_g - s.full_g * g[i];
    s.rss += rows[i].weight * e * e;
  }
  return s;
}

// ---- ArduPilot -------------------------------------------------------------------------------

ArduPilotFit fitArduPilot(const std::vector<Row>& rows, const FitSetup& setup) {
  checkRows(rows, "ArduPilot");
  ArduPilotParams p;
  p.pwm_min_us = setup.esc_min_us;
  p.pwm_max_us = setup.esc_max_us;
  const bool volts = haveVoltage(rows, setup);
  p.bat_volt_max_v = volts ? 4.2 * setup.cells : 0.0;
  p.bat_volt_min_v = volts ? setup.bat_volt_min_per_cell * setup.cells : 0.0;

  // per row: actuator and the voltage ratio (fixed by the battery parameters)
  std::vector<double> act(rows.size()), vr(rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    act[i] = (rows[i].pwm_us - p.pwm_min_us) / (p.pwm_max_us - p.pwm_min_us);
    vr[i] = ardupilot::voltageRatio(p, rows[i].vbat_v);
  }
  // force = c1 y + c2 y^2, y = clamp(t, 0, 1) v; e in -1..1 <=> (c1, c2) between the rays
  // (0, 1) (e = 1) and (2, -1) (e = -1)
  auto solve = [&](double smin, double smax) {
    Lin2 m;
    for (std::size_t i = 0; i < rows.size(); ++i) {
      if (!(rows[i].weight > 0) || !std::isfinite(rows[i].force_g) || !std::isfinite(act[i])) continue;
      const double t = act[i] > smin ? std::min((act[i] - smin) / (smax - smin), 1.0) : 0.0;
      const double y = t * vr[i];
      m.add(rows[i].weight, y, y * y, rows[i].force_g);
    }
    return solveInCone(m, 0.0, 1.0, 2.0, -1.0);
  };
  // best SPIN_MIN for a SPIN_MAX: grid of 0.002, then golden section around the best
  auto bestSpinMin = [&](double smax, double* rss) {
    double best = 0, best_rss = kInf;
    for (double s = 0; s <= 0.3 + 1e-9; s += 0.002) {
      const double r = solve(s, smax).rss;
      if (r < best_rss) best_rss = r, best = s;
    }
    const double s = golden(std::max(0.0, best - 0.002), std::min(0.3, best + 0.002),
                            [&](double x) { return solve(x, smax).rss; });
    const double r = solve(s, smax).rss;
    if (r < best_rss) best_rss = r, best = s;
    if (rss) *rss = best_rss;
    return best;
  };
  double smax = 0.95, best_rss = kInf;
  if (setup.fit_spin_max) {
    for (double m = 0.9; m <= 1.0 + 1e-9; m += 0.005) {
      double r;
      bestSpinMin(m, &r);
      if (r < best_rss) best_rss = r, smax = m;
    }
    smax = golden(std::max(0.9, smax - 0.005), std::min(1.0, smax + 0.005), [&](double m) {
      double r;
      bestSpinMin(m, &r);
      return r;
    });
    bestSpinMin(smax, &best_rss);
    double r_default;
    bestSpinMin(0.95, &r_default);
    if (r_default <= best_rss * (1 + kTieTolerance) + 1e-9) smax = 0.95;
  }
  const double smin = bestSpinMin(smax, &best_rss);
  const Lin2Solution s = solve(smin, smax);
  const double full = s.c1 + s.c2;
  p.spin_min = roundTo(smin, 1e-4);
  p.spin_max = roundTo(smax, 1e-3);
  p.thst_expo = full > 0 ? roundTo(std::clamp(s.c2 / full, -1.0, 1.0), 1e-4) : 0.0;

  ArduPilotFit fit;
  fit.params = p;
  fit.scale = bestScale(rows, [&](const Row& r) { return ardupilot::thrustFraction(p, r.pwm_us, r.vbat_v); });
  if (std::fabs(p.thst_expo) >= 0.9999)
    fit.notes.push_back(fmt::format("MOT_THST_EXPO reached its limit {:+.0f}: the measured curve bends more than "
                                    "ArduPilot's quadratic can", p.thst_expo));
  if (p.spin_min <= 1e-4)
    fit.notes.push_back(fmt::format("MOT_SPIN_MIN 0: thrust starts at or below MOT_PWM_MIN {:.0f} us",
                                    p.pwm_min_us));
  if (p.spin_min >= 0.2999)
    fit.notes.push_back(fmt::format("MOT_SPIN_MIN reached its limit 0.3: thrust starts above {:.0f} us; check "
                                    "the ESC range (--esc-range) and the ESC calibration",
                                    p.pwm_min_us + 0.3 * (p.pwm_max_us - p.pwm_min_us)));
  return fit;
}

// ---- PX4 -------------------------------------------------------------------------------------

Px4Fit fitPx4(const std::vector<Row>& rows, const FitSetup& setup, bool bat_scale) {
  checkRows(rows, "PX4");
  Px4Params p;
  p.bat_scale_en = bat_scale;
  p.bat_v_charged = setup.px4_v_charged;
  p.bat_n_cells = bat_scale ? setup.cells : 0;
  if (bat_scale && !haveVoltage(rows, setup))
    throw std::invalid_argument("PX4 fit with MC_BAT_SCALE_EN needs the battery voltage and the cell count");
  std::vector<double> k(rows.size(), 1.0);
  if (bat_scale)
    for (std::size_t i = 0; i < rows.size(); ++i) k[i] = 1.0 / px4::batteryScale(p, rows[i].vbat_v);
  // force = c1 k x + c2 k x^2 with f = c2 / (c1 + c2) in 0..1: rays (1, 0) and (0, 1)
  auto solve = [&](int lo, int hi) {
    Lin2 m;
    for (std::size_t i = 0; i < rows.size(); ++i) {
      if (!(rows[i].weight > 0) || !std::isfinite(rows[i].force_g) || !std::isfinite(rows[i].pwm_us)) continue;
      const double x = std::clamp((rows[i].pwm_us - lo) / static_cast<double>(hi - lo), 0.0, 1.0);
      m.add(rows[i].weight, k[i] * x, k[i] * x * x, rows[i].force_g);
    }
    return solveInCone(m, 1.0, 0.0, 0.0, 1.0);
  };
  const int top = static_cast<int>(std::clamp(std::lround(setup.esc_max_us), 1600L, 2200L));
  auto bestMin = [&](int hi, double* rss) {
    const int lo = argminInt(800, 1400, 4, [&](int v) { return solve(v, hi).rss; });
    if (rss) *rss = solve(lo, hi).rss;
    return lo;
  };
  int hi = argminInt(1600, top, 10, [&](int v) {
    double r;
    bestMin(v, &r);
    return r;
  });
  double best_rss, top_rss;
  bestMin(hi, &best_rss);
  bestMin(top, &top_rss);
  if (top_rss <= best_rss * (1 + kTieTolerance) + 1e-9) hi = top;
  const int lo = bestMin(hi, &best_rss);
  const Lin2Solution s = solve(lo, hi);
  p.pwm_min_us = lo;
  p.pwm_max_us = hi;
  p.thr_mdl_fac = s.c1 + s.c2 > 0 ? roundTo(std::clamp(s.c2 / (s.c1 + s.c2), 0.0, 1.0), 1e-3) : 0.0;

  Px4Fit fit;
  fit.params = p;
  fit.scale = bestScale(rows, [&](const Row& r) { return px4::thrustFraction(p, r.pwm_us, r.vbat_v); });
  if (p.thr_mdl_fac >= 0.9995)
    fit.notes.push_back("THR_MDL_FAC reached its limit 1: the measured curve bends more than PX4's quadratic can");
  if (lo <= 800 || lo >= 1400)
    fit.notes.push_back(fmt::format("PWM_MAIN_MIN reached its limit {} us (PX4 allows 800..1400)", lo));
  return fit;
}

// ---- Betaflight ------------------------------------------------------------------------------

namespace {

// Betaflight's search: the error of a parameter set at its best scale, and the best motor_idle
// for the rest fixed.
struct BetaflightSearch {
  const std::vector<Row>& rows;

  double rss(const BetaflightParams& q) const {
    return bestScale(rows, [&](const Row& r) { return betaflight::thrustFraction(q, r.pwm_us, r.vbat_v); }).rss;
  }
  // motor_idle for the rest fixed: every 100 (10 us), then a pattern search down to 1
  int bestIdle(BetaflightParams q, double* rss_out) const {
    const int best = argminInt(0, 2000, 100, [&](int v) {
      q.motor_idle = v;
      return rss(q);
    });
    q.motor_idle = best;
    if (rss_out) *rss_out = rss(q);
    return best;
  }
  // coordinate passes over the output limit, sag compensation, thrust_linear and idle
  void refine(BetaflightParams& p, bool volts, double& best_rss) const {
    for (int pass = 0; pass < 3; ++pass) {
      const BetaflightParams before = p;
      p.motor_output_limit = argminInt(50, 100, 2, [&](int v) {
        BetaflightParams q = p;
        q.motor_output_limit = v;
        return rss(q);
      });
      if (volts)
        p.vbat_sag_compensation = argminInt(0, 150, 5, [&](int v) {
          BetaflightParams q = p;
          q.vbat_sag_compensation = v;
          return rss(q);
        });
      p.thrust_linear = argminInt(std::max(0, p.thrust_linear - 8), std::min(betaflight::kMonotoneThrustLinearMax,
                                                                             p.thrust_linear + 8), 4, [&](int v) {
        BetaflightParams q = p;
        q.thrust_linear = v;
        double r;
        q.motor_idle = bestIdle(q, &r);
        return r;
      });
      p.motor_idle = bestIdle(p, &best_rss);
      if (before.motor_output_limit == p.motor_output_limit && before.vbat_sag_compensation == p.vbat_sag_compensation &&
          before.thrust_linear == p.thrust_linear && before.motor_idle == p.motor_idle)
        break;
    }
  }
};

std::vector<std::string> betaflightNotes(const BetaflightParams& p) {
  std::vector<std::string> notes;
  if (p.thrust_linear >= betaflight::kMonotoneThrustLinearMax)
    notes.push_back(fmt::format("thrust_linear stopped at {}: above it Betaflight's curve falls while the "
                                "demand rises (its slope 5/6 - e^2/2 turns negative)",
                                betaflight::kMonotoneThrustLinearMax));
  if (p.motor_idle >= 2000)
    notes.push_back("motor_idle reached its limit 2000 (20 %): thrust starts above it; check the ESC range");
  else if (p.motor_idle > 1000)
    notes.push_back(fmt::format(
        "motor_idle {} ({:.1f} %) is far above the default 550: Betaflight's curve bends less than the propeller's "
        "(thrust_linear <= {}) and the fit moves the start of thrust up instead; the motors would idle at {:.0f} us",
        p.motor_idle, p.motor_idle / 100.0, betaflight::kMonotoneThrustLinearMax,
        betaflight::toPulseUs(p, betaflight::endpoints(p).low)));
  return notes;
}

}  // namespace

BetaflightFit fitBetaflight(const std::vector<Row>& rows, const FitSetup& setup) {
  checkRows(rows, "Betaflight");
  BetaflightParams p;
  p.protocol = setup.bf_protocol;
  p.min_command = static_cast<int>(std::lround(setup.esc_min_us));
  p.max_throttle = static_cast<int>(std::lround(setup.esc_max_us));
  p.vbat_warning_cell_cv = setup.bf_vbat_warning_cell_cv;
  const bool volts = haveVoltage(rows, setup);
  p.cells = volts ? setup.cells : 0;
  p.vbat_sag_compensation = 0;
  p.motor_output_limit = 100;

  const BetaflightSearch search{rows};
  double best_rss = kInf;
  p.thrust_linear = argminInt(0, betaflight::kMonotoneThrustLinearMax, 4, [&](int tl) {
    BetaflightParams q = p;
    q.thrust_linear = tl;
    double r;
    search.bestIdle(q, &r);
    return r;
  });
  p.motor_idle = search.bestIdle(p, &best_rss);
  search.refine(p, volts, best_rss);
  // ties go to the defaults
  for (auto [field, value] : {std::pair<int BetaflightParams::*, int>{&BetaflightParams::motor_output_limit, 100},
                              {&BetaflightParams::vbat_sag_compensation, 0}}) {
    BetaflightParams q = p;
    q.*field = value;
    double r;
    q.motor_idle = search.bestIdle(q, &r);
    if (r <= best_rss * (1 + kTieTolerance) + 1e-9) p = q, best_rss = r;
  }

  BetaflightFit fit;
  fit.params = p;
  fit.scale = bestScale(rows, [&](const Row& r) { return betaflight::thrustFraction(p, r.pwm_us, r.vbat_v); });
  fit.notes = betaflightNotes(p);
  return fit;
}

}  // namespace lab::autopilot
