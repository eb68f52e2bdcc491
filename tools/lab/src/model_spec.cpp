#include "lab/model.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <map>
#include <stdexcept>

#include "csv_reader.hpp"
#include "lab/effect.hpp"

// The model's SPEC: the catalogue (from the effects' registry, effects/registry.cpp), parsing and
// combining SPECs, and the derived columns a model may use. The fitter is model_eval.cpp (the
// model bound to its data and evaluated) and model_fit.cpp (the search).

namespace lab {

namespace {

std::string trimCopy(const std::string& s) {
  std::size_t a = 0, b = s.size();
  while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
  while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
  return s.substr(a, b - a);
}

// A pressure column and its scale to pascal.
int pressureColumn(const Dataset& d, double& to_pa) {
  for (std::size_t c = 0; c < d.names.size(); ++c) {
    const std::string n = csv::lower(d.names[c]);
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
    s += effects::expressionDef(user[i].multiplicative).prefix + " " + user[i].expression;
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
  for (const auto& [name, value] : more.fixed) out.fixed[name] = value;
  for (const auto& e : more.effects)
    if (!out.has(e)) out.effects.push_back(e);
  out.user.insert(out.user.end(), more.user.begin(), more.user.end());
  return out;
}

void fixParameter(ModelSpec& spec, const std::string& text) {
  const auto eq = text.find('=');
  const std::string name = trimCopy(text.substr(0, eq));
  char* end = nullptr;
  const std::string value = eq == std::string::npos ? "" : trimCopy(text.substr(eq + 1));
  const double v = std::strtod(value.c_str(), &end);
  if (eq == std::string::npos || name.empty() || value.empty() || *end != '\0' || !std::isfinite(v))
    throw std::invalid_argument("--fix '" + text + "': expected NAME=VALUE, e.g. --fix tau_cell_s=0.03");
  // the name as an entry documents it (per-motor names end in _motor_ID)
  const auto motor = name.find("_motor_");
  const std::string documented = motor == std::string::npos ? name : name.substr(0, motor);
  std::string all;
  for (const auto* e : effects::registry())
    for (const auto& p : e->params) {
      const std::string base = p.name.size() > 8 && p.name.compare(p.name.size() - 8, 8, "_motor_N") == 0
                                   ? p.name.substr(0, p.name.size() - 8)
                                   : p.name;
      if (base == documented || p.name == name) {
        spec.fixed[name] = v;
        return;
      }
      if (e->role != effects::Role::kExpression) all += (all.empty() ? "" : ", ") + p.name;
    }
  throw std::invalid_argument("--fix " + name + ": no effect has a parameter of that name; they are: " + all);
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

}  // namespace lab
