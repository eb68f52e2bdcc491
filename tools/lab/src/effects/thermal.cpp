// `thermal`: the motor's temperature (copper +0.39 %/K, magnets -0.1 %/K) as a force factor.
#include <algorithm>

#include "lab/effect.hpp"

namespace lab::effects {
namespace {

class Thermal : public Term {
 public:
  explicit Thermal(Setup& s) {
    s.require("temp_c");
    temp0_ = s.mean("temp_c");
    i_ = s.add(0);
    s.add(1);
  }
  void factors(const Frame& f, const std::vector<double>& x, Eigen::VectorXd& mul, Eigen::VectorXd&) const override {
    for (std::size_t i = 0; i < f.rows.n; ++i) {
      // the magnets' share is a plain gain; the winding resistance's share grows with the
      // current, i.e. with the drive
      const double k = f.alongDrive(i_, x[i]);
      mul[static_cast<Eigen::Index>(i)] *= 1.0 + k / 100.0 * ((*f.rows.temp)[i] - temp0_);
    }
  }

 private:
  double temp0_;
  int i_;
};

}  // namespace

extern const EffectDef kThermal;
const EffectDef kThermal = {
    .name = "thermal",
    .physics = "Temperature of the motor: copper resistance +0.39 %/K and magnets -0.1 %/K change the "
               "force at a given command; a factor linear in the temperature around its mean, whose "
               "slope changes with the drive x (the resistance matters more at high current).",
    .columns = "temp_c",
    .params = {{.name = "thermal_pct_per_k", .unit = "%/K", .meaning = "force change per kelvin at zero drive", .scale = 0.1},
               {.name = "thermal_drive_pct_per_k", .unit = "%/K", .meaning = "its change up to full drive", .scale = 0.1}},
    .export_note = "the board reads no motor temperature and the record holds no temperature term; fit "
                   "without it, on data taken at the temperature you fly at",
    .suggests = {.variables = {"temp*"},
                 .advice = "the motor's temperature (copper and magnets) changes the force; add `thermal`",
                 .still = "the temperature logged is not the motor's, or the air's density moves with it (log a "
                          "pressure column for rho_kg_m3)"},
    .make = [](Setup& s) -> std::unique_ptr<Term> { return std::make_unique<Thermal>(s); },
};

}  // namespace lab::effects
