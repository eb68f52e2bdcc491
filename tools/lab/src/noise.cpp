#include "lab/noise.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>

#include "noise_rows.hpp"

namespace lab {

namespace {

constexpr std::size_t kWindow = 4;          // rows per contrast: orthogonal to a quadratic
constexpr double kFeatureSd = 4.0;          // contrasts beyond this many robust SD are features
constexpr double kMedianChi2One = 0.454936; // median of a chi-square with one degree of freedom
constexpr double kMinDof = 5.0;
constexpr double kDenseShare = 0.005;       // neighbours this close in PWM (share of its span): a ramp
constexpr std::size_t kMinLevelWindows = 30;  // level windows of each spacing before rho is estimated

// The unit contrast over a window's abscissae x[0..3] orthogonal to 1, x and x^2 (those of them
// the points can tell apart); false when there is none.
bool contrastWeights(const double* x, double* w) {
  const double mean = (x[0] + x[1] + x[2] + x[3]) / 4.0;
  double scale = 0;
  for (std::size_t k = 0; k < kWindow; ++k) scale = std::max(scale, std::fabs(x[k] - mean));
  if (!(scale > 0)) scale = 1;
  Eigen::Matrix4d q = Eigen::Matrix4d::Zero();
  int nq = 0;
  for (int power = 0; power <= 2; ++power) {
    Eigen::Vector4d b;
    for (std::size_t k = 0; k < kWindow; ++k) b[static_cast<Eigen::Index>(k)] = std::pow((x[k] - mean) / scale, power);
    for (int j = 0; j < nq; ++j) b -= q.col(j).dot(b) * q.col(j);
    if (b.norm() < 1e-9) continue;
    q.col(nq++) = b.normalized();
  }
  const Eigen::Matrix4d p = Eigen::Matrix4d::Identity() - q.leftCols(nq) * q.leftCols(nq).transpose();
  Eigen::Index best = 0;
  for (Eigen::Index j = 1; j < 4; ++j)
    if (p.col(j).norm() > p.col(best).norm()) best = j;
  if (p.col(best).norm() < 1e-9) return false;
  const Eigen::Vector4d u = p.col(best).normalized();
  for (std::size_t k = 0; k < kWindow; ++k) w[k] = u[static_cast<Eigen::Index>(k)];
  return true;
}

// One contrast: its window's first row in the group's order, its group, its weights.
struct Window {
  std::size_t group = 0, start = 0, step = 1;  // rows start, start + step, ... of the group
  bool in_time = false;                        // at one set point (else along the PWM)
  double w[kWindow] = {};
};

// The windows of four neighbours (`step` 2: every other row): along the PWM where the four PWMs
// differ, along time where they are one set point (a transient is smooth in time), none where they
// mix the two.
std::vector<Window> windowsOf(const Dataset& d, const std::vector<std::vector<std::size_t>>& groups,
                              std::size_t step = 1) {
  const auto& pwm = d.col("pwm_us");
  const std::vector<double>* t = d.has("t_s") ? &d.col("t_s") : nullptr;
  std::vector<Window> out;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    const auto& rows = groups[g];
    for (std::size_t s = 0; s + step * (kWindow - 1) < rows.size(); ++s) {
      double p[kWindow], x[kWindow];
      std::size_t distinct = 1;
      for (std::size_t k = 0; k < kWindow; ++k) {
        p[k] = pwm[rows[s + step * k]];
        if (k && p[k] != p[k - 1]) ++distinct;
      }
      Window w;
      if (distinct == kWindow) {
        std::copy(p, p + kWindow, x);
      } else if (distinct == 1) {
        w.in_time = true;
        for (std::size_t k = 0; k < kWindow; ++k) {
          const std::size_t r = rows[s + step * k];
          x[k] = t && std::isfinite((*t)[r]) ? (*t)[r] : static_cast<double>(r);
        }
      } else {
        continue;
      }
      w.group = g;
      w.start = s;
      w.step = step;
      if (contrastWeights(x, w.w)) out.push_back(w);
    }
  }
  return out;
}

// Cov(e_i, e_j) / sigma^2 of two windows' contrasts of one group when the noise is AR(1) with
// lag-1 autocorrelation rho along the group's rows (rho 0: independent samples).
double contrastCov(const Window& a, const Window& b, double rho) {
  double c = 0;
  for (std::size_t p = 0; p < kWindow; ++p)
    for (std::size_t q = 0; q < kWindow; ++q) {
      const double lag = std::fabs(static_cast<double>(a.start + a.step * p) - static_cast<double>(b.start + b.step * q));
      c += a.w[p] * b.w[q] * (lag == 0 ? 1.0 : std::pow(rho, lag));
    }
  return c;
}

// Effective degrees of freedom of the kept contrasts: overlapping windows share rows, and
// correlated samples tie windows further apart, so their contrasts correlate;
// nu = (N - k) / N * (sum_i C_ii)^2 / sum_ij C_ij^2.
double effectiveDof(const std::vector<Window>& win, const std::vector<bool>& keep, std::size_t n_kept,
                    std::size_t k, double rho) {
  // windows further apart than this share (almost) nothing
  const std::size_t reach = kWindow - 1 + (rho > 0 ? static_cast<std::size_t>(std::min(30.0, std::log(1e-3) / std::log(rho))) : 0);
  double diag = 0, sum_c2 = 0;
  for (std::size_t i = 0; i < win.size(); ++i) {
    if (!keep[i]) continue;
    const double cii = contrastCov(win[i], win[i], rho);
    diag += cii;
    sum_c2 += cii * cii;
    for (std::size_t j = i + 1; j < win.size() && win[j].group == win[i].group && win[j].start - win[i].start <= reach;
         ++j) {
      if (!keep[j]) continue;
      const double c = contrastCov(win[i], win[j], rho);
      sum_c2 += 2 * c * c;
    }
  }
  const double n = static_cast<double>(n_kept);
  return (n - static_cast<double>(k)) / n * diag * diag / sum_c2;
}

// The windows whose rows see (nearly) the same force: at one set point in time, or along a dense
// drive (a ramp whose neighbours lie within kDenseShare of the PWM span); a sweep's one reading
// per set point is neither.
bool nearlyLevel(const Window& w, const std::vector<bool>& dense_group) { return w.in_time || dense_group[w.group]; }

std::vector<bool> denseGroups(const Dataset& d, const std::vector<std::vector<std::size_t>>& groups) {
  const auto& pwm = d.col("pwm_us");
  const auto [lo, hi] = std::minmax_element(pwm.begin(), pwm.end());
  std::vector<bool> dense(groups.size(), false);
  for (std::size_t g = 0; g < groups.size(); ++g) {
    std::vector<double> steps;
    for (std::size_t k = 1; k < groups[g].size(); ++k)
      if (pwm[groups[g][k]] != pwm[groups[g][k - 1]])
        steps.push_back(std::fabs(pwm[groups[g][k]] - pwm[groups[g][k - 1]]));
    if (steps.empty()) continue;
    std::nth_element(steps.begin(), steps.begin() + static_cast<long>(steps.size() / 2), steps.end());
    dense[g] = steps[steps.size() / 2] <= kDenseShare * (*hi - *lo);
  }
  return dense;
}

// Sum of the squared contrasts of the level windows, features beyond 4 robust SD left out, and
// their expectation's coefficients: E sum e^2 = sigma^2 sum_d alpha_d rho^(step d).
double levelContrasts(const Dataset& d, const std::vector<std::vector<std::size_t>>& groups,
                      const std::vector<Window>& win, const std::vector<bool>& dense, std::vector<double>& alpha,
                      std::size_t& used) {
  const auto& f = d.col("force_g");
  std::vector<double> e2;
  std::vector<const Window*> level;
  for (const auto& w : win) {
    if (!nearlyLevel(w, dense)) continue;
    double e = 0;
    for (std::size_t k = 0; k < kWindow; ++k) e += w.w[k] * f[groups[w.group][w.start + w.step * k]];
    e2.push_back(e * e);
    level.push_back(&w);
  }
  alpha.assign(kWindow, 0.0);
  used = 0;
  if (e2.empty()) return 0;
  std::vector<double> sorted = e2;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
  const double cut = kFeatureSd * kFeatureSd * sorted[sorted.size() / 2] / kMedianChi2One;
  double sum = 0;
  for (std::size_t i = 0; i < e2.size(); ++i) {
    if (e2[i] > cut) continue;
    sum += e2[i];
    ++used;
    for (std::size_t p = 0; p < kWindow; ++p)
      for (std::size_t q = 0; q < kWindow; ++q) alpha[p > q ? p - q : q - p] += level[i]->w[p] * level[i]->w[q];
  }
  return sum;
}

// The noise's lag-1 autocorrelation, AR(1) along the groups' rows: contrasts of every other row
// vary more than those of neighbours when successive samples correlate (E e^2 = sigma^2
// sum_pq w_p w_q rho^(step |p - q|)). Only from windows over which the force is level; 0 (the rows
// taken as independent) where there are too few of them.
double lag1Of(const Dataset& d, const std::vector<std::vector<std::size_t>>& groups, const std::vector<Window>& win1) {
  const std::vector<bool> dense = denseGroups(d, groups);
  const std::vector<Window> win2 = windowsOf(d, groups, 2);
  std::vector<double> a1, a2;
  std::size_t n1 = 0, n2 = 0;
  const double s1 = levelContrasts(d, groups, win1, dense, a1, n1);
  const double s2 = levelContrasts(d, groups, win2, dense, a2, n2);
  if (n1 < kMinLevelWindows || n2 < kMinLevelWindows || !(s1 > 0) || !(s2 > 0)) return 0;
  auto poly = [](const std::vector<double>& c, double x) {
    double v = 0, pw = 1;
    for (double a : c) v += a * pw, pw *= x;
    return v;
  };
  const double seen = s1 / s2;
  auto gap = [&](double rho) { return seen - poly(a1, rho) / poly(a2, rho * rho); };
  double lo = 0, hi = noise_rows::kMaxLag1;
  if (gap(lo) >= 0) return 0;
  if (gap(hi) <= 0) return hi;
  for (int it = 0; it < 50; ++it) {
    const double mid = 0.5 * (lo + hi);
    (gap(mid) < 0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// Least squares of e on the columns of Z over the kept rows, from the normal equations (Z's
// columns have unit RMS; a combination the rows do not determine is dropped); returns the
// residuals of every row and the rank used.
Eigen::VectorXd regressOut(const Eigen::VectorXd& e, const Eigen::MatrixXd& z, const std::vector<bool>& keep,
                           Eigen::Index& rank) {
  rank = 0;
  if (z.cols() == 0) return e;
  Eigen::MatrixXd g = Eigen::MatrixXd::Zero(z.cols(), z.cols());
  Eigen::VectorXd h = Eigen::VectorXd::Zero(z.cols());
  for (Eigen::Index i = 0; i < z.rows(); ++i) {
    if (!keep[static_cast<std::size_t>(i)]) continue;
    g.selfadjointView<Eigen::Lower>().rankUpdate(z.row(i).transpose());
    h.noalias() += z.row(i).transpose() * e[i];
  }
  g = g.selfadjointView<Eigen::Lower>();
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(g);
  cod.setThreshold(1e-12);
  rank = cod.rank();
  const Eigen::VectorXd beta = cod.solve(h);
  return e - z * beta;
}

// The contrasts of the force and of the conditions, one row per window; the conditions' columns
// scaled to unit RMS, and dropped when their contrasts vanish (a condition constant within
// every window, or one that moves with the drive: the window cancels it).
void contrastsOf(const Dataset& d, const std::vector<std::vector<std::size_t>>& groups, const std::vector<Window>& win,
                 Eigen::VectorXd& e, Eigen::MatrixXd& z, std::vector<std::string>& names) {
  const auto& f = d.col("force_g");
  const std::vector<std::size_t> cond = noise_rows::conditionColumns(d);
  const auto n = static_cast<Eigen::Index>(win.size());
  const auto nc = static_cast<Eigen::Index>(cond.size());
  e.resize(n);
  // per condition: its contrast, and the contrast times the window's mean force (a condition
  // that changes the force by a factor changes it more where the force is larger)
  Eigen::MatrixXd all(n, 2 * nc);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Window& w = win[static_cast<std::size_t>(i)];
    const auto& rows = groups[w.group];
    double ef = 0, fbar = 0;
    for (std::size_t k = 0; k < kWindow; ++k) {
      ef += w.w[k] * f[rows[w.start + k]];
      fbar += f[rows[w.start + k]] / static_cast<double>(kWindow);
    }
    e[i] = ef;
    for (Eigen::Index c = 0; c < nc; ++c) {
      double ez = 0;
      for (std::size_t k = 0; k < kWindow; ++k) ez += w.w[k] * d.columns[cond[static_cast<std::size_t>(c)]][rows[w.start + k]];
      all(i, c) = ez;
      all(i, nc + c) = fbar * ez;
    }
  }
  std::vector<Eigen::Index> used;
  for (Eigen::Index c = 0; c < nc; ++c) {
    const auto& v = d.columns[cond[static_cast<std::size_t>(c)]];
    const double mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
    double ss = 0;
    for (double x : v) ss += (x - mean) * (x - mean);
    const double sd = std::sqrt(ss / static_cast<double>(v.size()));
    const double rms = n ? all.col(c).norm() / std::sqrt(static_cast<double>(n)) : 0;
    if (!(rms > 1e-6 * sd)) continue;
    for (Eigen::Index col : {c, nc + c}) {
      const double norm = all.col(col).norm() / std::sqrt(static_cast<double>(n));
      if (!(norm > 0)) continue;
      all.col(col) /= norm;
      used.push_back(col);
    }
    names.push_back(d.names[cond[static_cast<std::size_t>(c)]]);
  }
  if (used.size() == static_cast<std::size_t>(all.cols())) {
    z = std::move(all);
    return;
  }
  z.resize(n, static_cast<Eigen::Index>(used.size()));
  for (std::size_t c = 0; c < used.size(); ++c) z.col(static_cast<Eigen::Index>(c)) = all.col(used[c]);
}

double medianOfSquares(const Eigen::VectorXd& r, const std::vector<bool>& keep) {
  std::vector<double> sq;
  for (Eigen::Index i = 0; i < r.size(); ++i)
    if (keep[static_cast<std::size_t>(i)]) sq.push_back(r[i] * r[i]);
  if (sq.empty()) return 0;
  const auto mid = sq.begin() + static_cast<long>(sq.size() / 2);
  std::nth_element(sq.begin(), mid, sq.end());
  return *mid;
}

}  // namespace

bool NoiseEstimate::known() const { return std::isfinite(sigma_g); }

double chiSquareQuantile(double p, double dof) {
  // the standard normal quantile (Acklam's rational approximation, central region and tails)
  auto normalQuantile = [](double q) {
    static const double a[] = {-3.969683028665376e+01, 2.209460984245205e+02, -2.759285104469687e+02,
                               1.383577518672690e+02, -3.066479806614716e+01, 2.506628277459239e+00};
    static const double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                               6.680131188771972e+01, -1.328068155288572e+01};
    static const double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                               -2.549732539343734e+00, 4.374664141464968e+00, 2.938163982698783e+00};
    static const double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                               3.754408661907416e+00};
    if (q < 0.02425) {
      const double s = std::sqrt(-2 * std::log(q));
      return (((((c[0] * s + c[1]) * s + c[2]) * s + c[3]) * s + c[4]) * s + c[5]) /
             ((((d[0] * s + d[1]) * s + d[2]) * s + d[3]) * s + 1);
    }
    if (q > 1 - 0.02425) {
      const double s = std::sqrt(-2 * std::log(1 - q));
      return -(((((c[0] * s + c[1]) * s + c[2]) * s + c[3]) * s + c[4]) * s + c[5]) /
             ((((d[0] * s + d[1]) * s + d[2]) * s + d[3]) * s + 1);
    }
    const double s = q - 0.5, r = s * s;
    return (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * s /
           (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1);
  };
  const double h = 2.0 / (9.0 * dof);
  const double c = 1 - h + normalQuantile(p) * std::sqrt(h);
  return dof * std::max(c, 0.0) * std::max(c, 0.0) * std::max(c, 0.0);
}

NoiseEstimate neighbourNoise(const Dataset& data) {
  NoiseEstimate out;
  out.method = "neighbours";
  if (!data.has("pwm_us") || !data.has("force_g")) {
    out.why_not = "the data have no pwm_us or force_g";
    return out;
  }
  bool held = false;
  const auto groups = noise_rows::neighbourGroups(data, held);
  if (held) out.note = "most rows repeat the previous force reading (held between updates): one row per update used";
  const std::vector<Window> win = windowsOf(data, groups);
  Eigen::VectorXd e;
  Eigen::MatrixXd z;
  contrastsOf(data, groups, win, e, z, out.conditions);
  std::vector<bool> keep(win.size(), true);
  Eigen::Index rank = 0;
  // robust scale of the first residuals, then the features left out and the fit again
  Eigen::VectorXd r = regressOut(e, z, keep, rank);
  const double robust_sd = std::sqrt(medianOfSquares(r, keep) / kMedianChi2One);
  std::size_t n_kept = 0;
  for (std::size_t i = 0; i < win.size(); ++i) {
    keep[i] = std::fabs(r[static_cast<Eigen::Index>(i)]) <= kFeatureSd * robust_sd;
    n_kept += keep[i] ? 1 : 0;
  }
  out.features = win.size() - n_kept;
  out.contrasts = n_kept;
  r = regressOut(e, z, keep, rank);
  double rss = 0;
  for (std::size_t i = 0; i < win.size(); ++i)
    if (keep[i]) rss += r[static_cast<Eigen::Index>(i)] * r[static_cast<Eigen::Index>(i)];
  const double dof_rss = static_cast<double>(n_kept) - static_cast<double>(rank);
  out.lag1 = dof_rss > 0 ? lag1Of(data, groups, win) : 0;
  std::vector<double> alpha(kWindow, 0.0);  // E rss = sigma^2 sum_d alpha_d rho^d over the kept windows
  for (std::size_t i = 0; i < win.size(); ++i)
    if (keep[i])
      for (std::size_t p = 0; p < kWindow; ++p)
        for (std::size_t q = 0; q < kWindow; ++q) alpha[p > q ? p - q : q - p] += win[i].w[p] * win[i].w[q];
  out.dof = dof_rss > 0 ? effectiveDof(win, keep, n_kept, static_cast<std::size_t>(rank), out.lag1) : 0;
  if (!(out.dof >= kMinDof)) {
    out.why_not = fmt::format("too few neighbouring rows: {} windows of four rows sorted by PWM within a run "
                              "(need enough for {} degrees of freedom); log more points per sweep",
                              win.size(), kMinDof);
    out.conditions.clear();
    return out;
  }
  out.uncorrected_g = std::sqrt(rss / dof_rss);
  // a contrast of AR(1) samples has the variance sum_d alpha_d rho^d / N of independent ones'
  double shrink = 0, pw = 1;
  for (double a : alpha) shrink += a * pw, pw *= out.lag1;
  shrink /= static_cast<double>(n_kept);
  out.sigma_g = out.uncorrected_g / std::sqrt(std::max(shrink, 1e-6));
  out.lo_g = out.sigma_g * std::sqrt(out.dof / chiSquareQuantile(0.975, out.dof));
  out.hi_g = out.sigma_g * std::sqrt(out.dof / chiSquareQuantile(0.025, out.dof));
  out.assumption = fmt::format(
      "no set point is held long enough to repeat it: neighbouring rows (four at a time, sorted by PWM within a "
      "sweep, or in time at one PWM) see the same force up to a quadratic in the drive, so their contrasts are "
      "noise; {}",
      out.lag1 > 0 ? fmt::format("the noise is AR(1) in logging order, lag-1 autocorrelation {:.2f} (contrasts of "
                                 "every other row against neighbours', where the force is level), sigma corrected "
                                 "for it ({:.3g} g if the samples were independent)",
                                 out.lag1, out.uncorrected_g)
                   : std::string("successive rows are taken as independent (too few rows at one set point or along "
                                 "a dense ramp to measure their correlation, or none found)"));
  return out;
}

NoiseEstimate estimateNoise(const Dataset& data) {
  NoiseEstimate pure = pureErrorNoise(data);
  const NoiseEstimate neighbours = neighbourNoise(data);
  if (!pure.known()) return neighbours;
  // what the neighbours' contrasts would have said, for the record
  pure.uncorrected_g = neighbours.uncorrected_g;
  pure.contrasts = neighbours.contrasts;
  pure.features = neighbours.features;
  pure.note = neighbours.note;
  return pure;
}

std::string describe(const NoiseEstimate& n) {
  if (!n.known()) return "not estimated (" + n.why_not + ")";
  return fmt::format("{:.3g} g ({:.3g}..{:.3g}, 95 %)", n.sigma_g, n.lo_g, n.hi_g);
}

}  // namespace lab
