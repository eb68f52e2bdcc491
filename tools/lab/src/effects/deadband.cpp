// `deadband`: the ESC's start threshold; the drive counts from it.
#include "lab/effect.hpp"

namespace lab::effects {
namespace {

class Deadband : public Term {
 public:
  explicit Deadband(Setup& s) {
    const auto& pwm = s.train.col("pwm_us");
    const auto& f = s.train.col("force_g");
    // start: the highest PWM below which the force stays under 3 % of the maximum
    double first_up = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < pwm.size(); ++i)
      if (f[i] > 0.03 * s.fmax) first_up = std::min(first_up, pwm[i]);
    double start = s.pmin;
    for (std::size_t i = 0; i < pwm.size(); ++i)
      if (pwm[i] < first_up || (pwm[i] == first_up && f[i] <= 0.03 * s.fmax)) start = std::max(start, pwm[i]);
    FitParam p = s.param(0);
    p.init = start;
    p.scale = 0.01 * s.span;
    p.lo = s.pmin - 0.05 * s.span;
    p.hi = s.pmax;
    p.neutral = s.pmin;
    p.scan_from = s.pmin;  // the curve can bend to mimic a later start: local minima
    i_ = s.add(p);
  }
  bool origin(const Frame& f, double& start_us) const override {
    start_us = f.p(i_);
    return true;
  }

 private:
  int i_;
};

}  // namespace

extern const EffectDef kDeadband;
const EffectDef kDeadband = {
    .name = "deadband",
    .physics = "ESC start threshold: below it the motor does not turn and the force is zero; the drive "
               "counts from the threshold (softened over ~2 us).",
    .columns = "pwm_us",
    .params = {{.name = "pwm_start_us",
                .unit = "us",
                .meaning = "PWM where the motor starts",
                .from_data = "range from the data: lowest PWM - 5 % of the span .. highest PWM"}},
    .exports = Export::kInRecord,
    .shapes_curve = true,
    .suggests = {.variables = {"pwm_us"},
                 .advice = "the curve's shape near the ESC's start threshold is off; add `deadband`",
                 .still = "the start is not one sharp threshold (the ESC's startup, a motor that cogs)"},
    .make = [](Setup& s) -> std::unique_ptr<Term> { return std::make_unique<Deadband>(s); },
};

}  // namespace lab::effects
