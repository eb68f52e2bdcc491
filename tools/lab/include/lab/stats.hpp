// Small numerical helpers for the lab: non-negative least squares with free variables, and the
// F-distribution's upper tail for significance tests.
#pragma once
#include <Eigen/Dense>

#include <vector>

namespace lab {

// min ||A x - b|| subject to x[j] >= 0 for every j with nonneg[j] true (Lawson-Hanson active
// set; the others are free). Columns that are all zero get 0.
Eigen::VectorXd nnls(const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                     const std::vector<bool>& nonneg);
// The same from the normal equations A^T A and A^T b (the n x k matrix need not be stored).
Eigen::VectorXd nnlsGram(const Eigen::MatrixXd& AtA, const Eigen::VectorXd& Atb,
                         const std::vector<bool>& nonneg);

// P(F > f) for an F(d1, d2) variable.
double fSurvival(double f, double d1, double d2);

// Regularized incomplete beta I_x(a, b).
double incompleteBeta(double a, double b, double x);

}  // namespace lab
