// `cell`: the bench's own response between the force and its reading (a load cell's RC low-pass, an
// amplifier, a logger's averaging): stages of first-order low-pass after the motor's `lag`, per run
// in time. Known for a bench (identified once): --fix tau_cell_s=VALUE --fix cell_stages=N.
#include <algorithm>
#include <cmath>

#include "lab/effect.hpp"
#include "lowpass.hpp"

namespace lab::effects {
namespace {

class Cell : public Term {
 public:
  explicit Cell(Setup& s) {
    s.require("t_s");
    tau_ = s.add(0);
    stages_ = s.add(1);
  }
  // A linear stage acts on the force; here on the drive after the motor's lag: exact while the
  // force is linear in the drive over a step (small steps), close for larger ones.
  void filter(const Frame& f, std::vector<double>& x) const override {
    const double tau = f.p(tau_);
    if (tau <= f.defs[static_cast<std::size_t>(tau_)].lo) return;  // off: the model without it
    const int stages = static_cast<int>(std::lround(f.p(stages_)));
    for (int k = 0; k < stages; ++k) lowPassPerRun(f.rows, true, x, [tau](std::size_t, bool) { return tau; });
  }
  void check(const Dataset& d) const override {
    if (!Setup::usable(d, "t_s")) throw std::invalid_argument("effect `cell` needs t_s on every row");
  }

 private:
  int tau_ = -1, stages_ = -1;
};

}  // namespace

extern const EffectDef kCell;
const EffectDef kCell = {
    .name = "cell",
    .physics = "The bench's own response between the force and its reading (the load cell's RC low-pass, an "
               "amplifier, a logger's averaging): cell_stages first-order stages of tau_cell_s each, after the "
               "motor's `lag`. Fitted, or known for the bench: --fix tau_cell_s=VALUE (and --fix cell_stages=N), "
               "so a step log's time constants are the motor's alone.",
    .columns = "t_s",
    .params = {{.name = "tau_cell_s",
                .unit = "s",
                .meaning = "time constant of each stage (off at the lower bound)",
                .init = 0.02,
                .scale = 0.01,
                .lo = 1e-4,
                .hi = 2.0,
                .neutral = 1e-4},
               {.name = "cell_stages",
                .unit = "1",
                .meaning = "number of equal stages (held, not fitted: --fix cell_stages=N)",
                .init = 1,
                .scale = 1,
                .lo = 1,
                .hi = 3,
                .neutral = 1,
                .fixed = true}},
    .export_note = "the bench's response is not the motor's: the record holds the steady-state curve; fit without it",
    .needs = "lag",
    .needs_why = "filters the drive after the motor's own dynamics",
    .suggests = {.variables = {"t_s", "time*"},
                 .advice = "the reading trails the motor's first-order lag by more than it explains (the bench's load "
                           "cell, amplifier or logger filters after the motor); add `cell` (with --fix tau_cell_s=... "
                           "when the bench's response is known)",
                 .still = "the bench's response is not equal first-order stages (identify it once on the bench: "
                          "gather_store's `dyn cell`, and hold it with --fix)"},
    .make = [](Setup& s) -> std::unique_ptr<Term> { return std::make_unique<Cell>(s); },
};

}  // namespace lab::effects
