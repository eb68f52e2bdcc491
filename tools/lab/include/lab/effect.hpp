// One effect of the lab's force model lives in one file of tools/lab/src/effects/: its registry entry (name,
// physics, columns, parameters with units, ranges and defaults, export rule) and its term (what
// it adds to the formula, set up on the training data). A new effect is that file plus one line
// in registry.cpp; nothing else in the lab names effects.
//
// How the model evaluates the terms (model_eval.cpp), each hook in registry order:
//   drive   x = softPlus(pwm - origin) / span           origin: pmin, or a term's (deadband)
//           then every term's drive() (voltage, motor)  V the motor sees: vbat then every sag()
//           then every term's filter() (lag)
//   force   = offset + M * curve(x) + A, or M * base(pwm) + A with a base that has its own curve
//           (thesis); M and A from every term's factors() (motor, drift, thermal, density,
//           then the diagnosis's probes, then the user's mul:/add: expressions)
//   cap     force = min(force, cap) with every term's caps() (current_limit: what the source
//           lets the motor make), or a term's underCap() (the force settling to the cap); the
//           curve's coefficients are solved on the rows below the cap
//   perRow  what a term derives from a data set once, when the model binds it (which runs a
//           limit holds), in Rows::derived
#pragma once
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "lab/dataset.hpp"
#include "lab/model.hpp"

namespace lab::effects {

constexpr double kUnbounded = 1e300;  // a parameter range's open end
constexpr double kSoftStartUs = 2.0;  // the drive's start is softened over this many us

inline double softPlus(double u, double s) {
  const double z = u / s;
  return z > 30 ? u : s * std::log1p(std::exp(z));
}

// A parameter an effect may fit, as documented and as the fit starts. Numbers the data set
// (a range from the PWMs, a scale from the largest force) are passed by the effect's set-up and
// named in `from_data`.
struct ParamSpec {
  std::string name{};   // "gain_motor_N": one per motor after the first
  std::string unit{};
  std::string meaning{};
  double init = 0;      // starting value
  double scale = 0.01;  // typical step (LM scaling, numerical derivatives)
  double lo = -kUnbounded, hi = kUnbounded;
  double neutral = 0;   // the value that switches the effect off (the warm start uses it)
  std::string from_data{};  // which numbers the data set, in words; empty: none
  bool fixed = false;       // held at init, not fitted (a setting: --fix NAME=VALUE changes it)
};

// A parameter of one fitted model.
struct FitParam {
  std::string name, unit, effect;
  double init, scale, lo, hi;
  double neutral = std::numeric_limits<double>::quiet_NaN();
  // Scan the parameter from this value to its start with the linear solve before LM when it is
  // new in a fit (it has local minima); NaN: no scan.
  double scan_from = std::numeric_limits<double>::quiet_NaN();
  bool fixed = false;  // held at init (a setting, or the user's --fix): not fitted, not counted
};

class Term;

// The columns of one data set, looked up once.
struct Rows {
  std::size_t n = 0;
  const Dataset* data = nullptr;
  const std::vector<double>* pwm = nullptr;
  const std::vector<double>* vbat = nullptr;
  const std::vector<double>* current = nullptr;
  const std::vector<double>* t = nullptr;
  const std::vector<double>* temp = nullptr;
  const std::vector<double>* rho = nullptr;
  const std::vector<int>* run = nullptr;
  std::vector<int> motor_index;  // per row: index into the model's motors, -1: not a training motor
  const std::vector<double>* sample_index = nullptr;  // row numbers (a subsample's lag by samples)
  std::map<const Term*, std::vector<double>> derived;  // each term's perRow() of these data
};

// What a term's formula sees: the rows, the parameters (clamped to their ranges) and the model's
// normalisation.
struct Frame {
  const Rows& rows;
  const Eigen::VectorXd& th;
  const std::vector<FitParam>& defs;
  const std::vector<const Term*>& terms;
  double vref = 1;  // the highest voltage of the training data
  double xtop = 1;  // the base's drive range (1.1 for the curve: room above the data)
  double pmin = 0, span = 1;  // the training data's lowest PWM and PWM range
  double p(int i) const {
    const auto& d = defs[static_cast<std::size_t>(i)];
    return std::clamp(th[i], d.lo, d.hi);
  }
  // Parameter i plus parameter i+1 times the drive on 0..1: a coefficient that changes from
  // zero to full drive (the winding resistance matters more at high current).
  double alongDrive(int i, double x) const { return p(i) + p(i + 1) * std::clamp(x / xtop, 0.0, 1.0); }
  // The voltage the motor sees at row i and drive `duty`: vbat after every term's sag().
  double volts(std::size_t i, double duty) const;
  // Where the drive counts from: a term's origin() (deadband), else pmin.
  double startUs() const;
};

// One effect in one model, set up on the training data. Every hook is optional.
class Term {
 public:
  virtual ~Term() = default;
  // Where the drive counts from (deadband); false: the smallest PWM of the training data.
  virtual bool origin(const Frame&, double& /*start_us*/) const { return false; }
  virtual double sag(const Frame&, std::size_t, double, double v) const { return v; }
  virtual void drive(const Frame&, std::vector<double>&) const {}
  virtual void filter(const Frame&, std::vector<double>&) const {}
  virtual void factors(const Frame&, const std::vector<double>& x, Eigen::VectorXd& mul,
                       Eigen::VectorXd& add) const {
    (void)x, (void)mul, (void)add;
  }
  // The largest force the source lets the motor make, per row (cap_g starts at +inf); false
  // when the term caps nothing.
  virtual bool caps(const Frame&, std::vector<double>& /*cap_g*/) const { return false; }
  // The force where the cap binds, from the force without it (force_g in; the model's default
  // is min(force, cap)); false to leave it to the default.
  virtual bool underCap(const Frame&, const std::vector<double>& /*cap_g*/, Eigen::VectorXd& /*force_g*/) const {
    return false;
  }
  // Values derived once from a data set the model binds (Rows::derived[this]); empty: none.
  virtual std::vector<double> perRow(const Dataset&) const { return {}; }
  // Throws std::invalid_argument when `data` lacks what the term needs to predict it.
  virtual void check(const Dataset&) const {}

  // A base: either linear coefficients over a basis of the drive (the curve) ...
  virtual int linearSize() const { return 0; }
  virtual void linearRow(double, double, double*) const {}
  virtual std::string linearName(int) const { return {}; }
  virtual double driveTop() const { return 1.0; }
  // ... or a force of its own from the (filtered) PWM (the thesis model).
  virtual bool hasOwnForce() const { return false; }
  virtual void ownForce(const Frame&, const std::vector<double>&, Eigen::VectorXd&) const {}
  virtual int countedParams() const { return 0; }  // counted for the criteria, not fitted
  virtual void warn(const Eigen::VectorXd& /*measured_g*/, std::vector<std::string>& /*warnings*/) const {}
};

struct EffectDef;

// What an effect's set-up sees: the training data, its normalisation, and where its parameters go.
class Setup {
 public:
  const Dataset& train;
  const EffectDef& def;
  double pmin = 0, pmax = 0, span = 1, vref = 1, fmax = 0;
  std::vector<FitParam>& params;
  std::vector<long>& motor_ids;  // the motors rows are indexed by (Rows::motor_index)
  const std::map<std::string, double>* fixes = nullptr;  // the user's --fix NAME=VALUE

  Setup(const Dataset& d, const EffectDef& e, std::vector<FitParam>& p, std::vector<long>& m)
      : train(d), def(e), params(p), motor_ids(m) {}
  static bool usable(const Dataset& d, const char* column);  // present and finite on every row
  bool usable(const char* column) const { return usable(train, column); }
  void require(const char* column) const;  // throws naming the effect and the data's columns
  double mean(const char* column) const;   // over the training rows
  // The fit parameter for spec `k` of the effect (its defaults), to adjust before add().
  FitParam param(std::size_t k) const;
  int add(const FitParam& p);  // its index in the parameter vector (held at a --fix value when one names it)
  int add(std::size_t k) { return add(param(k)); }
};

// What points the diagnosis at an effect, and what it says then (analysis.cpp reads only this:
// it names no effect itself).
struct Suggests {
  std::vector<std::string> variables{};  // columns whose residual suggests it ("vbat*": a prefix; any case)
  std::vector<std::string> evidence{};   // findings in the responses that suggest it (evidence.hpp's kinds)
  std::string advice{};  // the physics in a phrase, ending with what to add: "...; add `voltage`"
  std::string still{};   // when it is in the model and the residual still follows the variable: why
};

enum class Role { kBase, kEffect, kExpression };
enum class Export { kInRecord, kOneMotor, kRefused };

struct EffectDef {
  std::string name{};
  Role role = Role::kEffect;
  std::string physics{};   // what it models, in plain words
  std::string columns{};   // the columns it needs
  std::vector<ParamSpec> params{};  // every parameter it may fit
  Export exports = Export::kRefused;
  std::string export_note{};  // why a record cannot hold it, and what to do
  bool shapes_curve = false;  // only with the `curve` base (not with a base of its own curve)
  std::string needs{}, needs_why{};  // another effect it needs before it, and why
  Suggests suggests{};             // what points the diagnosis at it
  std::string prefix{};            // kExpression: the spec prefix ("mul:")
  bool multiplicative = false;   // kExpression: a factor (else grams added)
  std::unique_ptr<Term> (*make)(Setup&) = nullptr;  // nullptr: expressions, made from the spec
};

// The registry, in the order the model evaluates the terms and `lab effects` lists them.
const std::vector<const EffectDef*>& registry();
const EffectDef* find(const std::string& name);
int registryIndex(const std::string& name);  // -1: not in the registry
// The expression effect (`mul:` when multiplicative, else `add:`).
const EffectDef& expressionDef(bool multiplicative);

// Terms that are not catalogue entries: a user expression and the diagnosis's probe.
std::unique_ptr<Term> makeExpression(Setup&, const UserEffect& u);
std::unique_ptr<Term> makeProbe(Setup&, const Probe& probe);
const EffectDef& probeDef();  // the probes' parameters name this effect

// "name [unit], lo..hi: meaning" for the effect's parameters, joined by "; ".
std::string parametersText(const EffectDef& e);
// docs/lab.md's effect table (the block between its `effects:` markers).
std::string markdownTable();

}  // namespace lab::effects
