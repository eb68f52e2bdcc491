#include "lab/stats.hpp"

#include <cmath>
#include <limits>

namespace lab {

Eigen::VectorXd nnls(const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                     const std::vector<bool>& nonneg) {
  const Eigen::Index n = A.cols();
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  std::vector<bool> passive(static_cast<std::size_t>(n), false);
  for (Eigen::Index j = 0; j < n; ++j)
    if (!nonneg[static_cast<std::size_t>(j)] && A.col(j).squaredNorm() > 0)
      passive[static_cast<std::size_t>(j)] = true;

  auto solvePassive = [&](Eigen::VectorXd& z) {
    std::vector<Eigen::Index> idx;
    for (Eigen::Index j = 0; j < n; ++j)
      if (passive[static_cast<std::size_t>(j)]) idx.push_back(j);
    z = Eigen::VectorXd::Zero(n);
    if (idx.empty()) return;
    Eigen::MatrixXd Ap(A.rows(), static_cast<Eigen::Index>(idx.size()));
    for (std::size_t k = 0; k < idx.size(); ++k) Ap.col(static_cast<Eigen::Index>(k)) = A.col(idx[k]);
    const Eigen::VectorXd zp = Ap.colPivHouseholderQr().solve(b);
    for (std::size_t k = 0; k < idx.size(); ++k) z[idx[k]] = zp[static_cast<Eigen::Index>(k)];
  };

  Eigen::VectorXd z;
  solvePassive(z);
  x = z;
  const double tol = 1e-10 * (A.norm() * b.norm() + 1e-300);
  for (int outer = 0; outer < 3 * n + 10; ++outer) {
    const Eigen::VectorXd w = A.transpose() * (b - A * x);
    Eigen::Index best = -1;
    double best_w = tol;
    for (Eigen::Index j = 0; j < n; ++j) {
      if (passive[static_cast<std::size_t>(j)] || A.col(j).squaredNorm() == 0) continue;
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
  for (Eigen::Index j = 0; j < n; ++j)
    if (nonneg[static_cast<std::size_t>(j)] && x[j] < 0) x[j] = 0;
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
