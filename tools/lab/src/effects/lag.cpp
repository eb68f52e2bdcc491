// `lag`: first-order motor (and load-cell) dynamics: the drive low-pass filtered per run.
#include <algorithm>

#include "lab/effect.hpp"

namespace lab::effects {
namespace {

class Lag : public Term {
 public:
  explicit Lag(Setup& s) {
    // no time column: the rows are taken as equally spaced samples in logging order
    in_samples_ = !s.usable("t_s");
    i_ = s.add(in_samples_ ? 1 : 0);
  }
  // First-order low-pass per run in row order (the order the samples were logged).
  void filter(const Frame& f, std::vector<double>& x) const override {
    const double tau = f.p(i_);
    // at its lower bound the lag is off: exactly the model without it
    if (tau <= f.defs[static_cast<std::size_t>(i_)].lo) return;
    const Rows& b = f.rows;
    std::vector<long> last_row;  // per run: last row seen (-1: none)
    std::vector<double> last_x;
    const bool by_time = !in_samples_ && b.t;
    for (std::size_t i = 0; i < b.n; ++i) {
      const auto r = static_cast<std::size_t>(std::max((*b.run)[i], 0));
      if (r >= last_row.size()) {
        last_row.resize(r + 1, -1);
        last_x.resize(r + 1, 0.0);
      }
      if (last_row[r] >= 0) {
        const auto prev = static_cast<std::size_t>(last_row[r]);
        const double dt = by_time          ? (*b.t)[i] - (*b.t)[prev]
                          : b.sample_index ? (*b.sample_index)[i] - (*b.sample_index)[prev]
                                           : 1.0;
        if (dt > 0 && std::isfinite(dt)) x[i] = last_x[r] + (1 - std::exp(-dt / tau)) * (x[i] - last_x[r]);
      }
      last_row[r] = static_cast<long>(i);
      last_x[r] = x[i];
    }
  }

 private:
  bool in_samples_;
  int i_;
};

}  // namespace

extern const EffectDef kLag;
const EffectDef kLag = {
    .name = "lag",
    .physics = "First-order motor dynamics (and a slow load cell): the measured force follows the command "
               "with a time constant, so up and down sweeps differ (hysteresis). The drive is low-pass "
               "filtered per run in logging order, by t_s, or by sample count when there is no t_s.",
    .columns = "t_s (optional)",
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
                .neutral = 1e-3}},
    .export_note = "read_run sets the steady-state PWM for a force and the record holds no time constant; "
                   "fit without it (the steady-state curve is what the board needs)",
    .suggests = {.variables = {"t_s", "time*", "dpwm_us", "dir"},
                 .advice = "the force trails the command (motor inertia, a slow load cell): up and down sweeps "
                           "differ; add `lag`",
                 .still = "up and down differ by more than a first-order lag (hysteresis, a load cell that creeps)"},
    .make = [](Setup& s) -> std::unique_ptr<Term> { return std::make_unique<Lag>(s); },
};

}  // namespace lab::effects
