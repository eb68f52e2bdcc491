// The model lab's fitter, inside: the state of one model bound to its training data and the
// steps of evaluating and fitting it. Private to tools/lab/src (model_eval.cpp evaluates,
// model_fit.cpp fits); the interface is lab/model.hpp.
#pragma once
#include <Eigen/Dense>
#include <algorithm>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "lab/effect.hpp"
#include "lab/model.hpp"

namespace lab {

struct Model::Impl {
  using FitParam = effects::FitParam;
  using Frame = effects::Frame;
  using Rows = effects::Rows;
  using Term = effects::Term;
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  // Above this many rows the nonlinear parameters are searched on evenly spaced rows (the curve's
  // coefficients, the errors and the uncertainties always use every row).
  static constexpr std::size_t kMaxFitRows = 20000;

  ModelSpec spec;
  const Dataset& train;
  std::vector<FitParam> defs;                // the nonlinear parameters, effects in SPEC order
  std::vector<std::unique_ptr<Term>> owned;
  std::vector<const Term*> terms;            // evaluation order: registry, probes, expressions
  const Term* linear = nullptr;              // a base with linear coefficients (curve)
  std::string linear_effect;
  const Term* own = nullptr;                 // a base with a force of its own (thesis)
  bool own_base = false;                     // own != nullptr: no linear solve
  bool capped = false;                       // a term caps the force (no normal-equation RSS)
  std::vector<long> motor_ids;               // training motors, index 0 = reference
  double pmin = 0, span = 1, vref = 1, xtop = 1;
  Eigen::VectorXd theta;  // fitted nonlinear parameters
  Eigen::VectorXd coef;   // fitted linear parameters (curve)
  bool fitted = false;
  Rows train_bound;
  Eigen::VectorXd y;
  // The rows the nonlinear search runs on: all of them, or evenly spaced ones on big data.
  std::unique_ptr<Dataset> fit_data;
  std::vector<double> fit_index;
  Rows fit_bound;
  Eigen::VectorXd y_fit;

  Impl(const ModelSpec& s, const Dataset& d) : spec(s), train(d) { setup(); }

  Frame frame(const Rows& b, const Eigen::VectorXd& th) const {
    return Frame{b, th, defs, terms, vref, xtop, pmin, span};
  }

  double p(const Eigen::VectorXd& th, int i) const {
    return std::clamp(th[i], defs[static_cast<std::size_t>(i)].lo, defs[static_cast<std::size_t>(i)].hi);
  }

  // Where the drive counts from: a term's origin (deadband), else the smallest training PWM.
  double origin(const Frame& f) const { return f.startUs(); }

  int basisSize() const { return linear ? linear->linearSize() : 0; }  // incl. the constant

  // Row i of the design matrix of the linear parameters: 1 (the offset), then mul * S_j(x).
  void basisRow(double x, double mul, double* row) const { linear->linearRow(x, mul, row); }

  using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  // The SPEC's rules that are about several effects: one base, what an effect needs.
  void checkSpec(std::vector<const effects::EffectDef*>& in_spec);

  void setup();

  Rows bind(const Dataset& d) const;

  Eigen::VectorXd initialTheta() const;

  // The nonlinear parameters the fit moves (not held by --fix or as a setting).
  int freeParams() const {
    int n = 0;
    for (const auto& d : defs) n += d.fixed ? 0 : 1;
    return n;
  }

  // A drive for a base of its own (the effects that depend on it): PWM over the span.
  std::vector<double> plainDrive(const Rows& b) const;

  // The drive x per row (curve models).
  std::vector<double> drive(const Rows& b, const Eigen::VectorXd& th) const;

  // Multiplicative factor and additive grams per row.
  void factors(const Rows& b, const Eigen::VectorXd& th, const std::vector<double>& x,
               Eigen::VectorXd& mul, Eigen::VectorXd& add) const;

  // The largest force per row the terms allow (current_limit); empty when no term caps.
  std::vector<double> capsOf(const Rows& b, const Eigen::VectorXd& th) const;

  // The force of a base of its own, from the PWM after the terms' filters (lag).
  Eigen::VectorXd ownBase(const Rows& b, const Eigen::VectorXd& th) const;

  // The normal equations of the curve's coefficients, G = B'B, h = B'r, rr = r'r with
  // r = target - add, summed over blocks of rows (vectorised rank updates; the n x k matrix B is
  // not kept unless `keep` asks for it, row-major). False when a row is not finite.
  bool normalEquations(const Rows& b, const std::vector<double>& x, const Eigen::VectorXd& mul,
                       const Eigen::VectorXd& add, const Eigen::VectorXd& target, Eigen::MatrixXd& G,
                       Eigen::VectorXd& h, double& rr, std::vector<double>* keep,
                       const std::vector<char>* skip = nullptr) const;

  Eigen::VectorXd solveCurve(const Eigen::MatrixXd& G, const Eigen::VectorXd& h) const;

  // Prediction with the linear coefficients solved (when `solve`) or taken from `c`.
  Eigen::VectorXd predictWith(const Rows& b, const Eigen::VectorXd& th, Eigen::VectorXd& c, bool solve,
                              const Eigen::VectorXd* target) const;

  // The curve's prediction on every row (no cap), from the coefficients c.
  Eigen::VectorXd uncapped(const Rows& b, const std::vector<double>& x, const Eigen::VectorXd& mul,
                           const Eigen::VectorXd& add, const Eigen::VectorXd& c) const;

  // min(curve, cap) per row. Solving: the rows at the cap do not depend on the curve, so its
  // coefficients are solved on the rows below it, and the rows at the cap found again from the
  // new curve until they stay the same (a few passes).
  Eigen::VectorXd predictCapped(const Rows& b, const Eigen::VectorXd& th, const std::vector<double>& x,
                                const Eigen::VectorXd& mul, const Eigen::VectorXd& add, const std::vector<double>& cap,
                                Eigen::VectorXd& c, bool solve, const Eigen::VectorXd* target) const;

  // force = min(force, cap), or what a term says the force under its cap is.
  void applyCap(const Rows& b, const Eigen::VectorXd& th, const std::vector<double>& cap, Eigen::VectorXd& force) const;

  // The rows where the curve's force is above the cap (they do not depend on the curve).
  std::vector<char> atCap(const Rows& b, const Eigen::VectorXd& th, const Eigen::VectorXd& c) const;

  double rssAt(const Rows& b, const Eigen::VectorXd& target, const Eigen::VectorXd& th,
               Eigen::VectorXd* coef_out = nullptr) const;

  std::vector<double> predict(const Dataset& d) const;

  std::vector<double> motorVolts(const Dataset& d) const;

  double startUs() const;

  // Levenberg-Marquardt over the nonlinear parameters on the fit rows, each step solving the
  // curve linearly (variable projection): model_fit.cpp.
  struct Functor;

  // `quick`: looser tolerances for the ranking's refits (only their error matters there).
  Eigen::VectorXd runLm(const Eigen::VectorXd& start, FitResult& r, bool quick = false,
                        const std::vector<bool>* fixed = nullptr) const;

  // The smaller model's curve coefficients (offset_g, c1..), when it has all of them.
  bool warmCurve(const std::vector<Param>& warm, Eigen::VectorXd& c) const;

  // The starting point from a smaller model's fit: its parameters, and each new parameter at
  // the value that switches its effect off, so the start predicts exactly what the smaller
  // model did.
  // `neutral` false: the new parameters at their starting guesses instead (the effect switched
  // on), where LM finds a gradient (a lag at its lower bound has none).
  Eigen::VectorXd warmStart(const std::vector<Param>& warm, bool neutral = true) const;

  // A parameter with a scan (deadband's start threshold) has local minima (the curve can bend
  // to mimic a later start): when it is new (not in `known`), scan it from its scan_from value
  // to its first guess with the linear solve alone and start LM at the best.
  Eigen::VectorXd scanStart(Eigen::VectorXd th, const std::vector<Param>* known) const;

  // The nonlinear search: LM from the smaller model's optimum (`warm`) and cold, the best on
  // the fit rows, then on every row against the smaller model itself. Sets theta and coef;
  // returns the RSS on every row.
  double search(const std::vector<Param>* warm, bool warm_only, double warm_rss, FitResult& r);

  // A quick fit on many rows (continuation, ranking): the parameters and the error, not
  // every row's prediction.
  FitResult quickResult(FitResult& r, double best_rss) const;

  // The errors and criteria of the fit on every row, and the warnings about it.
  void errorsOf(FitResult& r, const Eigen::VectorXd& pred, Eigen::Index nl) const;

  // Uncertainties: J = d pred / d (linear, nonlinear) at the optimum, J^T J summed row by row;
  // one standard uncertainty per active linear and every nonlinear parameter (NaN when not
  // determined).
  Eigen::VectorXd sigmas(FitResult& r, const Eigen::VectorXd& pred, const std::vector<Eigen::Index>& active,
                         Eigen::Index nl) const;

  // Every parameter with its uncertainty and, for the nonlinear ones, whether it stopped at a
  // bound of its range.
  void paramsOf(FitResult& r, const Eigen::VectorXd& sig, const std::vector<Eigen::Index>& active, Eigen::Index nl,
                bool uncertainties) const;

  // `warm_rss`: the smaller model's RSS on these rows (its curve coefficients are in `warm`),
  // so its optimum need not be evaluated again; NaN: evaluate it.
  FitResult fit(const std::vector<Param>* warm, bool warm_only, bool uncertainties, double warm_rss);
};

}  // namespace lab
