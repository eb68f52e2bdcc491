#include "lab/model.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <unsupported/Eigen/LevenbergMarquardt>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <stdexcept>

#include "lab/effect.hpp"
#include "lab/stats.hpp"

// The fitter. The effects, their parameters and formulas are in effects/ (one file each, listed
// in effects/registry.cpp); this file parses a SPEC, sets the effects up on the training data
// and fits: the base's linear coefficients by non-negative least squares, every other parameter
// by Levenberg-Marquardt (variable projection).

namespace lab {

namespace {

using effects::FitParam;
using effects::Frame;
using effects::Rows;
using effects::Term;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Above this many rows the nonlinear parameters are searched on evenly spaced rows (the curve's
// coefficients, the errors and the uncertainties always use every row).
constexpr std::size_t kMaxFitRows = 20000;

std::string trimCopy(const std::string& s) {
  std::size_t a = 0, b = s.size();
  while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
  while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
  return s.substr(a, b - a);
}

// A pressure column and its scale to pascal.
int pressureColumn(const Dataset& d, double& to_pa) {
  for (std::size_t c = 0; c < d.names.size(); ++c) {
    std::string n = d.names[c];
    for (auto& ch : n) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    if (n.rfind("pressure", 0) != 0 && n.rfind("baro", 0) != 0 && n != "p_pa" && n != "p_hpa")
      continue;
    auto ends = [&](const char* s) {
      const std::string e(s);
      return n.size() >= e.size() && n.compare(n.size() - e.size(), e.size(), e) == 0;
    };
    if (ends("hpa") || ends("mbar")) to_pa = 100;
    else if (ends("kpa")) to_pa = 1000;
    else if (ends("pa")) to_pa = 1;
    else {
      double sum = 0;
      std::size_t k = 0;
      for (double v : d.columns[c])
        if (std::isfinite(v)) { sum += v; ++k; }
      const double mean = k ? sum / static_cast<double>(k) : 0;
      to_pa = mean > 20000 ? 1 : mean > 200 ? 100 : 1000;
    }
    return static_cast<int>(c);
  }
  return -1;
}

std::vector<EffectInfo> catalogue() {
  std::vector<EffectInfo> out;
  for (const auto* e : effects::registry())
    out.push_back({e->name, e->physics, e->columns, effects::parametersText(*e)});
  return out;
}

const effects::EffectDef* expressionDef(bool multiplicative) {
  for (const auto* e : effects::registry())
    if (e->role == effects::Role::kExpression && e->multiplicative == multiplicative) return e;
  throw std::logic_error("the effect registry has no expression effect");
}

}  // namespace

const std::vector<EffectInfo>& effectCatalogue() {
  static const std::vector<EffectInfo> all = catalogue();
  return all;
}

const EffectInfo* findEffect(const std::string& name) {
  for (const auto& e : effectCatalogue())
    if (e.name == name) return &e;
  return nullptr;
}


bool ModelSpec::has(const std::string& effect) const {
  return std::find(effects.begin(), effects.end(), effect) != effects.end();
}

std::string ModelSpec::text() const {
  std::string s;
  for (const auto& e : effects) s += (s.empty() ? "" : "+") + e;
  for (std::size_t i = 0; i < user.size(); ++i) {
    s += (s.empty() ? "" : "+");
    s += expressionDef(user[i].multiplicative)->prefix + " " + user[i].expression;
    if (i + 1 < user.size()) s += ";";
  }
  return s;
}

ModelSpec parseSpec(const std::string& spec) {
  ModelSpec out;
  std::size_t pos = 0;
  const std::string s = spec;
  while (pos < s.size()) {
    // next item: up to '+' (catalogue name) or, for mul:/add:, up to ';'
    std::size_t start = pos;
    while (start < s.size() && (std::isspace(static_cast<unsigned char>(s[start])) || s[start] == '+'))
      ++start;
    if (start >= s.size()) break;
    const std::string rest = s.substr(start);
    const effects::EffectDef* ex = nullptr;
    for (const auto* e : effects::registry())
      if (e->role == effects::Role::kExpression && rest.rfind(e->prefix, 0) == 0) ex = e;
    if (ex) {
      const std::size_t n = ex->prefix.size();
      const std::size_t end = s.find(';', start);
      const std::string expr = trimCopy(s.substr(start + n, end == std::string::npos ? std::string::npos : end - start - n));
      if (expr.empty())
        throw std::invalid_argument("'" + rest.substr(0, n) + "' needs an expression, e.g. mul: 1 + a*(temp_c - 25)");
      out.user.push_back({ex->multiplicative, expr});
      pos = end == std::string::npos ? s.size() : end + 1;
      continue;
    }
    const std::size_t end = s.find('+', start);
    const std::string name = trimCopy(s.substr(start, end == std::string::npos ? std::string::npos : end - start));
    pos = end == std::string::npos ? s.size() : end + 1;
    if (name.empty()) continue;
    const EffectInfo* e = findEffect(name);
    if (!e || name.find(':') != std::string::npos) {
      std::string names;
      for (const auto& c : effectCatalogue()) names += (names.empty() ? "" : ", ") + c.name;
      throw std::invalid_argument("unknown effect '" + name + "'; the catalogue has: " + names +
                                  " (see `thrustcal lab effects`)");
    }
    if (!out.has(name)) out.effects.push_back(name);
  }
  if (out.effects.empty() && out.user.empty())
    throw std::invalid_argument("empty model SPEC; start with `curve` (or `thesis`), e.g. curve+deadband");
  return out;
}

ModelSpec combine(const ModelSpec& base, const ModelSpec& more) {
  ModelSpec out = base;
  for (const auto& e : more.effects)
    if (!out.has(e)) out.effects.push_back(e);
  out.user.insert(out.user.end(), more.user.begin(), more.user.end());
  return out;
}

void addDerivedColumns(Dataset& data) {
  if (data.has("pwm_us") && !data.has("dpwm_us")) {
    const auto& pwm = data.col("pwm_us");
    std::vector<double> d(data.rows(), 0.0);
    std::map<int, std::size_t> last;
    for (std::size_t i = 0; i < data.rows(); ++i) {
      auto it = last.find(data.run[i]);
      if (it != last.end()) d[i] = pwm[i] - pwm[it->second];
      last[data.run[i]] = i;
    }
    data.set("dpwm_us", std::move(d));
  }
  double to_pa = 1;
  const int p = pressureColumn(data, to_pa);
  if (p >= 0 && data.has("temp_c") && !data.has("rho_kg_m3")) {
    const auto& t = data.col("temp_c");
    const auto& pr = data.columns[static_cast<std::size_t>(p)];
    std::vector<double> rho(data.rows());
    for (std::size_t i = 0; i < rho.size(); ++i) rho[i] = pr[i] * to_pa / (287.05 * (t[i] + 273.15));
    data.set("rho_kg_m3", std::move(rho));
  }
}

// ---------------------------------------------------------------------------------------------


struct Model::Impl {
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

  // The SPEC's rules that are about several effects: one base, what an effect needs.
  void checkSpec(std::vector<const effects::EffectDef*>& in_spec) {
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

  void setup() {
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
      make(*expressionDef(u.multiplicative), kExpressions, [&](effects::Setup& s) { return effects::makeExpression(s, u); });
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

  Rows bind(const Dataset& d) const {
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

  Frame frame(const Rows& b, const Eigen::VectorXd& th) const {
    return Frame{b, th, defs, terms, vref, xtop, pmin, span};
  }

  Eigen::VectorXd initialTheta() const {
    Eigen::VectorXd t(static_cast<Eigen::Index>(defs.size()));
    for (std::size_t i = 0; i < defs.size(); ++i) t[static_cast<Eigen::Index>(i)] = defs[i].init;
    return t;
  }

  double p(const Eigen::VectorXd& th, int i) const {
    return std::clamp(th[i], defs[static_cast<std::size_t>(i)].lo, defs[static_cast<std::size_t>(i)].hi);
  }

  // Where the drive counts from: a term's origin (deadband), else the smallest training PWM.
  double origin(const Frame& f) const { return f.startUs(); }

  // A drive for a base of its own (the effects that depend on it): PWM over the span.
  std::vector<double> plainDrive(const Rows& b) const {
    std::vector<double> x(b.n);
    for (std::size_t i = 0; i < b.n; ++i) x[i] = std::max(0.0, (*b.pwm)[i] - pmin) / span;
    return x;
  }

  // The drive x per row (curve models).
  std::vector<double> drive(const Rows& b, const Eigen::VectorXd& th) const {
    const Frame f = frame(b, th);
    const double start = origin(f);
    std::vector<double> x(b.n);
    for (std::size_t i = 0; i < b.n; ++i) x[i] = effects::softPlus((*b.pwm)[i] - start, effects::kSoftStartUs) / span;
    for (const Term* t : terms) t->drive(f, x);
    for (const Term* t : terms) t->filter(f, x);
    return x;
  }

  // Multiplicative factor and additive grams per row.
  void factors(const Rows& b, const Eigen::VectorXd& th, const std::vector<double>& x,
               Eigen::VectorXd& mul, Eigen::VectorXd& add) const {
    mul = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(b.n));
    add = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(b.n));
    const Frame f = frame(b, th);
    for (const Term* t : terms) t->factors(f, x, mul, add);
  }

  // The largest force per row the terms allow (current_limit); empty when no term caps.
  std::vector<double> capsOf(const Rows& b, const Eigen::VectorXd& th) const {
    std::vector<double> cap(b.n, std::numeric_limits<double>::infinity());
    const Frame f = frame(b, th);
    bool any = false;
    for (const Term* t : terms) any = t->caps(f, cap) || any;
    if (!any) cap.clear();
    return cap;
  }

  int basisSize() const { return linear ? linear->linearSize() : 0; }  // incl. the constant

  // Row i of the design matrix of the linear parameters: 1 (the offset), then mul * S_j(x).
  void basisRow(double x, double mul, double* row) const { linear->linearRow(x, mul, row); }

  // The force of a base of its own, from the PWM after the terms' filters (lag).
  Eigen::VectorXd ownBase(const Rows& b, const Eigen::VectorXd& th) const {
    const Frame f = frame(b, th);
    std::vector<double> pw(b.pwm->begin(), b.pwm->end());
    for (const Term* t : terms) t->filter(f, pw);
    Eigen::VectorXd out;
    own->ownForce(f, pw, out);
    return out;
  }

  using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  // The normal equations of the curve's coefficients, G = B'B, h = B'r, rr = r'r with
  // r = target - add, summed over blocks of rows (vectorised rank updates; the n x k matrix B is
  // not kept unless `keep` asks for it, row-major). False when a row is not finite.
  bool normalEquations(const Rows& b, const std::vector<double>& x, const Eigen::VectorXd& mul,
                       const Eigen::VectorXd& add, const Eigen::VectorXd& target, Eigen::MatrixXd& G,
                       Eigen::VectorXd& h, double& rr, std::vector<double>* keep,
                       const std::vector<char>* skip = nullptr) const {
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

  Eigen::VectorXd solveCurve(const Eigen::MatrixXd& G, const Eigen::VectorXd& h) const {
    std::vector<bool> nonneg(static_cast<std::size_t>(G.cols()), true);
    nonneg[0] = false;  // the offset is free
    return nnlsGram(G, h, nonneg);
  }

  // Prediction with the linear coefficients solved (when `solve`) or taken from `c`.
  Eigen::VectorXd predictWith(const Rows& b, const Eigen::VectorXd& th, Eigen::VectorXd& c, bool solve,
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
  Eigen::VectorXd uncapped(const Rows& b, const std::vector<double>& x, const Eigen::VectorXd& mul,
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
  Eigen::VectorXd predictCapped(const Rows& b, const Eigen::VectorXd& th, const std::vector<double>& x,
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
  void applyCap(const Rows& b, const Eigen::VectorXd& th, const std::vector<double>& cap, Eigen::VectorXd& force) const {
    const Frame f = frame(b, th);
    for (const Term* t : terms)
      if (t->underCap(f, cap, force)) return;
    for (std::size_t i = 0; i < b.n; ++i) force[static_cast<Eigen::Index>(i)] = std::min(force[static_cast<Eigen::Index>(i)], cap[i]);
  }

  // The rows where the curve's force is above the cap (they do not depend on the curve).
  std::vector<char> atCap(const Rows& b, const Eigen::VectorXd& th, const Eigen::VectorXd& c) const {
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

  double rssAt(const Rows& b, const Eigen::VectorXd& target, const Eigen::VectorXd& th,
               Eigen::VectorXd* coef_out = nullptr) const {
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

  // Levenberg-Marquardt over the nonlinear parameters on the fit rows, each step solving the
  // curve linearly (variable projection).
  struct Functor : Eigen::DenseFunctor<double> {
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
  Eigen::VectorXd runLm(const Eigen::VectorXd& start, FitResult& r, bool quick = false,
                        const std::vector<bool>* fixed = nullptr) const {
    const Eigen::Index np = static_cast<Eigen::Index>(defs.size());
    Eigen::VectorXd sc(np);
    std::vector<Eigen::Index> moving;
    for (Eigen::Index i = 0; i < np; ++i) {
      sc[i] = defs[static_cast<std::size_t>(i)].scale;
      if (!fixed || !(*fixed)[static_cast<std::size_t>(i)]) moving.push_back(i);
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
  bool warmCurve(const std::vector<Param>& warm, Eigen::VectorXd& c) const {
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
  Eigen::VectorXd warmStart(const std::vector<Param>& warm, bool neutral = true) const {
    Eigen::VectorXd start = initialTheta();
    for (std::size_t i = 0; i < defs.size(); ++i) {
      const auto& d = defs[i];
      bool found = false;
      for (const auto& w : warm)
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
  Eigen::VectorXd scanStart(Eigen::VectorXd th, const std::vector<Param>* known) const {
    const double inf = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < defs.size(); ++j) {
      const auto i = static_cast<Eigen::Index>(j);
      const double lo = defs[j].scan_from;
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
  double search(const std::vector<Param>* warm, bool warm_only, double warm_rss, FitResult& r) {
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
  FitResult quickResult(FitResult& r, double best_rss) const {
    const Eigen::Index np = static_cast<Eigen::Index>(defs.size());
    r.n = static_cast<std::size_t>(y.size());
    r.k = static_cast<int>(coef.size() + np);
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
    }
    return r;
  }

  // The errors and criteria of the fit on every row, and the warnings about it.
  void errorsOf(FitResult& r, const Eigen::VectorXd& pred, Eigen::Index nl) const {
    const Eigen::Index np = static_cast<Eigen::Index>(defs.size());
    r.n = static_cast<std::size_t>(y.size());
    r.k = static_cast<int>(nl + np) + (own ? own->countedParams() : 0);
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
  Eigen::VectorXd sigmas(FitResult& r, const Eigen::VectorXd& pred, const std::vector<Eigen::Index>& active,
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
      dcol[static_cast<std::size_t>(j)] = (predictWith(train_bound, tp, c, false, nullptr) - pred) / h;
    }
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
    const double dof = std::max(static_cast<double>(r.n) - static_cast<double>(ncol), 1.0);
    const double s2 = r.rss / dof;
    Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(JtJ);
    const Eigen::MatrixXd cov = cod.pseudoInverse() * s2;
    for (Eigen::Index j = 0; j < ncol; ++j) sig[j] = std::sqrt(std::max(cov(j, j), 0.0));
    if (cod.rank() < ncol)
      r.warnings.push_back(fmt::format("{} parameter combination(s) are not determined by the data "
                                       "(their uncertainties are not meaningful)", ncol - cod.rank()));
    return sig;
  }

  // Every parameter with its uncertainty and, for the nonlinear ones, whether it stopped at a
  // bound of its range.
  void paramsOf(FitResult& r, const Eigen::VectorXd& sig, const std::vector<Eigen::Index>& active, Eigen::Index nl,
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
      const double tol = 1e-6 * std::fabs(d.scale);
      if (theta[j] <= d.lo + tol || theta[j] >= d.hi - tol) {
        pr.at_bound = true;
        pr.bound = theta[j] <= d.lo + tol ? d.lo : d.hi;
        r.warnings.push_back(fmt::format("{} stopped at its bound {:.6g}", d.name, pr.bound));
      }
      r.params.push_back(pr);
    }
  }

  // `warm_rss`: the smaller model's RSS on these rows (its curve coefficients are in `warm`),
  // so its optimum need not be evaluated again; NaN: evaluate it.
  FitResult fit(const std::vector<Param>* warm, bool warm_only, bool uncertainties, double warm_rss) {
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

  std::vector<double> predict(const Dataset& d) const {
    if (!fitted) throw std::logic_error("predict before fit");
    Rows b = bind(d);
    Eigen::VectorXd c = coef;
    const Eigen::VectorXd pred = predictWith(b, theta, c, false, nullptr);
    return std::vector<double>(pred.data(), pred.data() + pred.size());
  }

  std::vector<double> motorVolts(const Dataset& d) const {
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

  double startUs() const {
    if (!fitted) throw std::logic_error("startUs before fit");
    return origin(frame(train_bound, theta));
  }
};

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
