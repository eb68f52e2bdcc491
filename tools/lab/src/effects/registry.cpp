// The lab's effect registry: one line per effect, in the order the model evaluates them and
// `thrustcal lab effects` lists them. Each effect's entry and formula are in its own file here.
#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>

#include "lab/effect.hpp"

namespace lab::effects {

extern const EffectDef kCurve, kDeadband, kVoltage, kSag, kMotor, kDrift, kLag, kCell, kThermal, kDensity,
    kCurrentLimit, kThesis, kMul, kAdd;

const std::vector<const EffectDef*>& registry() {
  static const std::vector<const EffectDef*> all = {
      &kCurve,    // curve.cpp: base, a monotone spline of the drive
      &kDeadband, // deadband.cpp: ESC start threshold
      &kVoltage,  // voltage.cpp: drive scaled by (V/V_ref)^gamma
      &kSag,      // sag.cpp: the voltage the motor sees under load
      &kMotor,    // motor.cpp: per-motor gain and Kv
      &kDrift,    // drift.cpp: grams per minute
      &kLag,      // lag.cpp: first-order low-pass of the drive
      &kCell,     // cell.cpp: the bench's own response after the lag
      &kThermal,  // thermal.cpp: temperature factor
      &kDensity,  // density.cpp: air-density factor
      &kCurrentLimit,  // current_limit.cpp: the force a capped bus current allows
      &kThesis,   // thesis.cpp: base, the firmware's option 2.1 through core/
      &kMul,      // expression.cpp: mul: EXPR
      &kAdd,      // expression.cpp: add: EXPR
  };
  return all;
}

const EffectDef* find(const std::string& name) {
  for (const auto* e : registry())
    if (e->name == name) return e;
  return nullptr;
}

const EffectDef& expressionDef(bool multiplicative) {
  for (const auto* e : registry())
    if (e->role == Role::kExpression && e->multiplicative == multiplicative) return *e;
  throw std::logic_error("the effect registry has no expression effect");
}

int registryIndex(const std::string& name) {
  const auto& r = registry();
  for (std::size_t i = 0; i < r.size(); ++i)
    if (r[i]->name == name) return static_cast<int>(i);
  return -1;
}

double Frame::volts(std::size_t i, double duty) const {
  double v = (*rows.vbat)[i];
  for (const Term* t : terms) v = t->sag(*this, i, duty, v);
  return std::max(v, 1e-3 * vref);
}

double Frame::startUs() const {
  double start = pmin;
  for (const Term* t : terms)
    if (t->origin(*this, start)) break;
  return start;
}

bool Setup::usable(const Dataset& d, const char* column) {
  if (!d.has(column)) return false;
  for (double v : d.col(column))
    if (!std::isfinite(v)) return false;
  return true;
}

void Setup::require(const char* column) const {
  if (!usable(column))
    throw std::invalid_argument(fmt::format("effect `{}` needs the column {} (logged on every row); the data has: {}",
                                            def.name, column, fmt::join(train.names, ", ")));
}

double Setup::mean(const char* column) const {
  const auto& c = train.col(column);
  double sum = 0;
  for (double v : c) sum += v;
  return sum / static_cast<double>(c.size());
}

FitParam Setup::param(std::size_t k) const {
  const ParamSpec& s = def.params.at(k);
  FitParam p{s.name, s.unit, def.name, s.init, s.scale, s.lo, s.hi, s.neutral};
  p.fixed = s.fixed;
  return p;
}

int Setup::add(const FitParam& p) {
  params.push_back(p);
  if (fixes)
    if (const auto it = fixes->find(p.name); it != fixes->end()) {
      params.back().init = params.back().neutral = std::clamp(it->second, p.lo, p.hi);
      params.back().fixed = true;
    }
  return static_cast<int>(params.size()) - 1;
}

namespace {
std::string number(double v) {
  if (v <= -kUnbounded) return "-inf";
  if (v >= kUnbounded) return "inf";
  return fmt::format("{:g}", v);
}
}  // namespace

std::string parametersText(const EffectDef& e) {
  std::string s;
  for (const auto& p : e.params) {
    s += (s.empty() ? "" : "; ") + fmt::format("{} [{}]", p.name, p.unit);
    if (e.role != Role::kExpression)
      s += !p.from_data.empty()                           ? " (" + p.from_data + ")"
           : p.lo <= -kUnbounded && p.hi >= kUnbounded ? std::string(" unbounded")
                                                         : fmt::format(" {}..{}", number(p.lo), number(p.hi));
    s += ": " + p.meaning;
  }
  return s.empty() ? "none fitted" : s;
}

std::string markdownTable() {
  std::string s = "| effect | columns | parameters [unit] range: meaning |\n|---|---|---|\n";
  for (const auto* e : registry()) {
    std::string params = parametersText(*e);
    std::replace(params.begin(), params.end(), '|', '/');
    s += fmt::format("| `{}` | {} | {} |\n", e->name, e->columns, params);
  }
  return s;
}

}  // namespace lab::effects
