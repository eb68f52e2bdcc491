// `current_limit`: a source (a bench supply's constant-current mode) or an ESC caps the bus
// current. An ESC is a buck converter: bus current = duty * motor current (+ its own idle), so
// above the drive where the cap is reached the motor current is cap / duty, and the torque and
// the thrust fall as the drive rises. The force is min(the model's force, the cap's force).
//
// With current_a: the bus current's relation to the PWM p and the force F, I = (a + b p) +
// (c + d p) F + (e + f p) F^2 (duty, affine in p, times the motor current, a smooth function of
// the force, plus the idle current), is fitted on the rows drawing at least a quarter of the
// largest current (outliers left out); the cap's force at each PWM solves I = i_limit_a. The
// limit starts at the ceiling current_a stops at and holds the runs that reach it. Without
// current_a amperes cannot be told from grams: the cap is cap_top_g at the data's top PWM,
// rising as 1/duty below it less the no-load current's share (idle_g), on the runs whose force
// falls while the drive rises. Held at a constant current the motor has no back-EMF damping and
// settles slower: with t_s, the force approaches the cap from the previous row's with
// tau_limit_s.
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>

#include "lab/analysis.hpp"
#include "lab/effect.hpp"
#include "lab/evidence.hpp"

namespace lab::effects {
namespace {

constexpr double kOutlierSd = 4.0;
constexpr double kRelevantShare = 0.25;  // the current's relation is fitted where it is near the cap

class CurrentLimit : public Term {
 public:
  explicit CurrentLimit(Setup& s) : pmin_(s.pmin), pmax_(s.pmax), span_(s.span) {
    by_current_ = s.usable("current_a");
    if (by_current_) withCurrent(s);
    else withoutCurrent(s);
  }

  std::vector<double> perRow(const Dataset& d) const override {
    std::vector<bool> runs(d.runs(), false);
    if (by_current_) {
      if (std::isfinite(ceiling_a_)) runs = runsAtCeiling(d, "current_a", ceiling_a_);
      else std::fill(runs.begin(), runs.end(), true);
    } else {
      for (const auto& c : findForceCollapse(d))
        for (std::size_t r = 0; r < d.runs(); ++r) runs[r] = runs[r] || d.run_labels[r] == c.run;
    }
    std::vector<double> held(d.rows(), 0.0);
    bool any = false;
    for (std::size_t i = 0; i < d.rows(); ++i) {
      held[i] = runs[static_cast<std::size_t>(d.run[i])] ? 1.0 : 0.0;
      any = any || held[i] > 0;
    }
    return any ? held : std::vector<double>();
  }

  bool caps(const Frame& f, std::vector<double>& cap) const override {
    const auto it = f.rows.derived.find(this);
    if (it == f.rows.derived.end()) return false;
    const auto& held = it->second;
    const auto& pwm = *f.rows.pwm;
    if (by_current_) {
      const double limit_a = f.p(i_);
      for (std::size_t i = 0; i < f.rows.n; ++i) {
        if (!(held[i] > 0)) continue;
        const double f = forceAtCurrent(limit_a, (pwm[i] - pmin_) / span_);
        if (std::isfinite(f)) cap[i] = std::min(cap[i], f);
      }
      return true;
    }
    const double start = f.startUs();
    const double top = softPlus(pmax_ - start, kSoftStartUs);
    const double cap_top = f.p(i_), idle = f.p(i_ + 1);
    for (std::size_t i = 0; i < f.rows.n; ++i) {
      const double u = softPlus(pwm[i] - start, kSoftStartUs);
      if (!(held[i] > 0) || !(u > 0)) continue;
      cap[i] = std::min(cap[i], (cap_top + idle) * top / u - idle);
    }
    return true;
  }

  // Held at a constant current the motor loses its back-EMF damping and settles slower: where
  // the cap binds, the force goes from the previous row's force to the cap with tau_limit_s
  // (per run, in logging order, by t_s); where it does not, the force is the model's.
  bool underCap(const Frame& f, const std::vector<double>& cap, Eigen::VectorXd& force) const override {
    const double tau = tau_ >= 0 ? f.p(tau_) : 0.0;
    const bool settle = tau > f.defs[static_cast<std::size_t>(std::max(tau_, 0))].lo && f.rows.t;
    std::vector<long> last(f.rows.data ? f.rows.data->runs() : 0, -1);
    for (std::size_t i = 0; i < f.rows.n; ++i) {
      const auto ri = static_cast<Eigen::Index>(i);
      const double free_force = force[ri];
      const auto r = static_cast<std::size_t>(std::max((*f.rows.run)[i], 0));
      if (r >= last.size()) last.resize(r + 1, -1);
      if (free_force > cap[i]) {
        force[ri] = cap[i];
        if (settle && last[r] >= 0) {
          const auto prev = static_cast<std::size_t>(last[r]);
          const double dt = (*f.rows.t)[i] - (*f.rows.t)[prev];
          if (dt > 0 && std::isfinite(dt))
            force[ri] = std::min(free_force, cap[i] + (force[static_cast<Eigen::Index>(prev)] - cap[i]) * std::exp(-dt / tau));
        }
      }
      last[r] = static_cast<long>(i);
    }
    return true;
  }

 private:
  void withCurrent(Setup& s) {
    if (const auto p = findPlateau(s.train, "current_a")) ceiling_a_ = p->level;
    fitBusCurrent(s.train);
    FitParam lim = s.param(0);
    double top_a = 0;
    for (double a : s.train.col("current_a")) top_a = std::max(top_a, a);
    // no ceiling in the data: start above every current, where the cap holds nothing
    lim.init = std::isfinite(ceiling_a_) ? ceiling_a_ : 1.05 * top_a;
    lim.scale = std::max(0.01 * lim.init, 1e-3);
    i_ = s.add(lim);
    if (s.usable("t_s")) tau_ = s.add(3);
  }

  void withoutCurrent(Setup& s) {
    double top_force = s.fmax;
    const auto falls = findForceCollapse(s.train);
    if (!falls.empty()) {
      top_force = 0;
      for (const auto& c : falls) top_force = std::max(top_force, c.top_force_g);
    }
    FitParam cap = s.param(1), idle = s.param(2);
    cap.init = top_force;
    cap.scale = std::max(0.01 * s.fmax, 1e-3);
    cap.hi = cap.neutral = 100.0 * std::max(s.fmax, 1.0);
    idle.init = 0.05 * top_force;
    idle.scale = cap.scale;
    idle.hi = std::max(s.fmax, 1.0);
    i_ = s.add(cap);
    s.add(idle);
    if (s.usable("t_s")) tau_ = s.add(3);
  }

  // The force at which the bus current reaches `amps` at drive p: the positive root of
  // (g4 + g5 p) F^2 + (g2 + g3 p) F + g0 + g1 p - amps = 0; NaN when there is none.
  double forceAtCurrent(double amps, double p) const {
    const double a = g_[4] + g_[5] * p, b = g_[2] + g_[3] * p, c = g_[0] + g_[1] * p - amps;
    if (std::fabs(a) < 1e-12 * std::fabs(b)) return b > 0 ? -c / b : std::numeric_limits<double>::quiet_NaN();
    const double disc = b * b - 4 * a * c;
    if (disc < 0) return std::numeric_limits<double>::quiet_NaN();
    const double root = (-b + std::sqrt(disc)) / (2 * a);
    return root;
  }

  // I = g0 + g1 p + g2 F + g3 p F by least squares (p on 0..1 over the training PWMs), again
  // without the rows beyond 4 robust standard deviations (a clipped force reading).
  void fitBusCurrent(const Dataset& d) {
    const auto& pwm = d.col("pwm_us");
    const auto& f = d.col("force_g");
    const auto& cur = d.col("current_a");
    double top_a = 0;
    for (double c : cur) top_a = std::max(top_a, c);
    std::vector<std::size_t> rows;
    for (std::size_t k = 0; k < d.rows(); ++k)
      if (cur[k] >= kRelevantShare * top_a) rows.push_back(k);
    const auto n = static_cast<Eigen::Index>(rows.size());
    Eigen::MatrixXd a(n, 6);
    Eigen::VectorXd y(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      const auto k = rows[static_cast<std::size_t>(i)];
      const double p = (pwm[k] - pmin_) / span_;
      a.row(i) << 1.0, p, f[k], p * f[k], f[k] * f[k], p * f[k] * f[k];
      y[i] = cur[k];
    }
    Eigen::VectorXd g = a.colPivHouseholderQr().solve(y);
    Eigen::VectorXd r = y - a * g;
    std::vector<double> sq(r.data(), r.data() + r.size());
    std::nth_element(sq.begin(), sq.begin() + static_cast<long>(sq.size() / 2), sq.end(),
                     [](double x, double z) { return std::fabs(x) < std::fabs(z); });
    const double robust_sd = std::fabs(sq[sq.size() / 2]) / 0.6745;
    std::vector<Eigen::Index> keep;
    for (Eigen::Index i = 0; i < n; ++i)
      if (std::fabs(r[i]) <= kOutlierSd * robust_sd) keep.push_back(i);
    if (keep.size() >= 8 && keep.size() < static_cast<std::size_t>(n)) {
      Eigen::MatrixXd ak(static_cast<Eigen::Index>(keep.size()), 6);
      Eigen::VectorXd yk(static_cast<Eigen::Index>(keep.size()));
      for (std::size_t k = 0; k < keep.size(); ++k) {
        ak.row(static_cast<Eigen::Index>(k)) = a.row(keep[k]);
        yk[static_cast<Eigen::Index>(k)] = y[keep[k]];
      }
      g = ak.colPivHouseholderQr().solve(yk);
    }
    for (int k = 0; k < 6; ++k) g_[k] = g[k];
  }

  bool by_current_ = false;
  double ceiling_a_ = std::numeric_limits<double>::quiet_NaN();
  double g_[6] = {0, 0, 0, 0, 0, 0};  // the bus current's relation (p on 0..1)
  double pmin_, pmax_, span_;
  int i_ = -1;
  int tau_ = -1;  // tau_limit_s (with t_s)
};

}  // namespace

extern const EffectDef kCurrentLimit;
const EffectDef kCurrentLimit = {
    .name = "current_limit",
    .physics = "A source (a bench supply in constant-current mode) or an ESC caps the bus current. The bus "
               "current of an ESC is the duty times the motor current, so above the drive where the cap is "
               "reached the motor current is cap/duty and the torque and the thrust fall as the drive rises: "
               "force = min(model force, cap's force). With current_a the bus current's relation to PWM p and "
               "force F (I = (a + b p) + (c + d p) F + (e + f p) F^2) is fitted on the data and the limit starts "
               "at the ceiling current_a stops at, on the runs that reach it; without it the cap is fitted in "
               "grams on the runs whose force falls while the drive rises. Held at a constant current the motor "
               "loses its back-EMF damping and settles slower (tau_limit_s, with t_s).",
    .columns = "pwm_us, current_a (optional)",
    .params = {{.name = "i_limit_a",
                .unit = "A",
                .meaning = "the bus current the source or ESC holds (with current_a)",
                .init = 10.0,
                .scale = 0.05,
                .lo = 0.01,
                .hi = 1000.0,
                .neutral = 1000.0,
                .from_data = "0.01..1000, off at 1000; starts at the ceiling of current_a"},
               {.name = "cap_top_g",
                .unit = "g",
                .meaning = "the force the limit allows at the data's top PWM (without current_a)",
                .init = 100.0,
                .scale = 1.0,
                .lo = 0.0,
                .hi = 1e5,
                .neutral = 1e5,
                .from_data = "0..100 x the largest force, off at the top; starts at the force where it falls to"},
               {.name = "idle_g",
                .unit = "g",
                .meaning = "the no-load current's share of the cap, in grams (without current_a)",
                .init = 5.0,
                .scale = 1.0,
                .lo = 0.0,
                .hi = 1e5,
                .neutral = 0.0,
                .from_data = "0..the largest force"},
               {.name = "tau_limit_s",
                .unit = "s",
                .meaning = "time constant of the force held by the limit (with t_s; off at the lower bound): without "
                           "its back-EMF's damping the motor settles slower",
                .init = 0.3,
                .scale = 0.05,
                .lo = 1e-4,
                .hi = 100.0,
                .neutral = 1e-4}},
    .exports = Export::kRefused,
    .export_note = "model v2 records have no current limit (read_run cannot know the source's); fit and "
                   "export below the limit (--where 'pwm_us < P', P where the force stops rising)",
    .suggests = {.evidence = {"current_plateau", "force_falls"},
                 .advice = "the bus current is held at a ceiling, so the motor current (ceiling / duty) and the thrust "
                           "fall as the drive rises; add `current_limit`",
                 .still = "the cap's shape or its settling is not the data's"},
    .make = [](Setup& s) -> std::unique_ptr<Term> { return std::make_unique<CurrentLimit>(s); },
};

}  // namespace lab::effects
