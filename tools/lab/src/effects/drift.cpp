// `drift`: grams added in proportion to the time since the first sample (load-cell creep).
#include <algorithm>

#include "lab/effect.hpp"

namespace lab::effects {
namespace {

class Drift : public Term {
 public:
  explicit Drift(Setup& s) {
    s.require("t_s");
    const auto& t = s.train.col("t_s");
    t0_ = *std::min_element(t.begin(), t.end());
    FitParam p = s.param(0);
    p.scale = 0.01 * std::max(s.fmax, 1.0);
    i_ = s.add(p);
  }
  void factors(const Frame& f, const std::vector<double>&, Eigen::VectorXd&, Eigen::VectorXd& add) const override {
    const double rate = f.p(i_);
    for (std::size_t i = 0; i < f.rows.n; ++i) add[static_cast<Eigen::Index>(i)] += rate * ((*f.rows.t)[i] - t0_) / 60.0;
  }

 private:
  double t0_;
  int i_;
};

}  // namespace

extern const EffectDef kDrift;
const EffectDef kDrift = {
    .name = "drift",
    .physics = "Slow change with time, e.g. load-cell zero creep or a warming rig: grams added in "
               "proportion to the time since the first sample.",
    .columns = "t_s",
    .params = {{.name = "drift_g_per_min",
                .unit = "g/min",
                .meaning = "offset change rate",
                .from_data = "unbounded; step 1 % of the largest force"}},
    .export_note = "read_run has no clock-dependent term (the record holds no time); fit without it, or "
                   "re-zero the load cell and measure again",
    .suggests = {.variables = {"t_s", "time*"},
                 .advice = "something drifts with time (load-cell creep, a warming rig); add `drift`",
                 .still = "the change is not linear in time (warming, a draining pack?)"},
    .make = [](Setup& s) -> std::unique_ptr<Term> { return std::make_unique<Drift>(s); },
};

}  // namespace lab::effects
