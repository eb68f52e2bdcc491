// `sag`: the motor sees less than the logged voltage under load (battery and wiring resistance).
#include "lab/effect.hpp"

namespace lab::effects {
namespace {

class Sag : public Term {
 public:
  explicit Sag(Setup& s) {
    s.require("vbat_v");
    by_current_ = s.usable("current_a");
    i_ = s.add(by_current_ ? 0 : 1);
  }
  double sag(const Frame& f, std::size_t i, double duty, double v) const override {
    if (by_current_) return v - f.p(i_) * (*f.rows.current)[i];
    // without a current column the current goes as (duty*V)^2
    const double load = duty * v / f.vref;
    return v * (1.0 - f.p(i_) * load * load);
  }

 private:
  bool by_current_;
  int i_;
};

}  // namespace

extern const EffectDef kSag;
const EffectDef kSag = {
    .name = "sag",
    .physics = "Battery internal resistance and wiring: the motor sees V = vbat - R*I, lower than the "
               "logged (resting) voltage under load. Without a current column the current is taken as "
               "proportional to (duty*V)^2 and the sag is fitted as a fraction of V at full drive. "
               "Needs `voltage`.",
    .columns = "vbat_v, current_a (optional)",
    .params = {{.name = "r_sag_ohm",
                .unit = "ohm",
                .meaning = "source resistance (with current_a)",
                .init = 0.02,
                .scale = 0.02,
                .lo = 0.0,
                .hi = 10.0},
               {.name = "sag_full",
                .unit = "1",
                .meaning = "relative sag at full drive (without current_a)",
                .init = 0.02,
                .scale = 0.02,
                .lo = 0.0,
                .hi = 0.9}},
    .exports = Export::kInRecord,
    .shapes_curve = true,
    .needs = "voltage",
    .needs_why = "corrects the voltage the motor sees",
    .suggests = {.variables = {"vbat*", "voltage*", "v_v", "v"},
                 .advice = "the motor sees less than the logged voltage under load (the battery and its wiring "
                           "sag); add `sag` (it uses current_a when logged)",
                 .still = "the sag is not linear in the current"},
    .make = [](Setup& s) -> std::unique_ptr<Term> { return std::make_unique<Sag>(s); },
};

}  // namespace lab::effects
