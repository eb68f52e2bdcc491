// The fit of a model: Levenberg-Marquardt over the effects' parameters with the curve solved
// linearly at every step (variable projection), warm starts from a smaller model so a model with
// an added effect never fits worse, the errors, criteria and uncertainties, and the public
// Model and fitModel.
#include <fmt/format.h>

#include <Eigen/Dense>
#include <unsupported/Eigen/LevenbergMarquardt>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "lab/effect.hpp"
#include "model_impl.hpp"

namespace lab {

using effects::FitParam;
using effects::Frame;
using effects::Rows;
using effects::Term;

// Levenberg-Marquardt over the nonlinear parameters on the fit rows, each step solving the
// curve linearly (variable projection).
struct Model::Impl::Functor : Eigen::DenseFunctor<double> {
  const Impl* m;
  Eigen::VectorXd th0, scale;
  std::vector<Eigen::Index> free;  // the parameters LM moves (the others stay at th0)
  Functor(const Impl* model, const Eigen::VectorXd& init, const Eigen::VectorXd& sc,
          std::vector<Eigen::Index> moving)
      : Eigen::DenseFunctor<double>(static_cast<int>(moving.size()), static_cast<int>(model->y_fit.size())),
        m(model), th0(init), scale(sc), free(std::move(moving)) {}
  // the residual at the last point evaluated: LM asks for the Jacobian where it just was
  mutable Eigen::VectorXd last_z, last_f;
  Eigen::VectorXd theta(const Eigen::VectorXd& z) const {
    Eigen::VectorXd th = th0;
    for (std::size_t k = 0; k < free.size(); ++k) th[free[k]] += scale[free[k]] * z[static_cast<Eigen::Index>(k)];
    return th;
  }
  int operator()(const Eigen::VectorXd& z, Eigen::VectorXd& fvec) const {
    Eigen::VectorXd c;
    fvec = m->y_fit - m->predictWith(m->fit_bound, theta(z), c, true, &m->y_fit);
    for (Eigen::Index i = 0; i < fvec.size(); ++i)
      if (!std::isfinite(fvec[i])) fvec[i] = 1e6;
    last_z = z;
    last_f = fvec;
    return 0;
  }
  int df(const Eigen::VectorXd& z, Eigen::MatrixXd& jac) const {
    Eigen::VectorXd f0, f1;
    if (last_z.size() == z.size() && last_z == z) f0 = last_f;
    else (*this)(z, f0);
    jac.resize(f0.size(), z.size());
    for (Eigen::Index j = 0; j < z.size(); ++j) {
      Eigen::VectorXd zp = z;
      const double h = 1e-4;
      zp[j] += h;
      (*this)(zp, f1);
      jac.col(j) = (f1 - f0) / h;
    }
    return 0;
  }
};

// `quick`: looser tolerances for the ranking's refits (only their error matters there).
Eigen::VectorXd Model::Impl::runLm(const Eigen::VectorXd& start, FitResult& r, bool quick,
                      const std::vector<bool>* fixed) const {
  const Eigen::Index np = static_cast<Eigen::Index>(defs.size());
  Eigen::VectorXd sc(np);
  std::vector<Eigen::Index> moving;
  for (Eigen::Index i = 0; i < np; ++i) {
    sc[i] = defs[static_cast<std::size_t>(i)].scale;
    const bool held = defs[static_cast<std::size_t>(i)].fixed || (fixed && (*fixed)[static_cast<std::size_t>(i)]);
    if (!held) moving.push_back(i);
  }
  if (moving.empty()) return start;
  const int nm = static_cast<int>(moving.size());
  Functor fn(this, start, sc, moving);
  Eigen::LevenbergMarquardt<Functor> lm(fn);
  lm.setMaxfev(quick ? 20 + 10 * nm : 60 + 20 * nm);
  lm.setXtol(quick ? 1e-6 : 1e-8);
  lm.setFtol(quick ? 1e-7 : 1e-9);
  Eigen::VectorXd z = Eigen::VectorXd::Zero(nm);
  const auto status = lm.minimize(z);
  if (status == Eigen::LevenbergMarquardtSpace::ImproperInputParameters)
    r.warnings.push_back("the fit could not start (improper input)");
  Eigen::VectorXd th = fn.theta(z);
  for (Eigen::Index i = 0; i < np; ++i) th[i] = p(th, static_cast<int>(i));
  return th;
}

// The smaller model's curve coefficients (offset_g, c1..), when it has all of them.
bool Model::Impl::warmCurve(const std::vector<Param>& warm, Eigen::VectorXd& c) const {
  c = Eigen::VectorXd::Constant(basisSize(), kNaN);
  for (const auto& w : warm) {
    if (w.effect != linear_effect) continue;
    for (int j = 0; j < c.size(); ++j)
      if (w.name == linear->linearName(j)) c[j] = w.value;
  }
  return c.allFinite();
}

// The starting point from a smaller model's fit: its parameters, and each new parameter at
// the value that switches its effect off, so the start predicts exactly what the smaller
// model did.
// `neutral` false: the new parameters at their starting guesses instead (the effect switched
// on), where LM finds a gradient (a lag at its lower bound has none).
Eigen::VectorXd Model::Impl::warmStart(const std::vector<Param>& warm, bool neutral) const {
  Eigen::VectorXd start = initialTheta();
  for (std::size_t i = 0; i < defs.size(); ++i) {
    const auto& d = defs[i];
    bool found = d.fixed;  // a held parameter keeps its value
    for (const auto& w : warm)
      if (!d.fixed)
      if (w.name == d.name && w.effect == d.effect && std::isfinite(w.value)) {
        start[static_cast<Eigen::Index>(i)] = w.value;
        found = true;
      }
    if (!found && neutral && std::isfinite(d.neutral)) start[static_cast<Eigen::Index>(i)] = d.neutral;
  }
  return start;
}

// A parameter with a scan (deadband's start threshold) has local minima (the curve can bend
// to mimic a later start): when it is new (not in `known`), scan it from its scan_from value
// to its first guess with the linear solve alone and start LM at the best.
Eigen::VectorXd Model::Impl::scanStart(Eigen::VectorXd th, const std::vector<Param>* known) const {
  const double inf = std::numeric_limits<double>::infinity();
  for (std::size_t j = 0; j < defs.size(); ++j) {
    const auto i = static_cast<Eigen::Index>(j);
    const double lo = defs[j].fixed ? kNaN : defs[j].scan_from;
    bool is_new = std::isfinite(lo);
    if (known)
      for (const auto& w : *known) is_new = is_new && w.name != defs[j].name;
    if (!is_new) continue;
    const double hi = initialTheta()[i];
    double best = inf, best_start = hi;
    for (int k = 0; k <= 16; ++k) {
      th[i] = lo + (hi - lo) * k / 16.0;
      const double rss = rssAt(fit_bound, y_fit, th);
      if (rss < best) best = rss, best_start = th[i];
    }
    th[i] = best_start;
  }
  return th;
}

// The nonlinear search: LM from the smaller model's optimum (`warm`) and cold, the best on
// the fit rows, then on every row against the smaller model itself. Sets theta and coef;
// returns the RSS on every row.
double Model::Impl::search(const std::vector<Param>* warm, bool warm_only, double warm_rss, FitResult& r) {
  const double inf = std::numeric_limits<double>::infinity();
  const bool have_warm = warm && !warm->empty();
  std::vector<Eigen::VectorXd> searched;  // LM results
  bool cold = !have_warm;
  Eigen::VectorXd neutral;
  if (have_warm) {
    // Warm start from a smaller model's optimum: with the new effects switched off it is
    // itself a candidate, so a model with an added effect never fits worse than the model
    // without it; LM starts from it with the new effects switched on.
    neutral = warmStart(*warm);
    Eigen::VectorXd start = warmStart(*warm, /*neutral=*/false);
    start = scanStart(start, warm);
    // A generic probe asks whether anything is left in a variable: the model's own
    // parameters stay where they are, only the probe's move (cheap, and it cannot borrow
    // from the effects already fitted).
    std::vector<bool> fixed;
    if (warm_only && !spec.probes.empty()) {
      fixed.assign(defs.size(), false);
      for (std::size_t i = 0; i < defs.size(); ++i) fixed[i] = defs[i].effect != "probe";
    }
    searched.push_back(runLm(start, r, warm_only, fixed.empty() ? nullptr : &fixed));
    // and from a cold start too (multi-start): the start threshold and the voltage exponent
    // have local minima the continuation can end in
    cold = !warm_only;
  }
  if (cold) searched.push_back(runLm(scanStart(initialTheta(), nullptr), r));
  // the best search result on the fit rows, then on every row against the smaller model
  double best_fit_rows = inf;
  theta = searched.front();
  for (const auto& th : searched) {
    Eigen::VectorXd c;
    const double rss = rssAt(fit_bound, y_fit, th, &c);
    if (rss < best_fit_rows) {
      best_fit_rows = rss;
      theta = th;
      coef = c;
    }
  }
  double best_rss = fit_data ? rssAt(train_bound, y, theta, &coef) : best_fit_rows;
  if (have_warm) {
    Eigen::VectorXd c;
    double rss = inf;
    if (std::isfinite(warm_rss) && !own_base && warmCurve(*warm, c)) rss = warm_rss;
    else rss = rssAt(train_bound, y, neutral, &c);
    if (rss < best_rss || !std::isfinite(best_rss)) {
      best_rss = rss;
      theta = neutral;
      coef = c;
    }
  }
  return best_rss;
}

// A quick fit on many rows (continuation, ranking): the parameters and the error, not
// every row's prediction.
FitResult Model::Impl::quickResult(FitResult& r, double best_rss) const {
  const Eigen::Index np = static_cast<Eigen::Index>(defs.size());
  r.n = static_cast<std::size_t>(y.size());
  r.k = static_cast<int>(coef.size()) + freeParams();
  r.rss = best_rss;
  const double n = static_cast<double>(r.n);
  r.rmse_g = std::sqrt(r.rss / n);
  r.max_g = r.max_pct = kNaN;
  r.rmse_pct = 100 * r.rmse_g / std::max(y.cwiseAbs().maxCoeff(), 1e-9);
  const double ll = n * std::log(std::max(r.rss / n, 1e-300));
  r.aic = ll + 2.0 * r.k;
  r.bic = ll + std::log(n) * r.k;
  for (Eigen::Index j = 0; j < coef.size(); ++j)
    r.params.push_back({linear->linearName(static_cast<int>(j)), "g", linear_effect, coef[j], kNaN});
  for (Eigen::Index j = 0; j < np; ++j) {
    const auto& d = defs[static_cast<std::size_t>(j)];
    r.params.push_back({d.name, d.unit, d.effect, theta[j], kNaN});
    r.params.back().fixed = d.fixed;
  }
  return r;
}

// The errors and criteria of the fit on every row, and the warnings about it.
void Model::Impl::errorsOf(FitResult& r, const Eigen::VectorXd& pred, Eigen::Index nl) const {
  r.n = static_cast<std::size_t>(y.size());
  r.k = static_cast<int>(nl) + freeParams() + (own ? own->countedParams() : 0);
  const Eigen::VectorXd res = y - pred;
  r.rss = res.squaredNorm();
  const double n = static_cast<double>(r.n);
  r.rmse_g = std::sqrt(r.rss / n);
  r.max_g = res.cwiseAbs().maxCoeff();
  const double fmax = std::max(y.cwiseAbs().maxCoeff(), 1e-9);
  r.rmse_pct = 100 * r.rmse_g / fmax;
  r.max_pct = 100 * r.max_g / fmax;
  const double ll = n * std::log(std::max(r.rss / n, 1e-300));
  r.aic = ll + 2.0 * r.k;
  r.bic = ll + std::log(n) * r.k;
  r.predicted_g.assign(pred.data(), pred.data() + pred.size());
  r.residual_g.assign(res.data(), res.data() + res.size());
  if (!res.allFinite()) r.warnings.push_back("the model is not finite on some rows (check expressions and columns)");
  if (!own_base && static_cast<double>(r.k) >= n)
    r.warnings.push_back(fmt::format("{} samples for {} parameters: the fit interpolates, its error says "
                                     "nothing; log more samples or use fewer effects", r.n, r.k));
  for (const Term* t : terms) t->warn(y, r.warnings);
}

// Uncertainties: J = d pred / d (linear, nonlinear) at the optimum, J^T J summed row by row;
// one standard uncertainty per active linear and every nonlinear parameter (NaN when not
// determined).
Eigen::VectorXd Model::Impl::sigmas(FitResult& r, const Eigen::VectorXd& pred, const std::vector<Eigen::Index>& active,
                       Eigen::Index nl) const {
  const Eigen::Index np = static_cast<Eigen::Index>(defs.size());
  const Eigen::Index ncol = static_cast<Eigen::Index>(active.size()) + np;
  Eigen::VectorXd sig = Eigen::VectorXd::Constant(ncol, kNaN);
  std::vector<Eigen::VectorXd> dcol(static_cast<std::size_t>(np));
  for (Eigen::Index j = 0; j < np; ++j) {
    Eigen::VectorXd tp = theta;
    const double h = 1e-3 * defs[static_cast<std::size_t>(j)].scale;
    tp[j] += h;
    Eigen::VectorXd c = coef;
    dcol[static_cast<std::size_t>(j)] = defs[static_cast<std::size_t>(j)].fixed  // held: no column
                                            ? Eigen::VectorXd::Zero(pred.size())
                                            : Eigen::VectorXd((predictWith(train_bound, tp, c, false, nullptr) - pred) / h);
  }
  const Eigen::Index held = np - freeParams();
  Eigen::VectorXd mul, add;
  std::vector<double> x;
  if (nl > 0) {
    x = drive(train_bound, theta);
    factors(train_bound, theta, x, mul, add);
  }
  const std::vector<char> at_cap = atCap(train_bound, theta, coef);  // the curve does not move these rows
  Eigen::MatrixXd JtJ = Eigen::MatrixXd::Zero(ncol, ncol);
  Eigen::VectorXd jrow(ncol);
  double row[64];
  bool finite = true;
  for (std::size_t i = 0; i < r.n && finite; ++i) {
    const auto ri = static_cast<Eigen::Index>(i);
    if (nl > 0) basisRow(x[i], mul[ri], row);
    for (std::size_t k = 0; k < active.size(); ++k) jrow[static_cast<Eigen::Index>(k)] = at_cap[i] ? 0.0 : row[active[k]];
    for (Eigen::Index j = 0; j < np; ++j)
      jrow[static_cast<Eigen::Index>(active.size()) + j] = dcol[static_cast<std::size_t>(j)][ri];
    finite = jrow.allFinite();
    for (Eigen::Index a = 0; a < ncol; ++a)
      for (Eigen::Index b = 0; b <= a; ++b) JtJ(a, b) += jrow[a] * jrow[b];
  }
  if (!finite) return sig;
  JtJ = JtJ.selfadjointView<Eigen::Lower>();
  const double dof = std::max(static_cast<double>(r.n) - static_cast<double>(ncol - held), 1.0);
  const double s2 = r.rss / dof;
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(JtJ);
  const Eigen::MatrixXd cov = cod.pseudoInverse() * s2;
  for (Eigen::Index j = 0; j < ncol; ++j) sig[j] = std::sqrt(std::max(cov(j, j), 0.0));
  for (Eigen::Index j = 0; j < np; ++j)
    if (defs[static_cast<std::size_t>(j)].fixed) sig[static_cast<Eigen::Index>(active.size()) + j] = kNaN;
  if (cod.rank() < ncol - held)
    r.warnings.push_back(fmt::format("{} parameter combination(s) are not determined by the data "
                                     "(their uncertainties are not meaningful)", ncol - held - cod.rank()));
  return sig;
}

// Every parameter with its uncertainty and, for the nonlinear ones, whether it stopped at a
// bound of its range.
void Model::Impl::paramsOf(FitResult& r, const Eigen::VectorXd& sig, const std::vector<Eigen::Index>& active, Eigen::Index nl,
              bool uncertainties) const {
  const Eigen::Index np = static_cast<Eigen::Index>(defs.size());
  for (Eigen::Index j = 0; j < nl; ++j) {
    Param pr;
    pr.name = linear->linearName(static_cast<int>(j));
    pr.unit = "g";
    pr.effect = linear_effect;
    pr.value = coef[j];
    pr.sigma = uncertainties ? 0.0 : kNaN;
    for (std::size_t k = 0; k < active.size(); ++k)
      if (active[k] == j) pr.sigma = sig[static_cast<Eigen::Index>(k)];
    r.params.push_back(pr);
  }
  for (Eigen::Index j = 0; j < np; ++j) {
    const auto& d = defs[static_cast<std::size_t>(j)];
    Param pr;
    pr.name = d.name;
    pr.unit = d.unit;
    pr.effect = d.effect;
    pr.value = theta[j];
    pr.sigma = sig[static_cast<Eigen::Index>(active.size()) + j];
    pr.fixed = d.fixed;
    const double tol = 1e-6 * std::fabs(d.scale);
    if (!d.fixed && (theta[j] <= d.lo + tol || theta[j] >= d.hi - tol)) {
      pr.at_bound = true;
      pr.bound = theta[j] <= d.lo + tol ? d.lo : d.hi;
      r.warnings.push_back(fmt::format("{} stopped at its bound {:.6g}", d.name, pr.bound));
    }
    r.params.push_back(pr);
  }
}

// `warm_rss`: the smaller model's RSS on these rows (its curve coefficients are in `warm`),
// so its optimum need not be evaluated again; NaN: evaluate it.
FitResult Model::Impl::fit(const std::vector<Param>* warm, bool warm_only, bool uncertainties, double warm_rss) {
  FitResult r;
  r.model = spec.text();
  const Eigen::Index np = static_cast<Eigen::Index>(defs.size());
  theta = initialTheta();
  double best_rss;
  if (np > 0) best_rss = search(warm, warm_only, warm_rss, r);
  else best_rss = rssAt(train_bound, y, theta, &coef);
  fitted = true;
  if (!uncertainties && fit_data && !own_base) return quickResult(r, best_rss);
  Eigen::VectorXd pred_c = coef;
  const Eigen::VectorXd pred = predictWith(train_bound, theta, pred_c, own_base, &y);
  const Eigen::Index nl = own_base ? 0 : coef.size();
  std::vector<Eigen::Index> active;
  for (Eigen::Index j = 0; j < nl; ++j)
    if (j == 0 || coef[j] > 0) active.push_back(j);
  const Eigen::Index ncol = static_cast<Eigen::Index>(active.size()) + np;
  errorsOf(r, pred, nl);
  Eigen::VectorXd sig = Eigen::VectorXd::Constant(ncol, kNaN);
  if (uncertainties && ncol > 0 && (y - pred).allFinite()) sig = sigmas(r, pred, active, nl);
  paramsOf(r, sig, active, nl, uncertainties);
  return r;
}

Model::Model(const ModelSpec& spec, const Dataset& train) : impl_(std::make_unique<Impl>(spec, train)) {}
Model::~Model() = default;
const ModelSpec& Model::spec() const { return impl_->spec; }
namespace {
// The model one effect smaller (the last user effect, else the last catalogue effect after the
// base): where a direct fit continues from. Empty when there is none.
ModelSpec smallerSpec(const ModelSpec& spec) {
  ModelSpec s = spec;
  if (!s.probes.empty()) s.probes.pop_back();
  else if (!s.user.empty()) s.user.pop_back();
  else if (s.effects.size() > 1) s.effects.pop_back();
  else return ModelSpec();
  return s;
}
}  // namespace

FitResult Model::fit(const std::vector<Param>* warm, bool warm_only, bool uncertainties, double warm_rss) {
  if (!warm) {
    // Continuation: fit the model one effect smaller (recursively, down to the base) and
    // start from its optimum as well as cold. A direct fit then equals the ladder that adds
    // the same effects one by one in the same order, and it never stops worse than the
    // smaller model.
    const ModelSpec smaller = smallerSpec(impl_->spec);
    if (!smaller.effects.empty() || !smaller.user.empty()) {
      std::unique_ptr<Model> m;
      try {
        m = std::make_unique<Model>(smaller, impl_->train);
      } catch (const std::invalid_argument&) {
        m.reset();  // the smaller model is not a model on its own (sag without voltage, ...)
      }
      if (m) {
        const FitResult prev = m->fit(nullptr, false, false);
        return impl_->fit(&prev.params, false, uncertainties, prev.rss);
      }
    }
  }
  return impl_->fit(warm, warm_only, uncertainties, warm_rss);
}
std::vector<double> Model::predict(const Dataset& data) const { return impl_->predict(data); }
std::vector<double> Model::motorVoltage(const Dataset& data) const { return impl_->motorVolts(data); }
double Model::startUs() const { return impl_->startUs(); }

FitResult fitModel(const Dataset& data, const ModelSpec& spec, const std::vector<Param>* warm,
                   bool warm_only, bool uncertainties, double warm_rss) {
  Model m(spec, data);
  return m.fit(warm, warm_only, uncertainties, warm_rss);
}

}  // namespace lab
