// `voltage`: the force follows the motor voltage duty*V: the drive times (V/V_ref)^gamma.
#include "lab/effect.hpp"

namespace lab::effects {
namespace {

class Voltage : public Term {
 public:
  explicit Voltage(Setup& s) {
    s.require("vbat_v");
    i_ = s.add(0);
  }
  void drive(const Frame& f, std::vector<double>& x) const override {
    const double gamma = f.p(i_);
    for (std::size_t i = 0; i < x.size(); ++i) x[i] *= std::pow(f.volts(i, x[i]) / f.vref, gamma);
  }

 private:
  int i_;
};

}  // namespace

extern const EffectDef kVoltage;
const EffectDef kVoltage = {
    .name = "voltage",
    .physics = "Force follows the effective motor voltage duty*V, not the PWM alone: the drive is "
               "multiplied by (V/V_ref)^gamma, V_ref the highest voltage in the data.",
    .columns = "vbat_v",
    .params = {{.name = "gamma",
                .unit = "1",
                .meaning = "voltage exponent (1 for an ideal motor)",
                .init = 1.0,
                .scale = 0.1,
                .lo = 0.0,
                .hi = 5.0}},
    .exports = Export::kInRecord,
    .shapes_curve = true,
    .suggests = {.variables = {"vbat*", "voltage*", "v_v", "v"},
                 .advice = "the force follows the motor voltage duty*V, not the PWM alone; add `voltage`",
                 .still = "the voltage logged is not the one at the ESC"},
    .make = [](Setup& s) -> std::unique_ptr<Term> { return std::make_unique<Voltage>(s); },
};

}  // namespace lab::effects
