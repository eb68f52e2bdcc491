#include "lab/model.hpp"

#include <fmt/format.h>
#include <muParser.h>

#include <Eigen/Dense>
#include <unsupported/Eigen/LevenbergMarquardt>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>

#include "lab/stats.hpp"
#include "thrustcal/battery_monitor.hpp"
#include "thrustcal/curve_builder.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/motor_calibration.hpp"

namespace lab {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kSplineDegree = 3;     // cubic B-splines
constexpr int kInteriorKnots = 6;    // at quantiles of the drive
constexpr double kSoftStartUs = 2.0;
// Above this many rows the nonlinear parameters are searched on evenly spaced rows (the curve's
// coefficients, the errors and the uncertainties always use every row).
constexpr std::size_t kMaxFitRows = 20000;

const std::vector<EffectInfo> kCatalogue = {
    {"curve",
     "Base force curve: smooth and monotone in the drive x (PWM above the start, scaled by the "
     "voltage terms when present). A monotone cubic spline (I-spline basis: cumulative cubic "
     "B-splines with up to 6 knots at quantiles of the drive, non-negative coefficients), plus "
     "a free zero offset (tare error).",
     "pwm_us, force_g", "offset_g [g]: force at zero drive; c1..c9 [g]: curve steps (>= 0)"},
    {"deadband",
     "ESC start threshold: below it the motor does not turn and the force is zero; the drive "
     "counts from the threshold (softened over ~2 us).",
     "pwm_us", "pwm_start_us [us]: PWM where the motor starts"},
    {"voltage",
     "Force follows the effective motor voltage duty*V, not the PWM alone: the drive is "
     "multiplied by (V/V_ref)^gamma, V_ref the highest voltage in the data.",
     "vbat_v", "gamma [1]: voltage exponent (1 for an ideal motor)"},
    {"sag",
     "Battery internal resistance and wiring: the motor sees V = vbat - R*I, lower than the "
     "logged (resting) voltage under load. Without a current column the current is taken as "
     "proportional to (duty*V)^2 and the sag is fitted as a fraction of V at full drive. "
     "Needs `voltage`.",
     "vbat_v, current_a (optional)",
     "r_sag_ohm [ohm]: source resistance (with current_a) | sag_full [1]: relative sag at full "
     "drive (without)"},
    {"motor",
     "Per-motor variation (Kv, resistance, propeller): each motor has its own force gain and its "
     "own drive scale (speed per volt); the first motor in the data is the reference.",
     "motor",
     "gain_motor_N [1]: relative force of motor N minus 1; kv_motor_N [1]: relative drive "
     "(speed per volt) minus 1"},
    {"drift",
     "Slow change with time, e.g. load-cell zero creep or a warming rig: grams added in "
     "proportion to the time since the first sample.",
     "t_s", "drift_g_per_min [g/min]: offset change rate"},
    {"lag",
     "First-order motor dynamics (and a slow load cell): the measured force follows the command "
     "with a time constant, so up and down sweeps differ (hysteresis). The drive is low-pass "
     "filtered per run in logging order, by t_s, or by sample count when there is no t_s.",
     "t_s (optional)", "tau_s [s]: time constant | tau_samples [samples]: without t_s"},
    {"thermal",
     "Temperature of the motor: copper resistance +0.39 %/K and magnets -0.1 %/K change the "
     "force at a given command; a factor linear in the temperature around its mean, whose "
     "slope changes with the drive x (the resistance matters more at high current).",
     "temp_c",
     "thermal_pct_per_k [%/K]: force change per kelvin at zero drive; "
     "thermal_drive_pct_per_k [%/K]: its change up to full drive"},
    {"density",
     "Air density rho = p / (287.05 T) from temperature and pressure: thrust at fixed speed is "
     "proportional to rho; at a fixed command the motor slows down under a heavier load, the "
     "more so the higher the drive (winding resistance), so the force goes as "
     "(rho/rho_ref)^(beta + beta_drive * x), x the drive on 0..1.",
     "temp_c, a pressure column (pressure_pa, pressure_hpa, ...)",
     "beta [1]: density exponent at zero drive (1: force proportional to rho); beta_drive [1]: "
     "its change up to full drive"},
    {"thesis",
     "The firmware's model (thesis option 2.1), built from the data as gather_store would: per "
     "motor, the run at the highest voltage is the first curve (with its start voltage and sag "
     "offsets), the run at the most different voltage the second; each row's force is the one "
     "for which core's forceToPwm() returns the row's PWM at the row's (sag-compensated) "
     "voltage. Replaces `curve`; parameters counted for the criteria: the distinct PWMs in the "
     "curves.",
     "pwm_us, force_g, vbat_v (for two curves)", "none fitted"},
    {"mul: EXPR",
     "User effect: the force is multiplied by EXPR (muParser syntax). Identifiers that are "
     "columns take the row's value; any other identifier that is not a function or constant is "
     "a free parameter, fitted, starting at 0; write EXPR so that 0 means no effect (1 + a*..., "
     "not a*...), then a ladder step adding it never fits worse. Example: mul: 1 + a*(temp_c - 25).",
     "the columns EXPR names", "the free identifiers [unit of what they multiply]"},
    {"add: EXPR",
     "User effect: EXPR grams are added to the force. Same rules as mul:. Example: "
     "add: b*sin(t_s/60).",
     "the columns EXPR names", "the free identifiers [g per unit of what they multiply]"},
};

std::string trimCopy(const std::string& s) {
  std::size_t a = 0, b = s.size();
  while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
  while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
  return s.substr(a, b - a);
}


// Cumulative B-splines: S_j(u) = sum_{m >= j} B_m(u), j = 1..N-1, for the clamped knot vector
// `t` on [0, 1]. Each S_j rises from 0 to 1, so a non-negative combination is a monotone
// spline (an I-spline basis); local support lets the curve follow local features.
void cumulativeBSpline(double u, const std::vector<double>& t, double* s) {
  const int p = kSplineDegree;
  const int n = static_cast<int>(t.size()) - p - 1;  // basis functions
  u = std::clamp(u, 0.0, 1.0);
  // span index
  int k = p;
  while (k < n - 1 && u >= t[static_cast<std::size_t>(k + 1)]) ++k;
  // Cox-de Boor on the p+1 non-zero functions of span k (NURBS book, A2.2)
  double N[kSplineDegree + 1], left[kSplineDegree + 1], right[kSplineDegree + 1];
  N[0] = 1.0;
  for (int j = 1; j <= p; ++j) {
    left[j] = u - t[static_cast<std::size_t>(k + 1 - j)];
    right[j] = t[static_cast<std::size_t>(k + j)] - u;
    double saved = 0.0;
    for (int r = 0; r < j; ++r) {
      const double den = right[r + 1] + left[j - r];
      const double tmp = den != 0 ? N[r] / den : 0.0;
      N[r] = saved + right[r + 1] * tmp;
      saved = left[j - r] * tmp;
    }
    N[j] = saved;
  }
  // S_j = sum over m >= j of B_m: 1 below the span's first non-zero function (the functions sum
  // to one), the partial sums of N within the span, 0 above it.
  const int first = k - p;
  for (int j = 1; j <= std::min(first, n - 1); ++j) s[j - 1] = 1.0;
  double acc = 0;
  for (int m = k; m >= std::max(first, 1); --m) {
    acc += N[m - first];
    s[m - 1] = acc;
  }
  for (int j = k + 1; j <= n - 1; ++j) s[j - 1] = 0.0;
}

double softPlus(double u, double s) {
  const double z = u / s;
  return z > 30 ? u : s * std::log1p(std::exp(z));
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

}  // namespace

const std::vector<EffectInfo>& effectCatalogue() { return kCatalogue; }

const EffectInfo* findEffect(const std::string& name) {
  for (const auto& e : kCatalogue)
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
    s += (user[i].multiplicative ? "mul: " : "add: ") + user[i].expression;
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
    if (rest.rfind("mul:", 0) == 0 || rest.rfind("add:", 0) == 0) {
      const std::size_t end = s.find(';', start);
      const std::string expr = trimCopy(s.substr(start + 4, end == std::string::npos ? std::string::npos : end - start - 4));
      if (expr.empty())
        throw std::invalid_argument("'" + rest.substr(0, 4) + "' needs an expression, e.g. mul: 1 + a*(temp_c - 25)");
      out.user.push_back({rest[0] == 'm', expr});
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
      for (const auto& c : kCatalogue) names += (names.empty() ? "" : ", ") + c.name;
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
  struct ParamDef {
    std::string name, unit, effect;
    double init, scale, lo, hi;
    double neutral = std::numeric_limits<double>::quiet_NaN();  // value that switches it off
  };
  struct UserExpr {
    bool mul;
    std::string text;
    std::unique_ptr<mu::Parser> parser;
    std::vector<std::unique_ptr<double>> storage;
    std::vector<std::pair<std::string, double*>> columns;  // column name -> slot
    std::vector<std::pair<int, double*>> params;           // param index -> slot
  };
  // Columns of one data set, looked up once.
  struct Bound {
    std::size_t n = 0;
    const std::vector<double>* pwm = nullptr;
    const std::vector<double>* vbat = nullptr;
    const std::vector<double>* current = nullptr;
    const std::vector<double>* t = nullptr;
    const std::vector<double>* temp = nullptr;
    const std::vector<double>* rho = nullptr;
    const std::vector<double>* dir = nullptr;
    std::vector<int> motor_index;  // -1: not a training motor
    const std::vector<int>* run = nullptr;
    std::vector<std::vector<const std::vector<double>*>> user_columns;
    std::vector<const std::vector<double>*> probe_columns;
    std::vector<double> thesis_start;  // per row: motor calibration index
    const std::vector<double>* sample_index = nullptr;  // row numbers (lag by samples on a subsample)
  };

  ModelSpec spec;
  const Dataset& train;
  std::vector<ParamDef> defs;
  std::vector<UserExpr> users;
  bool thesis = false;
  bool lag_in_samples = false;
  int i_start = -1, i_gamma = -1, i_rsag = -1, i_sagrel = -1, i_tau = -1,
      i_motor0 = -1, i_motorkv0 = -1, i_drift = -1, i_thermal = -1, i_beta = -1;
  double pmin = 0, span = 1, vref = 1, t0 = 0, temp0 = 25, rho0 = 1.2, xtop = 1;
  std::vector<double> knots;  // clamped B-spline knots of the curve on [0, 1]
  std::vector<long> motors;  // training motor ids, index 0 = reference
  std::vector<tc::MotorCalibration> cals;
  int thesis_k = 0;
  Eigen::VectorXd theta;  // fitted nonlinear parameters
  Eigen::VectorXd coef;   // fitted linear parameters (curve)
  bool fitted = false;
  Bound train_bound;
  Eigen::VectorXd y;
  // The rows the nonlinear search runs on: all of them, or evenly spaced ones on big data.
  std::unique_ptr<Dataset> fit_data;
  std::vector<double> fit_index;
  Bound fit_bound;
  Eigen::VectorXd y_fit;

  Impl(const ModelSpec& s, const Dataset& d) : spec(s), train(d) { setup(); }

  static bool usable(const Dataset& d, const char* name) {
    if (!d.has(name)) return false;
    for (double v : d.col(name))
      if (!std::isfinite(v)) return false;
    return true;
  }

  void require(const std::string& effect, const char* column) const {
    if (!usable(train, column))
      throw std::invalid_argument(fmt::format(
          "effect `{}` needs the column {} (logged on every row); the data has: {}", effect,
          column, fmt::join(train.names, ", ")));
  }

  int addParam(const std::string& name, const std::string& unit, const std::string& effect,
               double init, double scale, double lo = -1e300, double hi = 1e300,
               double neutral = 0.0) {
    defs.push_back({name, unit, effect, init, scale, lo, hi, neutral});
    return static_cast<int>(defs.size()) - 1;
  }

  void setup() {
    thesis = spec.has("thesis");
    const bool curve = spec.has("curve");
    if (thesis && curve)
      throw std::invalid_argument("`thesis` and `curve` are both base models; use one of them");
    if (!thesis && !curve) spec.effects.insert(spec.effects.begin(), "curve");
    if (thesis) {
      for (const char* e : {"deadband", "voltage", "sag"})
        if (spec.has(e))
          throw std::invalid_argument(fmt::format(
              "`{}` shapes the `curve` base; the thesis model has its own curve and voltage "
              "handling. Compare with a curve model instead, e.g. curve+deadband+voltage", e));
    }
    if (spec.has("sag") && !spec.has("voltage"))
      throw std::invalid_argument("`sag` corrects the voltage the motor sees; add `voltage` before it");
    const auto& pwm = train.col("pwm_us");
    pmin = *std::min_element(pwm.begin(), pwm.end());
    const double pmax = *std::max_element(pwm.begin(), pwm.end());
    span = std::max(pmax - pmin, 1e-9);
    if (usable(train, "vbat_v")) {
      const auto& v = train.col("vbat_v");
      vref = *std::max_element(v.begin(), v.end());
      if (!(vref > 0)) vref = 1;
    }
    const auto& f = train.col("force_g");
    const double fmax = *std::max_element(f.begin(), f.end());

    for (const auto& e : spec.effects) {
      if (e == "deadband") {
        // start: the highest PWM below which the force stays under 3 % of the maximum
        double first_up = std::numeric_limits<double>::infinity();
        for (std::size_t i = 0; i < pwm.size(); ++i)
          if (f[i] > 0.03 * fmax) first_up = std::min(first_up, pwm[i]);
        double start = pmin;
        for (std::size_t i = 0; i < pwm.size(); ++i)
          if (pwm[i] < first_up || (pwm[i] == first_up && f[i] <= 0.03 * fmax)) start = std::max(start, pwm[i]);
        i_start = addParam("pwm_start_us", "us", e, start, 0.01 * span, pmin - 0.05 * span, pmax, pmin);
      } else if (e == "voltage") {
        require(e, "vbat_v");
        i_gamma = addParam("gamma", "1", e, 1.0, 0.1, 0.0, 5.0);
      } else if (e == "sag") {
        require(e, "vbat_v");
        if (usable(train, "current_a"))
          i_rsag = addParam("r_sag_ohm", "ohm", e, 0.02, 0.02, 0.0, 10.0);
        else
          i_sagrel = addParam("sag_full", "1", e, 0.02, 0.02, 0.0, 0.9);
      } else if (e == "lag") {
        if (usable(train, "t_s")) {
          i_tau = addParam("tau_s", "s", e, 0.05, 0.02, 1e-4, 100.0, 1e-4);
        } else {
          // no time column: the rows are taken as equally spaced samples in logging order
          lag_in_samples = true;
          i_tau = addParam("tau_samples", "samples", e, 1.0, 0.5, 1e-3, 1000.0, 1e-3);
        }
      } else if (e == "motor") {
        require(e, "motor");
        std::set<long> ids;
        for (double m : train.col("motor")) ids.insert(std::lround(m));
        motors.assign(ids.begin(), ids.end());
        for (std::size_t k = 1; k < motors.size(); ++k) {
          const int idx = addParam(fmt::format("gain_motor_{}", motors[k]), "1", e, 0.0, 0.02, -0.9, 10.0);
          if (k == 1) i_motor0 = idx;
        }
        for (std::size_t k = 1; k < motors.size(); ++k) {
          const int idx = addParam(fmt::format("kv_motor_{}", motors[k]), "1", e, 0.0, 0.02, -0.5, 2.0);
          if (k == 1) i_motorkv0 = idx;
        }
        if (motors.size() < 2) motors.clear();
      } else if (e == "drift") {
        require(e, "t_s");
        const auto& t = train.col("t_s");
        t0 = *std::min_element(t.begin(), t.end());
        i_drift = addParam("drift_g_per_min", "g/min", e, 0.0, 0.01 * std::max(fmax, 1.0));
      } else if (e == "thermal") {
        require(e, "temp_c");
        const auto& t = train.col("temp_c");
        double s = 0;
        for (double v : t) s += v;
        temp0 = s / static_cast<double>(t.size());
        i_thermal = addParam("thermal_pct_per_k", "%/K", e, 0.0, 0.1);
        addParam("thermal_drive_pct_per_k", "%/K", e, 0.0, 0.1);
      } else if (e == "density") {
        if (!usable(train, "rho_kg_m3"))
          throw std::invalid_argument(
              "effect `density` needs temp_c and a pressure column (pressure_pa, pressure_hpa, "
              "...) on every row to compute the air density");
        const auto& r = train.col("rho_kg_m3");
        double s = 0;
        for (double v : r) s += v;
        rho0 = s / static_cast<double>(r.size());
        i_beta = addParam("beta", "1", e, 1.0, 0.2, -5.0, 5.0, 0.0);
        addParam("beta_drive", "1", e, 0.0, 0.2, -5.0, 5.0);
      }
    }
    for (const auto& u : spec.user) setupUser(u);
    for (const auto& pr : spec.probes) setupProbe(pr);
    if (thesis) buildThesis();
    train_bound = bind(train);
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
    // Curve domain and knots: from the data alone, never from the effects, so a model with an
    // effect at its neutral value predicts exactly what the model without it does (nested
    // fits). The drive stays below ~1.05 (start >= pmin - 5 % span, V <= V_ref).
    if (!thesis) {
      xtop = 1.1;
      // knots at quantiles of the PWMs where the motor turns (force above 3 % of the largest),
      // and one where it starts turning, so a curve without `deadband` can bend there too
      std::vector<double> u;
      double turn_on = std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i < pwm.size(); ++i)
        if (f[i] > 0.03 * fmax) {
          u.push_back(softPlus(pwm[i] - pmin, kSoftStartUs) / span / xtop);
          turn_on = std::min(turn_on, u.back());
        }
      if (u.size() < 2) {
        u.clear();
        for (double p : pwm) u.push_back(softPlus(p - pmin, kSoftStartUs) / span / xtop);
      }
      std::sort(u.begin(), u.end());
      knots.assign(kSplineDegree + 1, 0.0);
      double last = 0;
      if (std::isfinite(turn_on) && turn_on > 0.02 && turn_on < 0.9) {
        knots.push_back(turn_on);
        last = turn_on;
      }
      for (int k = 1; k <= kInteriorKnots && !u.empty(); ++k) {
        const double q = u[std::min(u.size() - 1, u.size() * static_cast<std::size_t>(k) / (kInteriorKnots + 1))];
        if (q > last + 0.02 && q < 0.98) {
          knots.push_back(q);
          last = q;
        }
      }
      for (int k = 0; k <= kSplineDegree; ++k) knots.push_back(1.0);
    }
  }

  struct ProbeDef {
    std::string column;
    bool categorical;
    double mean = 0, sd = 1;
    std::vector<double> levels;
    int first_param = -1;
  };
  std::vector<ProbeDef> probes;

  void setupProbe(const Probe& pr) {
    if (!train.has(pr.column)) throw std::invalid_argument("probe: no column " + pr.column);
    ProbeDef d;
    d.column = pr.column;
    d.categorical = pr.categorical;
    const auto& z = train.col(pr.column);
    if (pr.categorical) {
      std::set<double> lv;
      for (double v : z)
        if (std::isfinite(v)) lv.insert(v);
      d.levels.assign(lv.begin(), lv.end());
      for (std::size_t k = 1; k < d.levels.size(); ++k) {
        const int idx = addParam(fmt::format("gain_{}_{:g}", pr.column, d.levels[k]), "1", "probe", 0.0, 0.02, -0.9, 10.0);
        if (k == 1) d.first_param = idx;
      }
    } else {
      double s = 0, s2 = 0;
      std::size_t n = 0;
      for (double v : z)
        if (std::isfinite(v)) { s += v; s2 += v * v; ++n; }
      d.mean = n ? s / static_cast<double>(n) : 0;
      d.sd = n ? std::sqrt(std::max(s2 / static_cast<double>(n) - d.mean * d.mean, 0.0)) : 1;
      if (!(d.sd > 0)) d.sd = 1;
      d.first_param = addParam(fmt::format("{}_lin", pr.column), "1/sd", "probe", 0.0, 0.01);
      addParam(fmt::format("{}_quad", pr.column), "1/sd^2", "probe", 0.0, 0.01);
    }
    probes.push_back(d);
  }

  void setupUser(const UserEffect& u) {
    UserExpr ue;
    ue.mul = u.multiplicative;
    ue.text = u.expression;
    ue.parser = std::make_unique<mu::Parser>();
    static thread_local UserExpr* current = nullptr;
    current = &ue;
    ue.parser->SetVarFactory(
        [](const char* name, void*) -> double* {
          (void)name;
          current->storage.push_back(std::make_unique<double>(0.0));
          return current->storage.back().get();
        },
        nullptr);
    try {
      ue.parser->SetExpr(u.expression);
      const auto vars = ue.parser->GetUsedVar();
      for (const auto& v : vars) {
        if (train.has(v.first)) {
          if (v.first == "force_g")
            throw std::invalid_argument("an effect cannot use the measured force_g");
          ue.columns.emplace_back(v.first, v.second);
        } else {
          const int idx = addParam(v.first, ue.mul ? "1/unit" : "g/unit",
                                   (ue.mul ? "mul: " : "add: ") + u.expression, 0.0, 0.01);
          ue.params.emplace_back(idx, v.second);
        }
      }
      ue.parser->Eval();
    } catch (mu::Parser::exception_type& e) {
      throw std::invalid_argument(fmt::format("expression '{}': {} at position {}; write it in "
                                              "muParser syntax, e.g. 1 + a*(temp_c - 25)",
                                              u.expression, e.GetMsg(), e.GetPos() + 1));
    }
    if (ue.params.empty())
      throw std::invalid_argument(fmt::format(
          "expression '{}' has no free parameter to fit (every identifier is a column: {}); "
          "add one, e.g. 1 + a*(...)",
          u.expression, fmt::join(train.names, ", ")));
    current = nullptr;
    users.push_back(std::move(ue));
  }

  void buildThesis() {
    // per motor: runs with their start voltage
    const auto& pwm = train.col("pwm_us");
    const auto& f = train.col("force_g");
    const bool has_v = usable(train, "vbat_v");
    const bool has_m = usable(train, "motor");
    std::map<long, std::vector<int>> runs_of_motor;
    for (std::size_t i = 0; i < train.rows(); ++i) {
      const long m = has_m ? std::lround(train.col("motor")[i]) : 0;
      auto& v = runs_of_motor[m];
      if (std::find(v.begin(), v.end(), train.run[i]) == v.end()) v.push_back(train.run[i]);
    }
    for (auto& [m, runs] : runs_of_motor) {
      struct RunInfo {
        int run;
        uint16_t start_mv;
        tc::SagTable sag;
        bool sag_ok;
      };
      std::vector<RunInfo> infos;
      for (int r : runs) {
        tc::SagBuilder sb;
        sb.reset(1000);
        double vsum = 0;
        std::size_t k = 0;
        for (std::size_t i = 0; i < train.rows(); ++i) {
          if (train.run[i] != r || (has_m && std::lround(train.col("motor")[i]) != m)) continue;
          if (has_v) {
            const double mv = std::clamp(train.col("vbat_v")[i] * 1000.0, 0.0, 65535.0);
            sb.add(static_cast<uint16_t>(std::clamp(pwm[i], 0.0, 65535.0)), static_cast<uint16_t>(mv));
            vsum += mv;
          }
          ++k;
        }
        RunInfo info{r, 0, tc::SagTable(), false};
        uint16_t start = 0;
        if (has_v && sb.build(info.sag, start)) {
          info.start_mv = start;
          info.sag_ok = true;
        } else if (has_v && k > 0) {
          info.start_mv = static_cast<uint16_t>(vsum / static_cast<double>(k));
        } else {
          info.start_mv = 12000;  // no voltage logged: a single curve, voltage term unused
        }
        infos.push_back(info);
      }
      std::sort(infos.begin(), infos.end(),
                [](const RunInfo& a, const RunInfo& b) { return a.start_mv > b.start_mv; });
      tc::MotorCalibration cal;
      cal.clear();
      auto build = [&](const RunInfo& info, tc::ThesisCurve& out) {
        std::map<long, std::pair<double, int>> merged;  // pwm -> force sum, count
        for (std::size_t i = 0; i < train.rows(); ++i) {
          if (train.run[i] != info.run || (has_m && std::lround(train.col("motor")[i]) != m)) continue;
          auto& e = merged[std::lround(pwm[i])];
          e.first += f[i];
          e.second += 1;
        }
        auto cb = std::make_unique<tc::CurveBuilder<1024>>();
        std::size_t step = merged.size() / 1024 + 1, idx = 0;
        for (const auto& [p, e] : merged) {
          if (idx++ % step) continue;
          const double dg = std::clamp(10.0 * e.first / e.second, -32768.0, 32767.0);
          cb->add(static_cast<uint16_t>(std::clamp<long>(p, 0, 65535)), static_cast<int16_t>(std::lround(dg)));
        }
        const tc::BuildReport rep = cb->build(out);
        if (rep.status == tc::BuildStatus::kOk) {
          out.start_mv = info.start_mv ? info.start_mv : 1;
          thesis_k += rep.samples_used;
          return true;
        }
        return false;
      };
      if (infos.empty() || !build(infos[0], cal.first))
        throw std::invalid_argument(fmt::format(
            "thesis model: could not build a force curve for motor {} from its highest-voltage "
            "run (the core curve builder needs at least 2 PWMs and a force of 1 g or more)", m));
      cal.sag = infos[0].sag;
      if (!infos[0].sag_ok) cal.sag = tc::SagTable();
      // the second curve: the run whose start voltage differs most from the first
      if (infos.size() > 1) {
        const RunInfo* second = nullptr;
        for (const auto& info : infos)
          if (std::abs(int(info.start_mv) - int(infos[0].start_mv)) >= 100 &&
              (!second || std::abs(int(info.start_mv) - int(infos[0].start_mv)) >
                              std::abs(int(second->start_mv) - int(infos[0].start_mv))))
            second = &info;
        if (second) build(*second, cal.second);
      }
      motors_thesis.push_back(m);
      cals.push_back(cal);
    }
  }
  std::vector<long> motors_thesis;

  // Force the thesis model gives at this PWM and measured voltage (inverse of forceToPwm).
  double thesisForce(const tc::MotorCalibration& cal, double pwm_us, double vbat_v) const {
    const double mv_raw = std::isfinite(vbat_v) ? std::clamp(vbat_v * 1000.0, 0.0, 65535.0) : 0.0;
    tc::BatteryMonitor mon;
    const uint16_t mv = mv_raw > 0
                            ? mon.compensatedMillivolts(static_cast<uint16_t>(mv_raw),
                                                        static_cast<uint16_t>(std::clamp(pwm_us, 0.0, 65535.0)), cal.sag)
                            : static_cast<uint16_t>(mv_raw);
    const uint16_t gmax = std::max(cal.first.maxGrams(), cal.second.maxGrams());
    auto pwmAt = [&](uint16_t g) { return double(tc::forceToPwm(cal, g, mv).pwm_us); };
    if (gmax == 0) return 0;
    if (pwm_us <= pwmAt(0)) return 0;
    // largest g with pwm(g) <= pwm_us (pwm(g) is non-decreasing in g for sane voltages)
    uint16_t lo = 0, hi = gmax;
    if (pwmAt(hi) <= pwm_us) return gmax;
    while (hi - lo > 1) {
      const uint16_t mid = static_cast<uint16_t>((lo + hi) / 2);
      if (pwmAt(mid) <= pwm_us) lo = mid; else hi = mid;
    }
    const double p0 = pwmAt(lo), p1 = pwmAt(hi);
    return p1 > p0 ? lo + (pwm_us - p0) / (p1 - p0) : lo;
  }

  Bound bind(const Dataset& d) const {
    Bound b;
    b.n = d.rows();
    b.pwm = &d.col("pwm_us");
    auto opt = [&](const char* name) { return d.has(name) ? &d.col(name) : nullptr; };
    b.vbat = opt("vbat_v");
    b.current = opt("current_a");
    b.t = opt("t_s");
    b.temp = opt("temp_c");
    b.rho = opt("rho_kg_m3");
    b.dir = opt("dir");
    b.run = &d.run;
    const auto* motor = opt("motor");
    b.motor_index.assign(b.n, 0);
    if (!motors.empty() || thesis) {
      const auto& ids = thesis ? motors_thesis : motors;
      for (std::size_t i = 0; i < b.n; ++i) {
        const long m = motor && std::isfinite((*motor)[i]) ? std::lround((*motor)[i]) : ids.empty() ? 0 : ids[0];
        const auto it = std::find(ids.begin(), ids.end(), m);
        b.motor_index[i] = it == ids.end() ? -1 : static_cast<int>(it - ids.begin());
      }
    }
    for (const auto& pd : probes) b.probe_columns.push_back(&d.col(pd.column));
    for (const auto& u : users) {
      std::vector<const std::vector<double>*> cols;
      for (const auto& c : u.columns) {
        if (!d.has(c.first))
          throw std::invalid_argument("expression '" + u.text + "' needs column " + c.first);
        cols.push_back(&d.col(c.first));
      }
      b.user_columns.push_back(cols);
    }
    return b;
  }

  Eigen::VectorXd initialTheta() const {
    Eigen::VectorXd t(static_cast<Eigen::Index>(defs.size()));
    for (std::size_t i = 0; i < defs.size(); ++i) t[static_cast<Eigen::Index>(i)] = defs[i].init;
    return t;
  }

  double p(const Eigen::VectorXd& th, int i) const {
    return std::clamp(th[i], defs[static_cast<std::size_t>(i)].lo, defs[static_cast<std::size_t>(i)].hi);
  }

  double voltageAt(const Bound& b, const Eigen::VectorXd& th, std::size_t i, double duty) const {
    double v = (*b.vbat)[i];
    if (i_rsag >= 0) v -= p(th, i_rsag) * (*b.current)[i];
    if (i_sagrel >= 0) {
      const double load = duty * v / vref;
      v *= 1.0 - p(th, i_sagrel) * load * load;
    }
    return std::max(v, 1e-3 * vref);
  }

  double pwmEffective(const Bound& b, const Eigen::VectorXd&, std::size_t i) const {
    double pw = (*b.pwm)[i];
    return pw;
  }

  // A drive for the thesis base (the effects that depend on it): PWM over the span.
  std::vector<double> thesisDrive(const Bound& b) const {
    std::vector<double> x(b.n);
    for (std::size_t i = 0; i < b.n; ++i) x[i] = std::max(0.0, (*b.pwm)[i] - pmin) / span;
    return x;
  }

  // The drive x per row (curve models).
  std::vector<double> drive(const Bound& b, const Eigen::VectorXd& th) const {
    std::vector<double> x(b.n);
    for (std::size_t i = 0; i < b.n; ++i) {
      const double pw = pwmEffective(b, th, i);
      double d = softPlus(pw - (i_start >= 0 ? p(th, i_start) : pmin), kSoftStartUs) / span;
      if (i_gamma >= 0) {
        const double v = voltageAt(b, th, i, d);
        d *= std::pow(v / vref, p(th, i_gamma));
      }
      if (i_motorkv0 >= 0 && b.motor_index[i] > 0) d *= 1.0 + p(th, i_motorkv0 + b.motor_index[i] - 1);
      x[i] = d;
    }
    if (i_tau >= 0) lowPass(b, p(th, i_tau), x);
    return x;
  }

  // First-order low-pass per run in row order (the order the samples were logged).
  void lowPass(const Bound& b, double tau, std::vector<double>& x) const {
    // at its lower bound the lag is off: exactly the model without it
    if (tau <= defs[static_cast<std::size_t>(i_tau)].lo) return;
    std::vector<long> last_row;     // per run: last row seen (-1: none)
    std::vector<double> last_x;
    const bool by_time = !lag_in_samples && b.t;
    for (std::size_t i = 0; i < b.n; ++i) {
      const auto r = static_cast<std::size_t>(std::max((*b.run)[i], 0));
      if (r >= last_row.size()) {
        last_row.resize(r + 1, -1);
        last_x.resize(r + 1, 0.0);
      }
      if (last_row[r] >= 0) {
        const auto prev = static_cast<std::size_t>(last_row[r]);
        const double dt = by_time          ? (*b.t)[i] - (*b.t)[prev]
                          : b.sample_index ? (*b.sample_index)[i] - (*b.sample_index)[prev]
                                           : 1.0;
        if (dt > 0 && std::isfinite(dt)) x[i] = last_x[r] + (1 - std::exp(-dt / tau)) * (x[i] - last_x[r]);
      }
      last_row[r] = static_cast<long>(i);
      last_x[r] = x[i];
    }
  }

  // Multiplicative factor and additive grams per row.
  void factors(const Bound& b, const Eigen::VectorXd& th, const std::vector<double>& x,
               Eigen::VectorXd& mul, Eigen::VectorXd& add) const {
    mul = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(b.n));
    add = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(b.n));
    for (std::size_t i = 0; i < b.n; ++i) {
      const auto r = static_cast<Eigen::Index>(i);
      if (i_motor0 >= 0 && b.motor_index[i] > 0) mul[r] *= 1.0 + p(th, i_motor0 + b.motor_index[i] - 1);
      if (i_drift >= 0) add[r] += p(th, i_drift) * ((*b.t)[i] - t0) / 60.0;
      if (i_thermal >= 0) {
        // the magnets' share is a plain gain; the winding resistance's share grows with the
        // current, i.e. with the drive
        const double k = p(th, i_thermal) + p(th, i_thermal + 1) * std::clamp(x[i] / xtop, 0.0, 1.0);
        mul[r] *= 1.0 + k / 100.0 * ((*b.temp)[i] - temp0);
      }
      if (i_beta >= 0) {
        // exponent falls with the drive: at low drive the speed barely depends on the load
        // (F ~ rho), at high drive the winding resistance lets the motor slow down
        const double beta = p(th, i_beta) + p(th, i_beta + 1) * std::clamp(x[i] / xtop, 0.0, 1.0);
        mul[r] *= std::pow(std::max((*b.rho)[i], 1e-6) / rho0, beta);
      }
    }
    for (std::size_t pi = 0; pi < probes.size(); ++pi) {
      const auto& pd = probes[pi];
      const auto& z = *b.probe_columns[pi];
      for (std::size_t i = 0; i < b.n; ++i) {
        const auto r = static_cast<Eigen::Index>(i);
        if (pd.first_param < 0 || !std::isfinite(z[i])) continue;
        if (pd.categorical) {
          const auto it = std::find(pd.levels.begin(), pd.levels.end(), z[i]);
          const long li = it - pd.levels.begin();
          if (it != pd.levels.end() && li > 0) mul[r] *= 1.0 + p(th, pd.first_param + static_cast<int>(li) - 1);
        } else {
          const double u = (z[i] - pd.mean) / pd.sd;
          mul[r] *= 1.0 + th[pd.first_param] * u + th[pd.first_param + 1] * u * u;
        }
      }
    }
    for (std::size_t u = 0; u < users.size(); ++u) {
      const auto& ue = users[u];
      for (const auto& pr : ue.params) *pr.second = th[pr.first];
      for (std::size_t i = 0; i < b.n; ++i) {
        for (std::size_t c = 0; c < ue.columns.size(); ++c) *ue.columns[c].second = (*b.user_columns[u][c])[i];
        double v;
        try {
          v = ue.parser->Eval();
        } catch (mu::Parser::exception_type&) {
          v = kNaN;
        }
        if (ue.mul) mul[static_cast<Eigen::Index>(i)] *= v; else add[static_cast<Eigen::Index>(i)] += v;
      }
    }
  }

  int basisSize() const { return static_cast<int>(knots.size()) - kSplineDegree - 1; }  // incl. the constant

  // Row i of the design matrix of the linear parameters: 1 (the offset), then mul * S_j(x).
  void basisRow(double x, double mul, double* row) const {
    double s[64];
    cumulativeBSpline(x / xtop, knots, s);
    row[0] = 1.0;
    for (int j = 0; j < basisSize() - 1; ++j) row[j + 1] = mul * s[j];
  }

  Eigen::VectorXd thesisBase(const Bound& b, const Eigen::VectorXd& th) const {
    Eigen::VectorXd out(static_cast<Eigen::Index>(b.n));
    std::vector<double> pw(b.n);
    for (std::size_t i = 0; i < b.n; ++i) pw[i] = pwmEffective(b, th, i);
    if (i_tau >= 0) lowPass(b, p(th, i_tau), pw);
    for (std::size_t i = 0; i < b.n; ++i) {
      const int mi = b.motor_index[i] < 0 ? 0 : b.motor_index[i];
      out[static_cast<Eigen::Index>(i)] =
          thesisForce(cals[static_cast<std::size_t>(mi)], pw[i], b.vbat ? (*b.vbat)[i] : kNaN);
    }
    return out;
  }

  using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  // The normal equations of the curve's coefficients, G = B'B, h = B'r, rr = r'r with
  // r = target - add, summed over blocks of rows (vectorised rank updates; the n x k matrix B is
  // not kept unless `keep` asks for it, row-major). False when a row is not finite.
  bool normalEquations(const Bound& b, const std::vector<double>& x, const Eigen::VectorXd& mul,
                       const Eigen::VectorXd& add, const Eigen::VectorXd& target, Eigen::MatrixXd& G,
                       Eigen::VectorXd& h, double& rr, std::vector<double>* keep) const {
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
  Eigen::VectorXd predictWith(const Bound& b, const Eigen::VectorXd& th, Eigen::VectorXd& c, bool solve,
                              const Eigen::VectorXd* target) const {
    Eigen::VectorXd mul, add;
    const std::vector<double> x = thesis ? thesisDrive(b) : drive(b, th);
    factors(b, th, x, mul, add);
    if (thesis) return mul.cwiseProduct(thesisBase(b, th)) + add;
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

  double rssAt(const Bound& b, const Eigen::VectorXd& target, const Eigen::VectorXd& th,
               Eigen::VectorXd* coef_out = nullptr) const {
    Eigen::VectorXd c;
    double rss;
    if (!thesis && b.n > kMaxFitRows) {
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
      if (w.effect != "curve") continue;
      const int j = w.name == "offset_g" ? 0 : (w.name.size() > 1 && w.name[0] == 'c') ? std::atoi(w.name.c_str() + 1) : -1;
      if (j >= 0 && j < c.size()) c[j] = w.value;
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

  // `warm_rss`: the smaller model's RSS on these rows (its curve coefficients are in `warm`),
  // so its optimum need not be evaluated again; NaN: evaluate it.
  FitResult fit(const std::vector<Param>* warm, bool warm_only, bool uncertainties, double warm_rss) {
    FitResult r;
    r.model = spec.text();
    const Eigen::Index np = static_cast<Eigen::Index>(defs.size());
    const double inf = std::numeric_limits<double>::infinity();
    theta = initialTheta();
    double best_rss = inf;
    if (np > 0) {
      const bool have_warm = warm && !warm->empty();
      std::vector<Eigen::VectorXd> searched;  // LM results
      // The start threshold has local minima (the curve can bend to mimic a later start): when
      // it is new, scan it from the lowest PWM to the first guess with the linear solve alone
      // and start LM at the best.
      auto scanStart = [&](Eigen::VectorXd th) {
        const double hi = initialTheta()[i_start];
        double best = inf, best_start = hi;
        for (int k = 0; k <= 16; ++k) {
          th[i_start] = pmin + (hi - pmin) * k / 16.0;
          const double rss = rssAt(fit_bound, y_fit, th);
          if (rss < best) best = rss, best_start = th[i_start];
        }
        th[i_start] = best_start;
        return th;
      };
      bool cold = !have_warm;
      Eigen::VectorXd neutral;
      if (have_warm) {
        // Warm start from a smaller model's optimum: with the new effects switched off it is
        // itself a candidate, so a model with an added effect never fits worse than the model
        // without it; LM starts from it with the new effects switched on.
        neutral = warmStart(*warm);
        Eigen::VectorXd start = warmStart(*warm, /*neutral=*/false);
        bool start_is_new = i_start >= 0;
        for (const auto& w : *warm) start_is_new = start_is_new && w.name != "pwm_start_us";
        if (start_is_new) start = scanStart(start);
        // A generic probe asks whether anything is left in a variable: the model's own
        // parameters stay where they are, only the probe's move (cheap, and it cannot borrow
        // from the effects already fitted).
        std::vector<bool> fixed;
        if (warm_only && !probes.empty()) {
          fixed.assign(defs.size(), false);
          for (std::size_t i = 0; i < defs.size(); ++i) fixed[i] = defs[i].effect != "probe";
        }
        searched.push_back(runLm(start, r, warm_only, fixed.empty() ? nullptr : &fixed));
        // and from a cold start too (multi-start): the start threshold and the voltage exponent
        // have local minima the continuation can end in
        cold = !warm_only;
      }
      if (cold) searched.push_back(runLm(i_start >= 0 ? scanStart(initialTheta()) : initialTheta(), r));
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
      best_rss = fit_data ? rssAt(train_bound, y, theta, &coef) : best_fit_rows;
      if (have_warm) {
        Eigen::VectorXd c;
        double rss = inf;
        if (std::isfinite(warm_rss) && !thesis && warmCurve(*warm, c)) rss = warm_rss;
        else rss = rssAt(train_bound, y, neutral, &c);
        if (rss < best_rss || !std::isfinite(best_rss)) {
          best_rss = rss;
          theta = neutral;
          coef = c;
        }
      }
    } else {
      best_rss = rssAt(train_bound, y, theta, &coef);
    }
    fitted = true;
    if (!uncertainties && fit_data && !thesis) {
      // A quick fit on many rows (continuation, ranking): the parameters and the error, not
      // every row's prediction.
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
        r.params.push_back({j == 0 ? "offset_g" : fmt::format("c{}", j), "g", "curve", coef[j], kNaN});
      for (Eigen::Index j = 0; j < np; ++j) {
        const auto& d = defs[static_cast<std::size_t>(j)];
        r.params.push_back({d.name, d.unit, d.effect, theta[j], kNaN});
      }
      return r;
    }
    Eigen::VectorXd pred_c = coef;
    const Eigen::VectorXd pred = predictWith(train_bound, theta, pred_c, thesis, &y);

    r.n = static_cast<std::size_t>(y.size());
    const Eigen::Index nl = thesis ? 0 : coef.size();
    std::vector<Eigen::Index> active;
    for (Eigen::Index j = 0; j < nl; ++j)
      if (j == 0 || coef[j] > 0) active.push_back(j);
    const Eigen::Index ncol = static_cast<Eigen::Index>(active.size()) + np;
    r.k = static_cast<int>(nl + np) + (thesis ? thesis_k : 0);
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
    if (!thesis && static_cast<double>(r.k) >= n)
      r.warnings.push_back(fmt::format("{} samples for {} parameters: the fit interpolates, its error says "
                                       "nothing; log more samples or use fewer effects", r.n, r.k));
    if (thesis) {
      std::size_t saturated = 0;
      double top = 0;
      for (const auto& cal : cals) top = std::max<double>(top, std::max(cal.first.maxGrams(), cal.second.maxGrams()));
      for (Eigen::Index i = 0; i < y.size(); ++i)
        if (y[i] > top + 1) ++saturated;
      if (saturated)
        r.warnings.push_back(fmt::format("{} samples are above the thesis curves' heaviest gram ({:.0f} g): "
                                         "the model saturates there, as the firmware does", saturated, top));
    }

    // Uncertainties: J = d pred / d (linear, nonlinear) at the optimum, J^T J summed row by row.
    Eigen::VectorXd sig = Eigen::VectorXd::Constant(ncol, kNaN);
    if (uncertainties && ncol > 0 && res.allFinite()) {
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
      Eigen::MatrixXd JtJ = Eigen::MatrixXd::Zero(ncol, ncol);
      Eigen::VectorXd jrow(ncol);
      double row[64];
      bool finite = true;
      for (std::size_t i = 0; i < r.n && finite; ++i) {
        const auto ri = static_cast<Eigen::Index>(i);
        if (nl > 0) basisRow(x[i], mul[ri], row);
        for (std::size_t k = 0; k < active.size(); ++k) jrow[static_cast<Eigen::Index>(k)] = row[active[k]];
        for (Eigen::Index j = 0; j < np; ++j)
          jrow[static_cast<Eigen::Index>(active.size()) + j] = dcol[static_cast<std::size_t>(j)][ri];
        finite = jrow.allFinite();
        for (Eigen::Index a = 0; a < ncol; ++a)
          for (Eigen::Index b = 0; b <= a; ++b) JtJ(a, b) += jrow[a] * jrow[b];
      }
      if (finite) {
        JtJ = JtJ.selfadjointView<Eigen::Lower>();
        const double dof = std::max(n - static_cast<double>(ncol), 1.0);
        const double s2 = r.rss / dof;
        Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(JtJ);
        const Eigen::MatrixXd cov = cod.pseudoInverse() * s2;
        for (Eigen::Index j = 0; j < ncol; ++j) sig[j] = std::sqrt(std::max(cov(j, j), 0.0));
        if (cod.rank() < ncol)
          r.warnings.push_back(fmt::format("{} parameter combination(s) are not determined by the data "
                                           "(their uncertainties are not meaningful)", ncol - cod.rank()));
      }
    }
    for (Eigen::Index j = 0; j < nl; ++j) {
      Param pr;
      pr.name = j == 0 ? "offset_g" : fmt::format("c{}", j);
      pr.unit = "g";
      pr.effect = "curve";
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
    return r;
  }

  std::vector<double> predict(const Dataset& d) const {
    if (!fitted) throw std::logic_error("predict before fit");
    Bound b = bind(d);
    Eigen::VectorXd c = coef;
    const Eigen::VectorXd pred = predictWith(b, theta, c, false, nullptr);
    return std::vector<double>(pred.data(), pred.data() + pred.size());
  }

  std::vector<double> motorVolts(const Dataset& d) const {
    if (!fitted) throw std::logic_error("motorVoltage before fit");
    Bound b = bind(d);
    std::vector<double> v(b.n, kNaN);
    if (!b.vbat) return v;
    for (std::size_t i = 0; i < b.n; ++i) {
      const double pw = (*b.pwm)[i];
      const double duty = softPlus(pw - (i_start >= 0 ? p(theta, i_start) : pmin), kSoftStartUs) / span;
      v[i] = voltageAt(b, theta, i, duty);
    }
    return v;
  }

  double startUs() const {
    if (!fitted) throw std::logic_error("startUs before fit");
    return i_start >= 0 ? p(theta, i_start) : pmin;
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
