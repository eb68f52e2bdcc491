#include "lab/evidence.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "csv_reader.hpp"
#include "lab/analysis.hpp"

namespace lab {

namespace {

constexpr double kPlateauTol = 0.005;  // a set point on the plateau: within 0.5 % of the run's top
constexpr double kShareTol = 0.01;     // runs share a ceiling within 1 %
constexpr std::size_t kMinPlateauPoints = 3;
constexpr double kStillRising = 0.01;  // a response still rising: +1 % across the plateau

// The first column whose lower-case name is one of `exact`, else starts with one of `prefixes`.
std::string columnLike(const Dataset& d, std::initializer_list<const char*> exact,
                       std::initializer_list<const char*> prefixes) {
  for (const char* e : exact)
    for (const auto& n : d.names)
      if (csv::lower(n) == e) return n;
  for (const char* p : prefixes)
    for (const auto& n : d.names)
      if (csv::lower(n).rfind(p, 0) == 0) return n;
  return {};
}

// A run's plateau at the top of the drive: (level, first PWM, set points); nullopt when none.
struct RunPlateau {
  double level, from_pwm_us;
  std::size_t points;
};
std::optional<RunPlateau> runPlateau(const std::vector<std::pair<double, double>>& bins) {
  if (bins.size() < kMinPlateauPoints + 2) return std::nullopt;
  double top = -std::numeric_limits<double>::infinity();
  for (const auto& b : bins) top = std::max(top, b.second);
  if (!(top > 0)) return std::nullopt;
  const double tol = kPlateauTol * top;
  std::size_t first = bins.size();
  while (first > 0 && bins[first - 1].second >= top - tol) --first;
  const std::size_t points = bins.size() - first;
  // at least three set points, and a rise before them (not a flat run)
  if (points < kMinPlateauPoints || first < 2 || !(bins.front().second < top - 4 * tol)) return std::nullopt;
  std::vector<double> v;
  for (std::size_t k = first; k < bins.size(); ++k) v.push_back(bins[k].second);
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return RunPlateau{v[v.size() / 2], bins[first].first, points};
}

// The median of `column` over the rows of `runs` at or above each run's `from` PWM, and just
// before it: what a second response does across the plateau.
std::pair<double, double> acrossPlateau(const Dataset& d, const Plateau& p, const std::string& column) {
  const auto& pwm = d.col("pwm_us");
  const auto& y = d.col(column);
  const auto runs = rowsOfRuns(d);
  double start_sum = 0, end_sum = 0;
  int k = 0;
  for (std::size_t r = 0; r < p.runs.size(); ++r) {
    const auto bins = binnedMedians(pwm, y, runs[static_cast<std::size_t>(p.runs[r])]);
    if (bins.empty()) continue;
    auto at = std::lower_bound(bins.begin(), bins.end(), std::make_pair(p.from_pwm_us[r], -1e300));
    if (at == bins.end()) continue;
    start_sum += at->second;
    end_sum += bins.back().second;
    ++k;
  }
  if (k == 0) return {Evidence::kNaN, Evidence::kNaN};
  return {start_sum / k, end_sum / k};
}

std::vector<std::string> labelsOf(const Dataset& d, const std::vector<int>& runs) {
  std::vector<std::string> out;
  for (int r : runs) out.push_back(d.run_labels[static_cast<std::size_t>(r)]);
  return out;
}

std::string runsText(const Dataset& d, const std::vector<int>& runs) {
  return runs.size() == d.runs() ? fmt::format("in every run ({})", runs.size())
                                 : fmt::format("in {} of {} runs", runs.size(), d.runs());
}

double lowest(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }

Evidence fromPlateau(const Dataset& d, const Plateau& p, const std::string& kind) {
  Evidence e;
  e.kind = kind;
  e.column = p.column;
  e.level = p.level;
  e.from_pwm_us = lowest(p.from_pwm_us);
  e.runs = labelsOf(d, p.runs);
  return e;
}

// The current stops rising: a current limit, unless speed and force stop with it (the ESC at
// full throttle).
Evidence currentEvidence(const Dataset& d, const Plateau& pc, const std::optional<Plateau>& pr) {
  const bool saturated = pr && pr->runs == pc.runs;
  Evidence e = fromPlateau(d, pc, saturated ? "esc_saturated" : "current_plateau");
  if (saturated) {
    e.cause = fmt::format("a saturated ESC: full throttle is reached at about {:.0f} us", e.from_pwm_us);
    e.text = fmt::format("{} and {} stop rising together from {:.0f} us {}: {}; the drive above it changes nothing "
                         "(calibrate the ESC's throttle range, or fit below it: --where 'pwm_us < {:.0f}')",
                         pc.column, pr->column, e.from_pwm_us, runsText(d, pc.runs), e.cause, e.from_pwm_us);
    return e;
  }
  e.cause = fmt::format("a supply or ESC current limit at {:.3g} A", pc.level);
  e.text = fmt::format("{} stops rising at {:.3g} A {} (from {:.0f} us on, {} set points at the ceiling): {}. The bus "
                       "current of an ESC is the duty times the motor current, so while the bus current is held the "
                       "motor current ({:.3g} A / duty), the torque and the thrust fall as the drive rises",
                       pc.column, pc.level, runsText(d, pc.runs), e.from_pwm_us, pc.set_points, e.cause, pc.level);
  if (d.has("vbat_v")) {
    const auto [v_start, v_end] = acrossPlateau(d, pc, "vbat_v");
    if (std::isfinite(v_start) && v_start - v_end > 0.02 * v_start)
      e.text += fmt::format("; vbat_v falls from {:.2f} to {:.2f} V there (the source folds its voltage back to hold "
                            "the current): where vbat_v is logged at the ESC, a model that uses it already sees the fall",
                            v_start, v_end);
  }
  return e;
}

// The force stops rising: a clipped reading when the rotor still speeds up (or draws more).
Evidence forcePlateauEvidence(const Dataset& d, const Plateau& pf, const std::string& rpm, const std::string& cur) {
  std::string witness;
  double rise = 0;
  for (const std::string& c : {rpm, cur}) {
    if (c.empty()) continue;
    const auto [a, b] = acrossPlateau(d, pf, c);
    if (std::isfinite(a) && a > 0 && b > a * (1 + kStillRising) && witness.empty()) witness = c, rise = b / a - 1;
  }
  Evidence e = fromPlateau(d, pf, witness.empty() ? "force_plateau" : "force_clipped");
  if (witness.empty()) {
    e.cause = "a clipped force reading or a saturated ESC";
    e.text = fmt::format("force_g stops rising at {:.4g} g {} (from {:.0f} us on): {} (log rpm or current_a to tell "
                         "them apart)",
                         pf.level, runsText(d, pf.runs), e.from_pwm_us, e.cause);
    return e;
  }
  e.cause = fmt::format("the force reading is clipped at {:.4g} g (the load cell's range or its ADC's full scale)",
                        pf.level);
  e.where = fmt::format("force_g < {:.4g}", pf.level * (1 - kShareTol));
  e.text = fmt::format("force_g stops at {:.4g} g {} (from {:.0f} us on) while {} still rises by {:.0f} %: {}; those "
                       "rows do not measure the force: drop them (--where '{}')",
                       pf.level, runsText(d, pf.runs), e.from_pwm_us, witness, 100 * rise, e.cause, e.where);
  return e;
}

// The force falls while the drive rises: what the speed and the current do says why.
Evidence fallEvidence(const Dataset& d, const ForceCollapse& c, int run, const std::string& rpm,
                      const std::optional<Plateau>& pc) {
  Evidence e;
  e.kind = "force_falls";  // the kinds below name what speed and current add
  e.column = "force_g";
  e.level = c.peak_force_g;
  e.from_pwm_us = c.peak_pwm_us;
  e.runs = {c.run};
  const bool limited = pc && std::find(pc->runs.begin(), pc->runs.end(), run) != pc->runs.end();
  double rpm_peak = Evidence::kNaN, rpm_top = Evidence::kNaN;
  if (!rpm.empty()) {
    const auto bins = binnedMedians(d.col("pwm_us"), d.col(rpm), rowsOfRuns(d)[static_cast<std::size_t>(run)]);
    for (const auto& b : bins) rpm_peak = std::isfinite(rpm_peak) ? std::max(rpm_peak, b.second) : b.second;
    if (!bins.empty()) rpm_top = bins.back().second;
  }
  if (limited)
    e.kind = "force_falls_at_limit", e.cause = fmt::format("the current limit at {:.3g} A", pc->level);
  else if (std::isfinite(rpm_top) && rpm_top < 0.5 * rpm_peak)
    e.kind = "motor_stalls", e.cause = "a stalled motor (the rotor slows to less than half its speed while the drive "
                                       "rises: a desync or a stall)";
  else if (std::isfinite(rpm_top) && rpm_top < rpm_peak * (1 - kStillRising))
    e.cause = "a limit of the source or the ESC (the rotor slows down; log current_a to tell which)";
  else if (std::isfinite(rpm_top))
    e.kind = "force_falls_rotor_rises",
    e.cause = "the measurement (the load cell or its mount) or the propeller, not the motor: the rotor keeps speeding up";
  else
    e.cause = "an ESC or current limit (log current_a and rpm to tell)";
  e.text = fmt::format("{}: from {:.4g} g at {:.0f} us to {:.4g} g at {:.0f} us", c.run, c.peak_force_g, c.peak_pwm_us,
                       c.top_force_g, c.top_pwm_us);
  return e;
}

}  // namespace

std::vector<std::vector<std::size_t>> rowsOfRuns(const Dataset& data) {
  std::vector<std::vector<std::size_t>> rows(data.runs());
  for (std::size_t i = 0; i < data.rows(); ++i) rows[static_cast<std::size_t>(data.run[i])].push_back(i);
  return rows;
}

std::vector<std::pair<double, double>> binnedMedians(const std::vector<double>& pwm, const std::vector<double>& y,
                                                     const std::vector<std::size_t>& idx) {
  std::vector<std::pair<double, double>> med;
  std::vector<std::size_t> rows;
  for (std::size_t i : idx)
    if (std::isfinite(y[i]) && std::isfinite(pwm[i])) rows.push_back(i);
  if (rows.empty()) return med;
  double lo = pwm[rows[0]], hi = lo;
  std::set<double> levels;
  for (std::size_t i : rows) {
    lo = std::min(lo, pwm[i]), hi = std::max(hi, pwm[i]);
    if (levels.size() <= 200) levels.insert(pwm[i]);
  }
  if (!(hi > lo)) return med;
  std::vector<double> edges;
  if (levels.size() <= 200) {
    edges.assign(levels.begin(), levels.end());
  } else {
    for (int k = 0; k < 40; ++k) edges.push_back(lo + (hi - lo) * k / 40.0);
  }
  std::vector<std::vector<double>> bin(edges.size());
  for (std::size_t i : rows) {
    const auto it = std::upper_bound(edges.begin(), edges.end(), pwm[i]);
    bin[static_cast<std::size_t>(std::max<long>(0, (it - edges.begin()) - 1))].push_back(y[i]);
  }
  for (std::size_t k = 0; k < bin.size(); ++k) {
    auto& b = bin[k];
    if (b.empty()) continue;
    std::nth_element(b.begin(), b.begin() + static_cast<long>(b.size() / 2), b.end());
    const double center = levels.size() <= 200 ? edges[k] : edges[k] + (hi - lo) / 80.0;
    med.emplace_back(center, b[b.size() / 2]);
  }
  return med;
}

std::optional<Plateau> findPlateau(const Dataset& data, const std::string& column) {
  if (!data.has(column) || !data.has("pwm_us")) return std::nullopt;
  const auto runs = rowsOfRuns(data);
  std::vector<std::pair<int, RunPlateau>> found;
  for (std::size_t r = 0; r < runs.size(); ++r)
    if (const auto p = runPlateau(binnedMedians(data.col("pwm_us"), data.col(column), runs[r])))
      found.emplace_back(static_cast<int>(r), *p);
  if (found.empty()) return std::nullopt;
  // the level most runs share (within 1 % of each other)
  std::size_t best = 0, best_count = 0;
  for (std::size_t a = 0; a < found.size(); ++a) {
    std::size_t count = 0;
    for (const auto& f : found)
      count += std::fabs(f.second.level - found[a].second.level) <= kShareTol * found[a].second.level ? 1 : 0;
    if (count > best_count) best = a, best_count = count;
  }
  Plateau p;
  p.column = column;
  std::vector<double> levels;
  for (const auto& [run, rp] : found) {
    if (std::fabs(rp.level - found[best].second.level) > kShareTol * found[best].second.level) continue;
    p.runs.push_back(run);
    p.from_pwm_us.push_back(rp.from_pwm_us);
    p.set_points += rp.points;
    levels.push_back(rp.level);
  }
  std::nth_element(levels.begin(), levels.begin() + static_cast<long>(levels.size() / 2), levels.end());
  p.level = levels[levels.size() / 2];
  return p;
}

std::vector<bool> runsAtCeiling(const Dataset& data, const std::string& column, double level) {
  std::vector<bool> at(data.runs(), false);
  if (!data.has(column)) return at;
  std::vector<double> top(data.runs(), -std::numeric_limits<double>::infinity());
  const auto& y = data.col(column);
  for (std::size_t i = 0; i < data.rows(); ++i)
    if (std::isfinite(y[i])) top[static_cast<std::size_t>(data.run[i])] = std::max(top[static_cast<std::size_t>(data.run[i])], y[i]);
  for (std::size_t r = 0; r < at.size(); ++r) at[r] = std::fabs(top[r] - level) <= kShareTol * std::fabs(level);
  return at;
}

std::vector<Evidence> gatherEvidence(const Dataset& d) {
  std::vector<Evidence> out;
  if (!d.has("pwm_us") || !d.has("force_g")) return out;
  const std::string cur = columnLike(d, {"current_a", "i_a"}, {"current"});
  const std::string rpm = columnLike(d, {"rpm"}, {"rpm"});
  const std::string power = columnLike(d, {"power_w", "p_w"}, {"electrical_power"});
  const auto pc = cur.empty() ? std::nullopt : findPlateau(d, cur);
  const auto pr = rpm.empty() ? std::nullopt : findPlateau(d, rpm);
  if (pc) out.push_back(currentEvidence(d, *pc, pr));
  const bool saturated = pc && !out.empty() && out.back().kind == "esc_saturated";
  if (pr && !saturated) {
    Evidence e = fromPlateau(d, *pr, "rpm_plateau");
    e.cause = fmt::format("a saturated ESC (full throttle below the top PWM) or a speed limit at {:.4g} rpm", pr->level);
    e.text = fmt::format("{} stops rising at {:.4g} rpm {} (from {:.0f} us on): {}", pr->column, pr->level,
                         runsText(d, pr->runs), e.from_pwm_us, e.cause);
    out.push_back(e);
  }
  if (const auto pp = power.empty() ? std::nullopt : findPlateau(d, power)) {
    Evidence e = fromPlateau(d, *pp, "power_plateau");
    e.cause = fmt::format("a power limit at {:.4g} W (the supply's or the ESC's)", pp->level);
    e.text = fmt::format("{} stops rising at {:.4g} W {} (from {:.0f} us on): {}", pp->column, pp->level,
                         runsText(d, pp->runs), e.from_pwm_us, e.cause);
    out.push_back(e);
  }
  if (const auto pf = findPlateau(d, "force_g"); pf && !saturated) out.push_back(forcePlateauEvidence(d, *pf, rpm, cur));
  // the runs where the force falls, one finding per cause
  std::vector<Evidence> falls;
  for (const auto& c : findForceCollapse(d)) {
    int run = -1;
    for (std::size_t r = 0; r < d.runs(); ++r)
      if (d.run_labels[r] == c.run) run = static_cast<int>(r);
    if (run < 0) continue;
    Evidence e = fallEvidence(d, c, run, rpm, pc);
    auto same = std::find_if(falls.begin(), falls.end(), [&](const Evidence& f) { return f.cause == e.cause; });
    if (same == falls.end()) {
      falls.push_back(e);
      continue;
    }
    same->runs.push_back(e.runs.front());
    same->from_pwm_us = std::min(same->from_pwm_us, e.from_pwm_us);
  }
  for (auto& f : falls) {
    f.text = f.runs.size() > 1 ? fmt::format("the force falls while the drive rises in {} runs (from {:.0f} us on; e.g. "
                                             "{}): {}",
                                             f.runs.size(), f.from_pwm_us, f.text, f.cause)
                               : fmt::format("the force falls while the drive rises ({}): {}", f.text, f.cause);
    out.push_back(f);
  }
  return out;
}

}  // namespace lab
