// The model bound to its data: the effects set up on the training data (in registry order), the
// drive, factors and caps they give each row, and the prediction with the curve's coefficients
// solved by non-negative least squares on the normal equations. The search is model_fit.cpp.
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "lab/effect.hpp"
#include "lab/stats.hpp"
#include "model_impl.hpp"

namespace lab {

using effects::FitParam;
using effects::Frame;
using effects::Rows;
using effects::Term;

// The SPEC's rules that are about several effects: one base, what an effect needs.
void Model::Impl::checkSpec(std::vector<const effects::EffectDef*>& in_spec) {
  const effects::EffectDef* base = nullptr;
  const effects::EffectDef* default_base = nullptr;
  for (const auto* d : effects::registry())
    if (d->role == effects::Role::kBase && !default_base) default_base = d;
  for (const auto& name : spec.effects) {
    const auto* d = effects::find(name);
    if (!d || d->role == effects::Role::kExpression)
      throw std::invalid_argument("unknown effect '" + name + "' (see `thrustcal lab effects`)");
    if (d->role != effects::Role::kBase) continue;
    if (base) {
      const bool later = effects::registryIndex(d->name) > effects::registryIndex(base->name);
      throw std::invalid_argument(fmt::format("`{}` and `{}` are both base models; use one of them",
                                              later ? d->name : base->name, later ? base->name : d->name));
    }
    base = d;
  }
  if (!base) {
    spec.effects.insert(spec.effects.begin(), default_base->name);
    base = default_base;
  }
  for (const auto* d : effects::registry())
    if (d->shapes_curve && base != default_base && spec.has(d->name))
      throw std::invalid_argument(fmt::format(
          "`{}` shapes the `{}` base; the {} model has its own curve and voltage "
          "handling. Compare with a curve model instead, e.g. curve+deadband+voltage",
          d->name, default_base->name, base->name));
  for (const auto* d : effects::registry())
    if (!d->needs.empty() && spec.has(d->name) && !spec.has(d->needs))
      throw std::invalid_argument(fmt::format("`{}` {}; add `{}` before it", d->name, d->needs_why, d->needs));
  for (const auto& name : spec.effects) in_spec.push_back(effects::find(name));
}

void Model::Impl::setup() {
  std::vector<const effects::EffectDef*> in_spec;
  checkSpec(in_spec);
  const auto& pwm = train.col("pwm_us");
  pmin = *std::min_element(pwm.begin(), pwm.end());
  const double pmax = *std::max_element(pwm.begin(), pwm.end());
  span = std::max(pmax - pmin, 1e-9);
  if (effects::Setup::usable(train, "vbat_v")) {
    const auto& v = train.col("vbat_v");
    vref = *std::max_element(v.begin(), v.end());
    if (!(vref > 0)) vref = 1;
  }
  const auto& f = train.col("force_g");
  const double fmax = *std::max_element(f.begin(), f.end());

  // each term's place in the evaluation order: its registry line; probes, then expressions last
  std::vector<std::pair<int, const Term*>> order;
  auto make = [&](const effects::EffectDef& def, int key, auto&& build) {
    effects::Setup s(train, def, defs, motor_ids);
    s.fixes = &spec.fixed;
    s.pmin = pmin, s.pmax = pmax, s.span = span, s.vref = vref, s.fmax = fmax;
    owned.push_back(build(s));
    order.emplace_back(key, owned.back().get());
    return owned.back().get();
  };
  for (const auto* d : in_spec) {
    const Term* t = make(*d, effects::registryIndex(d->name), [&](effects::Setup& s) { return d->make(s); });
    if (t->linearSize() > 0) linear = t, linear_effect = d->name;
    if (t->hasOwnForce()) own = t;
  }
  const int kProbes = static_cast<int>(effects::registry().size()), kExpressions = kProbes + 1;
  for (const auto& u : spec.user)
    make(effects::expressionDef(u.multiplicative), kExpressions, [&](effects::Setup& s) { return effects::makeExpression(s, u); });
  for (const auto& pr : spec.probes)
    make(effects::probeDef(), kProbes, [&](effects::Setup& s) { return effects::makeProbe(s, pr); });
  std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& o : order) terms.push_back(o.second);
  own_base = own != nullptr;
  xtop = linear ? linear->driveTop() : 1.0;

  train_bound = bind(train);
  capped = !capsOf(train_bound, initialTheta()).empty();
  y = Eigen::Map<const Eigen::VectorXd>(f.data(), static_cast<Eigen::Index>(f.size()));
  if (train.rows() > kMaxFitRows) {
    const std::size_t stride = (train.rows() + kMaxFitRows - 1) / kMaxFitRows;
    std::vector<bool> keep(train.rows(), false);
    for (std::size_t i = 0; i < train.rows(); i += stride) {
      keep[i] = true;
      fit_index.push_back(static_cast<double>(i));
    }
    fit_data = std::make_unique<Dataset>(train.subset(keep));
    fit_bound = bind(*fit_data);
    fit_bound.sample_index = &fit_index;
    const auto& fs = fit_data->col("force_g");
    y_fit = Eigen::Map<const Eigen::VectorXd>(fs.data(), static_cast<Eigen::Index>(fs.size()));
  } else {
    fit_bound = train_bound;
    y_fit = y;
  }
}

Rows Model::Impl::bind(const Dataset& d) const {
  Rows b;
  b.n = d.rows();
  b.data = &d;
  b.pwm = &d.col("pwm_us");
  auto opt = [&](const char* name) { return d.has(name) ? &d.col(name) : nullptr; };
  b.vbat = opt("vbat_v");
  b.current = opt("current_a");
  b.t = opt("t_s");
  b.temp = opt("temp_c");
  b.rho = opt("rho_kg_m3");
  b.run = &d.run;
  const auto* motor = opt("motor");
  b.motor_index.assign(b.n, 0);
  if (!motor_ids.empty()) {
    const auto& ids = motor_ids;
    for (std::size_t i = 0; i < b.n; ++i) {
      const long m = motor && std::isfinite((*motor)[i]) ? std::lround((*motor)[i]) : ids.empty() ? 0 : ids[0];
      const auto it = std::find(ids.begin(), ids.end(), m);
      b.motor_index[i] = it == ids.end() ? -1 : static_cast<int>(it - ids.begin());
    }
  }
  for (const Term* t : terms) t->check(d);
  for (const Term* t : terms) {
    std::vector<double> v = t->perRow(d);
    if (!v.empty()) b.derived[t] = std::move(v);
  }
  return b;
}

Eigen::VectorXd Model::Impl::initialTheta() const {
  Eigen::VectorXd t(static_cast<Eigen::Index>(defs.size()));
  for (std::size_t i = 0; i < defs.size(); ++i) t[static_cast<Eigen::Index>(i)] = defs[i].init;
  return t;
}

// A drive for a base of its own (the effects that depend on it): PWM over the span.
std::vector<double> Model::Impl::plainDrive(const Rows& b) const {
  std::vector<double> x(b.n);
  for (std::size_t i = 0; i < b.n; ++i) x[i] = std::max(0.0, (*b.pwm)[i] - pmin) / span;
  return x;
}

// The drive x per row (curve models).
std::vector<double> Model::Impl::drive(const Rows& b, const Eigen::VectorXd& th) const {
  const Frame f = frame(b, th);
  const double start = origin(f);
  std::vector<double> x(b.n);
  for (std::size_t i = 0; i < b.n; ++i) x[i] = effects::softPlus((*b.pwm)[i] - start, effects::kSoftStartUs) / span;
  for (const Term* t : terms) t->drive(f, x);
  for (const Term* t : terms) t->filter(f, x);
  return x;
}

// Multiplicative factor and additive grams per row.
void Model::Impl::factors(const Rows& b, const Eigen::VectorXd& th, const std::vector<double>& x,
             Eigen::VectorXd& mul, Eigen::VectorXd& add) const {
  mul = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(b.n));
  add = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(b.n));
  const Frame f = frame(b, th);
  for (const Term* t : terms) t->factors(f, x, mul, add);
}

// The largest force per row the terms allow (current_limit); empty when no term caps.
std::vector<double> Model::Impl::capsOf(const Rows& b, const Eigen::VectorXd& th) const {
  std::vector<double> cap(b.n, std::numeric_limits<double>::infinity());
  const Frame f = frame(b, th);
  bool any = false;
  for (const Term* t : terms) any = t->caps(f, cap) || any;
  if (!any) cap.clear();
  return cap;
}

// The force of a base of its own, from the PWM after the terms' filters (lag).
Eigen::VectorXd Model::Impl::ownBase(const Rows& b, const Eigen::VectorXd& th) const {
  const Frame f = frame(b, th);
  std::vector<double> pw(b.pwm->begin(), b.pwm->end());
  for (const Term* t : terms) t->filter(f, pw);
  Eigen::VectorXd out;
  own->ownForce(f, pw, out);
  return out;
}

// The normal equations of the curve's coefficients, G = B'B, h = B'r, rr = r'r with
// r = target - add, summed over blocks of rows (vectorised rank updates; the n x k matrix B is
// not kept unless `keep` asks for it, row-major). False when a row is not finite.
bool Model::Impl::normalEquations(const Rows& b, const std::vector<double>& x, const Eigen::VectorXd& mul,
                     const Eigen::VectorXd& add, const Eigen::VectorXd& target, Eigen::MatrixXd& G,
                     Eigen::VectorXd& h, double& rr, std::vector<double>* keep,
                     const std::vector<char>* skip) const {
  const int nb = basisSize();
  constexpr Eigen::Index kBlock = 512;
  G = Eigen::MatrixXd::Zero(nb, nb);
  h = Eigen::VectorXd::Zero(nb);
  rr = 0;
  RowMatrix blk(kBlock, nb);
  Eigen::VectorXd rblk(kBlock);
  if (keep) keep->resize(b.n * static_cast<std::size_t>(nb));
  Eigen::Index k = 0;
  auto flush = [&] {
    if (k == 0) return;
    G.selfadjointView<Eigen::Lower>().rankUpdate(blk.topRows(k).transpose());
    h.noalias() += blk.topRows(k).transpose() * rblk.head(k);
    rr += rblk.head(k).squaredNorm();
    k = 0;
  };
  for (std::size_t i = 0; i < b.n; ++i) {
    if (skip && (*skip)[i]) continue;
    const auto r = static_cast<Eigen::Index>(i);
    const double rhs = target[r] - add[r];
    double* row = blk.row(k).data();
    basisRow(x[i], mul[r], row);
    bool finite = std::isfinite(rhs);
    for (int a = 0; a < nb && finite; ++a) finite = std::isfinite(row[a]);
    if (!finite) return false;
    if (keep) std::copy(row, row + nb, keep->data() + i * static_cast<std::size_t>(nb));
    rblk[k++] = rhs;
    if (k == kBlock) flush();
  }
  flush();
  G = G.selfadjointView<Eigen::Lower>();
  return true;
}

Eigen::VectorXd Model::Impl::solveCurve(const Eigen::MatrixXd& G, const Eigen::VectorXd& h) const {
  std::vector<bool> nonneg(static_cast<std::size_t>(G.cols()), true);
  nonneg[0] = false;  // the offset is free
  return nnlsGram(G, h, nonneg);
}

// Prediction with the linear coefficients solved (when `solve`) or taken from `c`.
Eigen::VectorXd Model::Impl::predictWith(const Rows& b, const Eigen::VectorXd& th, Eigen::VectorXd& c, bool solve,
                            const Eigen::VectorXd* target) const {
  Eigen::VectorXd mul, add;
  const std::vector<double> x = own_base ? plainDrive(b) : drive(b, th);
  factors(b, th, x, mul, add);
  const std::vector<double> cap = capsOf(b, th);
  if (own_base) {
    Eigen::VectorXd out = mul.cwiseProduct(ownBase(b, th)) + add;
    if (!cap.empty()) applyCap(b, th, cap, out);
    return out;
  }
  if (!cap.empty()) return predictCapped(b, th, x, mul, add, cap, c, solve, target);
  const int nb = basisSize();
  // the rows of the design matrix are kept between the two passes when they are few
  thread_local std::vector<double> cache;
  const bool cached = solve && b.n * static_cast<std::size_t>(nb) <= (1u << 20);
  if (solve) {
    Eigen::MatrixXd G;
    Eigen::VectorXd h;
    double rr;
    if (!normalEquations(b, x, mul, add, *target, G, h, rr, cached ? &cache : nullptr)) {
      c = Eigen::VectorXd::Zero(nb);
      return Eigen::VectorXd::Constant(static_cast<Eigen::Index>(b.n), kNaN);
    }
    c = solveCurve(G, h);
  }
  if (cached) {
    const Eigen::Map<const RowMatrix> B(cache.data(), static_cast<Eigen::Index>(b.n), nb);
    return B * c + add;
  }
  return uncapped(b, x, mul, add, c);
}

// The curve's prediction on every row (no cap), from the coefficients c.
Eigen::VectorXd Model::Impl::uncapped(const Rows& b, const std::vector<double>& x, const Eigen::VectorXd& mul,
                         const Eigen::VectorXd& add, const Eigen::VectorXd& c) const {
  const int nb = basisSize();
  Eigen::VectorXd out(static_cast<Eigen::Index>(b.n));
  double row[64];
  for (std::size_t i = 0; i < b.n; ++i) {
    const auto r = static_cast<Eigen::Index>(i);
    basisRow(x[i], mul[r], row);
    double v = add[r];
    for (int a = 0; a < nb; ++a) v += row[a] * c[a];
    out[r] = v;
  }
  return out;
}

// min(curve, cap) per row. Solving: the rows at the cap do not depend on the curve, so its
// coefficients are solved on the rows below it, and the rows at the cap found again from the
// new curve until they stay the same (a few passes).
Eigen::VectorXd Model::Impl::predictCapped(const Rows& b, const Eigen::VectorXd& th, const std::vector<double>& x,
                              const Eigen::VectorXd& mul, const Eigen::VectorXd& add, const std::vector<double>& cap,
                              Eigen::VectorXd& c, bool solve, const Eigen::VectorXd* target) const {
  const int nb = basisSize();
  Eigen::VectorXd free_force;
  if (!solve) {
    free_force = uncapped(b, x, mul, add, c);
  } else {
    std::vector<char> at_cap(b.n, 0);
    for (int pass = 0; pass < 8; ++pass) {
      Eigen::MatrixXd G;
      Eigen::VectorXd h;
      double rr;
      if (!normalEquations(b, x, mul, add, *target, G, h, rr, nullptr, &at_cap)) {
        c = Eigen::VectorXd::Zero(nb);
        return Eigen::VectorXd::Constant(static_cast<Eigen::Index>(b.n), kNaN);
      }
      c = solveCurve(G, h);
      free_force = uncapped(b, x, mul, add, c);
      bool same = true;
      for (std::size_t i = 0; i < b.n; ++i) {
        const char now = free_force[static_cast<Eigen::Index>(i)] > cap[i];
        same = same && now == at_cap[i];
        at_cap[i] = now;
      }
      if (same) break;
    }
  }
  applyCap(b, th, cap, free_force);
  return free_force;
}

// force = min(force, cap), or what a term says the force under its cap is.
void Model::Impl::applyCap(const Rows& b, const Eigen::VectorXd& th, const std::vector<double>& cap, Eigen::VectorXd& force) const {
  const Frame f = frame(b, th);
  for (const Term* t : terms)
    if (t->underCap(f, cap, force)) return;
  for (std::size_t i = 0; i < b.n; ++i) force[static_cast<Eigen::Index>(i)] = std::min(force[static_cast<Eigen::Index>(i)], cap[i]);
}

// The rows where the curve's force is above the cap (they do not depend on the curve).
std::vector<char> Model::Impl::atCap(const Rows& b, const Eigen::VectorXd& th, const Eigen::VectorXd& c) const {
  const std::vector<double> cap = capsOf(b, th);
  std::vector<char> at(b.n, 0);
  if (cap.empty() || own_base) return at;
  Eigen::VectorXd mul, add;
  const std::vector<double> x = drive(b, th);
  factors(b, th, x, mul, add);
  const Eigen::VectorXd free_force = uncapped(b, x, mul, add, c);
  for (std::size_t i = 0; i < b.n; ++i) at[i] = free_force[static_cast<Eigen::Index>(i)] > cap[i];
  return at;
}

double Model::Impl::rssAt(const Rows& b, const Eigen::VectorXd& target, const Eigen::VectorXd& th,
             Eigen::VectorXd* coef_out) const {
  Eigen::VectorXd c;
  double rss;
  if (!own_base && b.n > kMaxFitRows && !capped) {
    // Many rows: RSS = r'r - 2 c'h + c'Gc from the normal equations, one pass over the rows.
    Eigen::VectorXd mul, add;
    const std::vector<double> x = drive(b, th);
    factors(b, th, x, mul, add);
    Eigen::MatrixXd G;
    Eigen::VectorXd h;
    double rr;
    if (normalEquations(b, x, mul, add, target, G, h, rr, nullptr)) {
      c = solveCurve(G, h);
      rss = std::max(0.0, rr - 2.0 * c.dot(h) + c.dot(G * c));
    } else {
      c = Eigen::VectorXd::Zero(basisSize());
      rss = kNaN;
    }
  } else {
    rss = (target - predictWith(b, th, c, true, &target)).squaredNorm();
  }
  if (coef_out) *coef_out = c;
  return std::isfinite(rss) ? rss : std::numeric_limits<double>::infinity();
}

std::vector<double> Model::Impl::predict(const Dataset& d) const {
  if (!fitted) throw std::logic_error("predict before fit");
  Rows b = bind(d);
  Eigen::VectorXd c = coef;
  const Eigen::VectorXd pred = predictWith(b, theta, c, false, nullptr);
  return std::vector<double>(pred.data(), pred.data() + pred.size());
}

std::vector<double> Model::Impl::motorVolts(const Dataset& d) const {
  if (!fitted) throw std::logic_error("motorVoltage before fit");
  Rows b = bind(d);
  std::vector<double> v(b.n, kNaN);
  if (!b.vbat) return v;
  const Frame f = frame(b, theta);
  const double start = origin(f);
  for (std::size_t i = 0; i < b.n; ++i) {
    const double pw = (*b.pwm)[i];
    const double duty = effects::softPlus(pw - start, effects::kSoftStartUs) / span;
    v[i] = f.volts(i, duty);
  }
  return v;
}

double Model::Impl::startUs() const {
  if (!fitted) throw std::logic_error("startUs before fit");
  return origin(frame(train_bound, theta));
}

}  // namespace lab
