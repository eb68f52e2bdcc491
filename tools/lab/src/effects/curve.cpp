// `curve`: the base force curve, a monotone cubic spline of the drive (I-spline basis) plus a
// free zero offset. Its coefficients are the fit's linear parameters (non-negative least
// squares keeps the curve monotone); this file gives their basis.
#include <fmt/format.h>

#include <algorithm>

#include "lab/effect.hpp"

namespace lab::effects {
namespace {

constexpr int kSplineDegree = 3;   // cubic B-splines
constexpr int kInteriorKnots = 6;  // at quantiles of the drive
constexpr double kTop = 1.1;       // the basis spans the drive 0..1.1 (room above the data)

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

class Curve : public Term {
 public:
  // Knots from the data alone, never from the effects, so a model with an effect at its neutral
  // value predicts exactly what the model without it does (nested fits). The drive stays below
  // ~1.05 (start >= pmin - 5 % span, V <= V_ref).
  explicit Curve(const Setup& s) {
    const auto& pwm = s.train.col("pwm_us");
    const auto& f = s.train.col("force_g");
    // knots at quantiles of the PWMs where the motor turns (force above 3 % of the largest),
    // and one where it starts turning, so a curve without `deadband` can bend there too
    std::vector<double> u;
    double turn_on = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < pwm.size(); ++i)
      if (f[i] > 0.03 * s.fmax) {
        u.push_back(softPlus(pwm[i] - s.pmin, kSoftStartUs) / s.span / kTop);
        turn_on = std::min(turn_on, u.back());
      }
    if (u.size() < 2) {
      u.clear();
      for (double p : pwm) u.push_back(softPlus(p - s.pmin, kSoftStartUs) / s.span / kTop);
    }
    std::sort(u.begin(), u.end());
    knots_.assign(kSplineDegree + 1, 0.0);
    double last = 0;
    if (std::isfinite(turn_on) && turn_on > 0.02 && turn_on < 0.9) {
      knots_.push_back(turn_on);
      last = turn_on;
    }
    for (int k = 1; k <= kInteriorKnots && !u.empty(); ++k) {
      const double q = u[std::min(u.size() - 1, u.size() * static_cast<std::size_t>(k) / (kInteriorKnots + 1))];
      if (q > last + 0.02 && q < 0.98) {
        knots_.push_back(q);
        last = q;
      }
    }
    for (int k = 0; k <= kSplineDegree; ++k) knots_.push_back(1.0);
  }
  // the basis functions, the constant included
  int linearSize() const override { return static_cast<int>(knots_.size()) - kSplineDegree - 1; }
  // Row of the design matrix: 1 (the offset), then mul * S_j(x).
  void linearRow(double x, double mul, double* row) const override {
    double s[64];
    cumulativeBSpline(x / kTop, knots_, s);
    row[0] = 1.0;
    for (int j = 0; j < linearSize() - 1; ++j) row[j + 1] = mul * s[j];
  }
  std::string linearName(int j) const override { return j == 0 ? "offset_g" : fmt::format("c{}", j); }
  double driveTop() const override { return kTop; }

 private:
  std::vector<double> knots_;  // clamped B-spline knots on [0, 1]
};

}  // namespace

extern const EffectDef kCurve;
const EffectDef kCurve = {
    .name = "curve",
    .role = Role::kBase,
    .physics = "Base force curve: smooth and monotone in the drive x (PWM above the start, scaled by the "
               "voltage terms when present). A monotone cubic spline (I-spline basis: cumulative cubic "
               "B-splines with up to 6 knots at quantiles of the drive, non-negative coefficients), plus "
               "a free zero offset (tare error).",
    .columns = "pwm_us, force_g",
    .params = {{.name = "offset_g", .unit = "g", .meaning = "force at zero drive (linear)"},
               {.name = "c1..c10", .unit = "g", .meaning = "curve steps (linear; up to 10: 6 knots at quantiles and one at the start)", .lo = 0}},
    .exports = Export::kInRecord,
    .suggests = {.variables = {"pwm_us"},
                 .still = "the curve cannot follow the data's shape (an effect that bends it is missing, the force "
                          "collapses at the top, or the PWM logged is not the PWM the ESC saw)"},
    .make = [](Setup& s) -> std::unique_ptr<Term> { return std::make_unique<Curve>(s); },
};

}  // namespace lab::effects
