// The lab's force model: a base (a smooth monotone force curve, or the firmware's thesis model
// evaluated through core/) plus named effects from a catalogue, plus user effects written as
// expressions (`mul: EXPR`, `add: EXPR`). Fitted by least squares: the curve's coefficients
// linearly (non-negative least squares keeps the curve monotone), every other parameter by
// Levenberg-Marquardt on the residual that remains after the linear solve (variable projection).
//
//   drive   d = (pwm - start) / span                  [deadband: start fitted, else min pwm]
//   x       = d * (V / V_ref)^gamma                   [voltage; V = vbat - R * I with sag]
//   force   = offset + M * curve(x) + A               curve(x) = sum_j c_j S_j(x), c_j >= 0
//   M       = product of the multiplicative effects   (motor, thermal, density, drift, mul:)
//   A       = sum of the additive effects             (add:)
#pragma once
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "lab/dataset.hpp"

namespace lab {

struct EffectInfo {
  std::string name;
  std::string physics;     // what it models, in plain words
  std::string columns;     // columns it needs
  std::string parameters;  // name [unit]: meaning
};
// The catalogue, in the order `effects` prints it.
const std::vector<EffectInfo>& effectCatalogue();
const EffectInfo* findEffect(const std::string& name);

struct UserEffect {
  bool multiplicative;  // mul: (factor on force) or add: (grams added)
  std::string expression;
};

// A generic multiplicative factor in one column, used by the diagnosis to ask "how much would
// an effect in this variable help?": 1 + a*u + b*u^2 (u the standardised column), or a gain
// per level for a categorical column.
struct Probe {
  std::string column;
  bool categorical = false;
};

struct ModelSpec {
  std::vector<std::string> effects;  // catalogue names, in order
  std::vector<UserEffect> user;
  std::vector<Probe> probes;
  std::map<std::string, double> fixed;  // parameters held at a value (--fix NAME=VALUE): known, not fitted
  bool has(const std::string& effect) const;
  std::string text() const;  // "curve+deadband+voltage+mul: 1 + a*(temp_c-25)"
};
// SPEC: names joined with '+'; `mul: EXPR` or `add: EXPR` runs to the next ';' or the end.
// Throws std::invalid_argument naming the unknown effect and listing the catalogue.
ModelSpec parseSpec(const std::string& spec);
// spec + more, checked the same way.
ModelSpec combine(const ModelSpec& base, const ModelSpec& more);
// `--fix NAME=VALUE`: holds a parameter of the catalogue at a known value (a bench's filter, a
// setting). Throws std::invalid_argument for a bad form or a name no effect has.
void fixParameter(ModelSpec& spec, const std::string& text);

struct Param {
  std::string name;
  std::string unit;
  std::string effect;
  double value = 0;
  double sigma = 0;  // one standard uncertainty from the Jacobian (NaN when not determined)
  bool at_bound = false;  // the fit stopped at a limit of the parameter's range
  double bound = 0;       // that limit
  bool fixed = false;     // held at a known value (--fix or a setting), not fitted
};

struct FitResult {
  std::string model;
  std::size_t n = 0;
  int k = 0;             // fitted parameters (for the information criteria)
  double rss = 0;        // g^2
  double rmse_g = 0;
  double max_g = 0;      // largest |residual|
  double rmse_pct = 0;   // percent of the largest measured force
  double max_pct = 0;
  double aic = 0;
  double bic = 0;
  std::vector<double> predicted_g;
  std::vector<double> residual_g;  // measured - predicted
  std::vector<Param> params;
  std::vector<std::string> warnings;
};

// A model bound to training data. Normalisation constants (PWM span, reference voltage,
// temperature, density, time origin, motors) come from the training data so the fitted model
// also predicts other data (held-out runs).
class Model {
 public:
  Model(const ModelSpec& spec, const Dataset& train);
  ~Model();
  Model(const Model&) = delete;
  const ModelSpec& spec() const;  // as fitted (with the base effect)
  Model& operator=(const Model&) = delete;

  // `warm`: parameters of a smaller model; the fit also starts from them, the new effects at
  // their neutral values (exactly the smaller model), and keeps the best of the starts, so it
  // never fits worse than the smaller model; `warm_only` skips the cold start. Without `warm`
  // the model one effect smaller is fitted first (recursively) and used as the warm start: a
  // direct fit equals the ladder adding the same effects one by one. On more than 20,000 rows
  // the nonlinear parameters are searched on evenly spaced rows; the curve, the errors and the
  // uncertainties use every row. `uncertainties` false skips them (continuation, ranking refits;
  // on more than 20,000 rows the per-row predictions too). `warm_rss`: the smaller model's RSS
  // on these data (saves evaluating its optimum again), NaN when not known.
  FitResult fit(const std::vector<Param>* warm = nullptr, bool warm_only = false, bool uncertainties = true,
                double warm_rss = std::numeric_limits<double>::quiet_NaN());
  // Prediction of the fitted model on other data (same columns needed). NaN where it cannot.
  std::vector<double> predict(const Dataset& data) const;
  // The voltage the motor sees per row (vbat_v after the fitted sag; NaN without vbat_v):
  // what the board's battery monitor reads under load. Needs fit().
  std::vector<double> motorVoltage(const Dataset& data) const;
  // The ESC start threshold the drive is measured from: pwm_start_us with `deadband`, else
  // the smallest PWM of the training data. Needs fit().
  double startUs() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Fits `spec` on `data`.
FitResult fitModel(const Dataset& data, const ModelSpec& spec, const std::vector<Param>* warm = nullptr,
                   bool warm_only = false, bool uncertainties = true,
                   double warm_rss = std::numeric_limits<double>::quiet_NaN());

// Adds derived candidate columns: rho_kg_m3 (from temp_c and a pressure column) and dpwm_us
// (the PWM step from the previous sample of the same run: what a lag responds to).
void addDerivedColumns(Dataset& data);

}  // namespace lab
