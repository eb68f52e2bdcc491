// Where along the drive the residual concentrates (analysis.hpp, residualRegions): per voltage
// level and over all of them, the PWM interval that holds much of the residual above the noise
// in few rows (the largest divergence of the residual's split, in and out of it, from the rows'
// split; a share of at least 25 % and twice its share of the rows); up to three, each found with
// the rows of the previous ones taken out.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "lab/analysis.hpp"

namespace lab {

namespace {

constexpr double kMinShare = 0.25;          // a region holds at least this share of the excess ...
constexpr double kMinConcentration = 2.0;   // ... and at least twice its share of the rows
constexpr int kMaxRegions = 3;

// Each run's voltage level: its mean vbat_v rounded to 0.25 V (NaN without vbat_v).
std::vector<double> levelOfRow(const Dataset& d) {
  std::vector<double> level(d.rows(), std::numeric_limits<double>::quiet_NaN());
  if (!d.has("vbat_v")) return level;
  const auto& v = d.col("vbat_v");
  std::map<int, std::pair<double, int>> run_v;
  for (std::size_t i = 0; i < d.rows(); ++i)
    if (std::isfinite(v[i])) run_v[d.run[i]].first += v[i], run_v[d.run[i]].second += 1;
  for (std::size_t i = 0; i < d.rows(); ++i) {
    const auto it = run_v.find(d.run[i]);
    if (it != run_v.end() && it->second.second > 0) level[i] = std::round(4.0 * it->second.first / it->second.second) / 4.0;
  }
  return level;
}

struct Best {
  double score = 0, share = 0, rows_share = 0, lo = 0, hi = 0, ss = 0;
  std::size_t rows = 0;
  double level = std::numeric_limits<double>::quiet_NaN();
};

// The best interval of PWM values among `rows` (bins: each PWM, or 40 of the range when there
// are more than 200).
void bestInterval(const std::vector<std::size_t>& rows, const std::vector<double>& pwm, const std::vector<double>& excess,
                  const std::vector<double>& sq, double total_excess, double total_rows, double level, Best& best) {
  if (rows.empty()) return;
  std::set<double> values;
  for (std::size_t i : rows) values.insert(pwm[i]);
  std::vector<double> edges(values.begin(), values.end());
  if (edges.size() > 200) {
    const double lo = edges.front(), hi = edges.back();
    edges.clear();
    for (int k = 0; k < 40; ++k) edges.push_back(lo + (hi - lo) * k / 40.0);
  }
  const std::size_t nb = edges.size();
  std::vector<double> e(nb, 0), n(nb, 0), s(nb, 0), top(nb, 0);
  for (std::size_t i : rows) {
    const auto k = static_cast<std::size_t>(std::max<long>(0, (std::upper_bound(edges.begin(), edges.end(), pwm[i]) - edges.begin()) - 1));
    e[k] += excess[i], n[k] += 1, s[k] += sq[i], top[k] = std::max(top[k], pwm[i]);
  }
  for (std::size_t a = 0; a < nb; ++a) {
    double ea = 0, na = 0, sa = 0;
    for (std::size_t b = a; b < nb; ++b) {
      ea += e[b], na += n[b], sa += s[b];
      if (na == 0) continue;
      const double share = ea / total_excess, rows_share = na / total_rows;
      if (!(share > rows_share) || !(rows_share < 1)) continue;  // where the residual is, not where it is not
      // much of the residual in few rows, and little of it left outside: the divergence of the
      // residual's split (in, out) from the rows'
      const double out = std::max(1 - share, 1e-12);
      const double score = share * std::log(share / rows_share) + out * std::log(out / (1 - rows_share));
      if (score > best.score)
        best = {score, share, rows_share, edges[a], top[b], sa, static_cast<std::size_t>(na), level};
    }
  }
}

std::string describeRegion(const Region& r, double pmin, double pmax) {
  std::string where;
  if (r.pwm_lo_us <= pmin && r.pwm_hi_us >= pmax) where = "over the whole drive";
  else if (r.pwm_hi_us >= pmax) where = fmt::format("above {:.0f} us", r.pwm_lo_us);
  else if (r.pwm_lo_us <= pmin) where = fmt::format("below {:.0f} us", r.pwm_hi_us);
  else where = fmt::format("between {:.0f} and {:.0f} us", r.pwm_lo_us, r.pwm_hi_us);
  return fmt::format("{:.0f} % of the residual above the noise is {}{} ({:.0f} % of the rows, RMSE {:.3g} g there)",
                     100 * r.share, where,
                     std::isfinite(r.vbat_v) ? fmt::format(" at {:.2f} V", r.vbat_v) : std::string(" at every voltage"),
                     100 * r.rows_share, r.rmse_g);
}

}  // namespace

std::vector<Region> residualRegions(const Dataset& data, const FitResult& fit, const NoiseEstimate& noise) {
  std::vector<Region> out;
  const std::size_t n = data.rows();
  if (fit.residual_g.size() != n || n == 0) return out;
  const auto& pwm = data.col("pwm_us");
  const double s2 = noise.known() ? noise.sigma_g * noise.sigma_g : 0.0;
  std::vector<double> excess(n), sq(n);
  double total = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double r = fit.residual_g[i];
    sq[i] = std::isfinite(r) ? r * r : 0.0;
    excess[i] = sq[i] - s2;
    total += excess[i];
  }
  if (!(total > 0)) return out;
  const std::vector<double> level = levelOfRow(data);
  std::set<double> levels;
  for (double l : level)
    if (std::isfinite(l)) levels.insert(l);
  const double pmin = *std::min_element(pwm.begin(), pwm.end()), pmax = *std::max_element(pwm.begin(), pwm.end());
  std::vector<bool> taken(n, false);
  for (int k = 0; k < kMaxRegions; ++k) {
    Best best;
    std::vector<std::size_t> all;
    for (std::size_t i = 0; i < n; ++i)
      if (!taken[i]) all.push_back(i);
    bestInterval(all, pwm, excess, sq, total, static_cast<double>(n), std::numeric_limits<double>::quiet_NaN(), best);
    if (levels.size() > 1)
      for (double l : levels) {
        std::vector<std::size_t> rows;
        for (std::size_t i : all)
          if (level[i] == l) rows.push_back(i);
        bestInterval(rows, pwm, excess, sq, total, static_cast<double>(n), l, best);
      }
    if (best.share < kMinShare || best.share < kMinConcentration * best.rows_share) break;
    Region r;
    r.pwm_lo_us = best.lo, r.pwm_hi_us = best.hi, r.vbat_v = best.level;
    r.share = best.share, r.rows_share = best.rows_share;
    r.rmse_g = std::sqrt(best.ss / static_cast<double>(std::max<std::size_t>(best.rows, 1)));
    r.text = describeRegion(r, pmin, pmax);
    out.push_back(r);
    for (std::size_t i : all)
      if (pwm[i] >= r.pwm_lo_us && pwm[i] <= r.pwm_hi_us && (!std::isfinite(r.vbat_v) || level[i] == r.vbat_v))
        taken[i] = true, excess[i] = 0;
  }
  return out;
}

}  // namespace lab
