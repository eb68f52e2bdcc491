// `lag`: first-order dynamics between the command and the force (the motor's inertia, a slow load
// cell): the drive low-pass filtered per run. On a step log (lab/steps.hpp) each motor has its
// own time constants up and down (spin-down is slower without active braking).
#include <fmt/format.h>

#include <algorithm>
#include <set>

#include "lab/effect.hpp"
#include "lab/steps.hpp"
#include "lowpass.hpp"

namespace lab::effects {
namespace {

enum Spec { kTau, kTauSamples, kTauUp, kTauDown };

class Lag : public Term {
 public:
  explicit Lag(Setup& s) {
    // no time column: the rows are taken as equally spaced samples in logging order
    in_samples_ = !s.usable("t_s");
    if (in_samples_ || !isStepLog(s.train)) {
      up_ = down_ = s.add(in_samples_ ? kTauSamples : kTau);
      return;
    }
    std::set<long> ids;
    if (s.usable("motor"))
      for (double m : s.train.col("motor")) ids.insert(std::lround(m));
    const std::vector<long> motors(ids.begin(), ids.end());
    per_motor_ = motors.size() >= 2;
    const std::size_t n = per_motor_ ? motors.size() : 1;
    for (std::size_t k = 0; k < n; ++k) {
      for (const Spec which : {kTauUp, kTauDown}) {
        FitParam p = s.param(which);
        if (per_motor_) p.name = fmt::format("{}_motor_{}", p.name, motors[k]);
        const int idx = s.add(p);
        if (k == 0) (which == kTauUp ? up_ : down_) = idx;
      }
    }
    if (per_motor_) s.motor_ids = motors;
  }

  // First-order low-pass per run in row order (the order the samples were logged); on a step
  // log the time constant is the motor's up one while the drive rises toward the command, its
  // down one while it falls.
  void filter(const Frame& f, std::vector<double>& x) const override {
    // at their lower bounds the lag is off: exactly the model without it
    if (f.p(up_) <= lower(f, up_) && f.p(down_) <= lower(f, down_)) return;
    const Rows& b = f.rows;
    lowPassPerRun(b, !in_samples_ && b.t, x, [&](std::size_t i, bool rising) {
      const int m = per_motor_ ? std::max(b.motor_index[i], 0) : 0;
      return f.p((rising ? up_ : down_) + 2 * m);
    });
  }

 private:
  static double lower(const Frame& f, int i) { return f.defs[static_cast<std::size_t>(i)].lo; }

  bool in_samples_ = false;
  bool per_motor_ = false;
  int up_ = -1, down_ = -1;  // the first motor's (one time constant: both the same parameter)
};

}  // namespace

extern const EffectDef kLag;
const EffectDef kLag = {
    .name = "lag",
    .physics = "First-order motor dynamics (and a slow load cell): the measured force follows the command "
               "with a time constant, so up and down sweeps differ (hysteresis). The drive is low-pass "
               "filtered per run in logging order, by t_s, or by sample count when there is no t_s. On a step "
               "log (the PWM held at set points, rows logged through each step with t_s) each motor has a time "
               "constant up and one down: spin-down is slower when the ESC does not brake.",
    .columns = "t_s (optional), motor (optional, step logs)",
    .params = {{.name = "tau_s",
                .unit = "s",
                .meaning = "time constant (with t_s; off at the lower bound)",
                .init = 0.05,
                .scale = 0.02,
                .lo = 1e-4,
                .hi = 100.0,
                .neutral = 1e-4},
               {.name = "tau_samples",
                .unit = "samples",
                .meaning = "time constant without t_s (off at the lower bound)",
                .init = 1.0,
                .scale = 0.5,
                .lo = 1e-3,
                .hi = 1000.0,
                .neutral = 1e-3},
               {.name = "tau_up_s",
                .unit = "s",
                .meaning = "step logs: time constant while the force rises (tau_up_s_motor_M per motor when the "
                           "log holds several)",
                .init = 0.05,
                .scale = 0.02,
                .lo = 1e-4,
                .hi = 10.0,
                .neutral = 1e-4},
               {.name = "tau_down_s",
                .unit = "s",
                .meaning = "step logs: time constant while the force falls (tau_down_s_motor_M per motor)",
                .init = 0.05,
                .scale = 0.02,
                .lo = 1e-4,
                .hi = 10.0,
                .neutral = 1e-4}},
    .export_note = "read_run sets the steady-state PWM for a force and the record holds no time constant; "
                   "fit without it (the steady-state curve is what the board needs)",
    .suggests = {.variables = {"t_s", "time*", "dpwm_us", "dir"},
                 .advice = "the force trails the command (motor inertia, a slow load cell): up and down sweeps "
                           "differ; add `lag`",
                 .still = "up and down differ by more than a first-order lag (hysteresis, a load cell that creeps)"},
    .make = [](Setup& s) -> std::unique_ptr<Term> { return std::make_unique<Lag>(s); },
};

}  // namespace lab::effects
