// `motor`: per-motor force gain and drive scale (Kv), relative to the first motor in the data.
#include <fmt/format.h>

#include <set>

#include "lab/effect.hpp"

namespace lab::effects {
namespace {

class Motor : public Term {
 public:
  explicit Motor(Setup& s) {
    s.require("motor");
    std::set<long> ids;
    for (double m : s.train.col("motor")) ids.insert(std::lround(m));
    const std::vector<long> motors(ids.begin(), ids.end());
    for (std::size_t k = 1; k < motors.size(); ++k) {
      FitParam p = s.param(0);
      p.name = fmt::format("gain_motor_{}", motors[k]);
      const int idx = s.add(p);
      if (k == 1) gain0_ = idx;
    }
    for (std::size_t k = 1; k < motors.size(); ++k) {
      FitParam p = s.param(1);
      p.name = fmt::format("kv_motor_{}", motors[k]);
      const int idx = s.add(p);
      if (k == 1) kv0_ = idx;
    }
    if (motors.size() >= 2) s.motor_ids = motors;
  }
  void drive(const Frame& f, std::vector<double>& x) const override {
    if (kv0_ < 0) return;
    for (std::size_t i = 0; i < x.size(); ++i)
      if (f.rows.motor_index[i] > 0) x[i] *= 1.0 + f.p(kv0_ + f.rows.motor_index[i] - 1);
  }
  void factors(const Frame& f, const std::vector<double>&, Eigen::VectorXd& mul, Eigen::VectorXd&) const override {
    if (gain0_ < 0) return;
    for (std::size_t i = 0; i < f.rows.n; ++i)
      if (f.rows.motor_index[i] > 0) mul[static_cast<Eigen::Index>(i)] *= 1.0 + f.p(gain0_ + f.rows.motor_index[i] - 1);
  }

 private:
  int gain0_ = -1, kv0_ = -1;
};

}  // namespace

extern const EffectDef kMotor;
const EffectDef kMotor = {
    .name = "motor",
    .physics = "Per-motor variation (Kv, resistance, propeller): each motor has its own force gain and its "
               "own drive scale (speed per volt); the first motor in the data is the reference.",
    .columns = "motor",
    .params = {{.name = "gain_motor_N",
                .unit = "1",
                .meaning = "relative force of motor N minus 1",
                .scale = 0.02,
                .lo = -0.9,
                .hi = 10.0},
               {.name = "kv_motor_N",
                .unit = "1",
                .meaning = "relative drive (speed per volt) of motor N minus 1",
                .scale = 0.02,
                .lo = -0.5,
                .hi = 2.0}},
    .exports = Export::kOneMotor,
    .export_note = "a record holds one motor; pick one motor's rows with --motor N and export each motor "
                   "into its own slot",
    .suggests = {.variables = {"motor"},
                 .advice = "motors differ from each other (motor and propeller variation); add `motor`",
                 .still = "motors differ in the curve's shape, not only in gain and Kv"},
    .make = [](Setup& s) -> std::unique_ptr<Term> { return std::make_unique<Motor>(s); },
};

}  // namespace lab::effects
