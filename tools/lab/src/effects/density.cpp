// `density`: air density rho = p / (287.05 T) as a force factor (rho/rho_ref)^(beta + beta_drive x).
#include <algorithm>
#include <stdexcept>

#include "lab/effect.hpp"

namespace lab::effects {
namespace {

class Density : public Term {
 public:
  explicit Density(Setup& s) {
    if (!s.usable("rho_kg_m3"))
      throw std::invalid_argument(
          "effect `density` needs temp_c and a pressure column (pressure_pa, pressure_hpa, "
          "...) on every row to compute the air density");
    rho0_ = s.mean("rho_kg_m3");
    i_ = s.add(0);
    s.add(1);
  }
  void factors(const Frame& f, const std::vector<double>& x, Eigen::VectorXd& mul, Eigen::VectorXd&) const override {
    for (std::size_t i = 0; i < f.rows.n; ++i) {
      // exponent falls with the drive: at low drive the speed barely depends on the load
      // (F ~ rho), at high drive the winding resistance lets the motor slow down
      const double beta = f.alongDrive(i_, x[i]);
      mul[static_cast<Eigen::Index>(i)] *= std::pow(std::max((*f.rows.rho)[i], 1e-6) / rho0_, beta);
    }
  }

 private:
  double rho0_;
  int i_;
};

}  // namespace

extern const EffectDef kDensity;
const EffectDef kDensity = {
    .name = "density",
    .physics = "Air density rho = p / (287.05 T) from temperature and pressure: thrust at fixed speed is "
               "proportional to rho; at a fixed command the motor slows down under a heavier load, the "
               "more so the higher the drive (winding resistance), so the force goes as "
               "(rho/rho_ref)^(beta + beta_drive * x), x the drive on 0..1.",
    .columns = "temp_c, a pressure column (pressure_pa, pressure_hpa, ...)",
    .params = {{.name = "beta",
                .unit = "1",
                .meaning = "density exponent at zero drive (1: force proportional to rho)",
                .init = 1.0,
                .scale = 0.2,
                .lo = -5.0,
                .hi = 5.0},
               {.name = "beta_drive", .unit = "1", .meaning = "its change up to full drive", .scale = 0.2, .lo = -5.0, .hi = 5.0}},
    .export_note = "the board has no air-density input and the record holds no density term; fit without "
                   "it, on data taken in the air you fly in",
    .suggests = {.variables = {"rho_kg_m3"},
                 .advice = "thrust is proportional to the air density rho = p/(R T); add `density`",
                 .still = "the exponent changes differently with the drive"},
    .make = [](Setup& s) -> std::unique_ptr<Term> { return std::make_unique<Density>(s); },
};

}  // namespace lab::effects
