#include "lab/stats.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lab {

Eigen::VectorXd nnls(const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                     const std::vector<bool>& nonneg) {
  return nnlsGram(A.transpose() * A, A.transpose() * b, nonneg);
}

Eigen::VectorXd nnlsGram(const Eigen::MatrixXd& AtA, const Eigen::VectorXd& Atb,
                         const std::vector<bool>& nonneg) {
  // Lawson-Hanson on the normal equations: the active-set iterations solve k x k systems.
  // Columns are scaled to unit norm first.
  const Eigen::Index n = AtA.cols();
  Eigen::VectorXd scale(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const double norm = std::sqrt(std::max(AtA(j, j), 0.0));
    scale[j] = norm > 0 ? 1.0 / norm : 0.0;
  }
  const Eigen::MatrixXd G = scale.asDiagonal() * AtA * scale.asDiagonal();
  const Eigen::VectorXd h = scale.asDiagonal() * Atb;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  std::vector<bool> passive(static_cast<std::size_t>(n), false);
  auto usable = [&](Eigen::Index j) { return scale[j] > 0; };
  for (Eigen::Index j = 0; j < n; ++j)
    if (!nonneg[static_cast<std::size_t>(j)] && usable(j)) passive[static_cast<std::size_t>(j)] = true;

  auto solvePassive = [&](Eigen::VectorXd& z) {
    std::vector<Eigen::Index> idx;
    for (Eigen::Index j = 0; j < n; ++j)
      if (passive[static_cast<std::size_t>(j)]) idx.push_back(j);
    z = Eigen::VectorXd::Zero(n);
    if (idx.empty()) return;
    const Eigen::Index m = static_cast<Eigen::Index>(idx.size());
    Eigen::MatrixXd Gp(m, m);
    Eigen::VectorXd hp(m);
    for (Eigen::Index a = 0; a < m; ++a) {
      hp[a] = h[idx[static_cast<std::size_t>(a)]];
      for (Eigen::Index c = 0; c < m; ++c) Gp(a, c) = G(idx[static_cast<std::size_t>(a)], idx[static_cast<std::size_t>(c)]);
    }
    // a tiny ridge keeps nearly collinear spline columns solvable
    Gp.diagonal().array() += 1e-12;
    const Eigen::VectorXd zp = Gp.ldlt().solve(hp);
    for (Eigen::Index a = 0; a < m; ++a) z[idx[static_cast<std::size_t>(a)]] = zp[a];
  };

  Eigen::VectorXd z;
  solvePassive(z);
  x = z;
  const double tol = 1e-12 * (h.norm() + 1e-300);
  for (int outer = 0; outer < 3 * n + 10; ++outer) {
    const Eigen::VectorXd w = h - G * x;
    Eigen::Index best = -1;
    double best_w = tol;
    for (Eigen::Index j = 0; j < n; ++j) {
      if (passive[static_cast<std::size_t>(j)] || !usable(j)) continue;
      if (w[j] > best_w) { best_w = w[j]; best = j; }
    }
    if (best < 0) break;
    passive[static_cast<std::size_t>(best)] = true;
    for (int inner = 0; inner < 3 * n + 10; ++inner) {
      solvePassive(z);
      double alpha = 1.0;
      bool feasible = true;
      for (Eigen::Index j = 0; j < n; ++j) {
        if (!passive[static_cast<std::size_t>(j)] || !nonneg[static_cast<std::size_t>(j)]) continue;
        if (z[j] <= 0) {
          feasible = false;
          const double denom = x[j] - z[j];
          if (denom > 0) alpha = std::min(alpha, x[j] / denom);
        }
      }
      if (feasible) { x = z; break; }
      x += alpha * (z - x);
      for (Eigen::Index j = 0; j < n; ++j) {
        if (passive[static_cast<std::size_t>(j)] && nonneg[static_cast<std::size_t>(j)] &&
            x[j] <= 1e-14 * (1 + std::abs(z[j]))) {
          passive[static_cast<std::size_t>(j)] = false;
          x[j] = 0;
        }
      }
    }
  }
  for (Eigen::Index j = 0; j < n; ++j) {
    if (nonneg[static_cast<std::size_t>(j)] && x[j] < 0) x[j] = 0;
    x[j] *= scale[j];
  }
  return x;
}

namespace {
// Continued fraction for the incomplete beta (Numerical Recipes betacf, Lentz's method).
double betaContinuedFraction(double a, double b, double x) {
  const double tiny = 1e-300;
  double qab = a + b, qap = a + 1, qam = a - 1;
  double c = 1, d = 1 - qab * x / qap;
  if (std::abs(d) < tiny) d = tiny;
  d = 1 / d;
  double h = d;
  for (int m = 1; m <= 300; ++m) {
    const int m2 = 2 * m;
    double aa = m * (b - m) * x / ((qam + m2) * (a + m2));
    d = 1 + aa * d;
    if (std::abs(d) < tiny) d = tiny;
    c = 1 + aa / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    h *= d * c;
    aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
    d = 1 + aa * d;
    if (std::abs(d) < tiny) d = tiny;
    c = 1 + aa / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1) < 1e-14) break;
  }
  return h;
}
}  // namespace

double incompleteBeta(double a, double b, double x) {
  if (x <= 0) return 0;
  if (x >= 1) return 1;
  const double lbt = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) +
                     b * std::log1p(-x);
  if (x < (a + 1) / (a + b + 2)) return std::exp(lbt) * betaContinuedFraction(a, b, x) / a;
  return 1 - std::exp(lbt) * betaContinuedFraction(b, a, 1 - x) / b;
}

double fSurvival(double f, double d1, double d2) {
  if (!(f > 0)) return 1.0;
  if (!std::isfinite(f)) return 0.0;
  return incompleteBeta(d2 / 2, d1 / 2, d2 / (d2 + d1 * f));
}

}  // namespace lab
