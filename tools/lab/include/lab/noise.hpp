// The measurement noise estimated from the data alone, so a fit's error can be compared with
// what no model can explain (the noise floor). Two estimators; the first that applies is used:
//
// Pure error (`method` "pure_error"), where the log holds set points: blocks of at least 12
// consecutive rows of a run at one PWM. Each block's steady part (its settling transient left
// out, see noise_setpoints.cpp) scatters about its own mean by the noise alone; sigma^2 is the
// pooled scatter, corrected for the correlation of successive samples (lag-1 autocorrelation r,
// an AR(1) noise: a mean of n samples varies by (1 + r) / (1 - r) / n of it), with
// (1 - r^2) / (1 + r^2) of the pooled degrees of freedom. A model's residual is then tested
// against it (lack of fit: the set points' mean residuals against their noise, an F test).
//
// Neighbours (`method` "neighbours"), where it does not: differences of neighbours at the same conditions, corrected for the curve's local
// shape): the rows of each run and sweep direction (`dir`, else the sign of the PWM's change),
// sorted by PWM (a reading the logger held over several rows counts once); every window of four neighbours gives one contrast e = w . force, w the unit
// vector orthogonal to 1, PWM and PWM^2 over the window, so a force curve that is locally
// quadratic in the drive cancels and e has the noise's variance (four rows at one set point:
// orthogonal to a quadratic in time, so a settling transient cancels). The same contrasts of the other logged conditions
// (voltage, current, temperature, ...; never a column that may hold the force, such as an
// efficiency) are regressed out, so a condition that changes from point to point is not taken
// for noise (a difference-based partially linear fit). Contrasts beyond 4 robust standard
// deviations of the rest (a kink: the ESC's start, a limit, a clipped reading) are features, not
// noise, and are left out and counted. sigma^2 = RSS / (N - k); its 95 % interval is the
// chi-square one with the effective degrees of freedom of the overlapping windows. Neighbouring
// samples may correlate (a filtered reading): the noise is taken as AR(1) in logging order, its
// lag-1 autocorrelation found from how successive contrasts correlate against what independent
// samples give, and sigma corrected for it (a contrast of correlated samples has less variance).
#pragma once
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "lab/dataset.hpp"

namespace lab {

struct NoiseEstimate {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  double sigma_g = kNaN;  // one standard deviation of the force reading's noise; NaN: not estimated
  double lo_g = kNaN, hi_g = kNaN;  // its 95 % interval
  double dof = 0;               // effective degrees of freedom of the estimate
  std::size_t contrasts = 0;    // windows used
  std::size_t features = 0;     // windows left out as features (beyond 4 robust SD)
  std::vector<std::string> conditions;  // columns whose contrasts were regressed out
  std::string why_not;                  // when sigma_g is NaN: why
  std::string note;                     // what was done to the rows first, if anything
  std::string method;      // "pure_error" or "neighbours"
  std::string assumption;  // what the estimate assumes, in words
  double lag1 = kNaN;      // lag-1 autocorrelation of the noise between successive samples
  double uncorrected_g = kNaN;  // neighbours: sigma as if successive samples were independent
  double successive_g = kNaN;   // pure error: sqrt(mean squared successive difference / 2)
  std::size_t setpoints = 0;      // pure error: set points used
  std::size_t steady_rows = 0;    // pure error: their steady rows
  std::size_t setpoint_rows = 0;  // pure error: the rows of every set point (steady and settling)
  std::vector<int> setpoint_of_row;  // pure error: each row's set point, -1 when not a steady row
  bool known() const;
};

// The estimate the lab uses: pure error where the log holds set points, else neighbours.
NoiseEstimate estimateNoise(const Dataset& data);
// Each estimator alone (sigma_g NaN and why_not set when it does not apply).
NoiseEstimate pureErrorNoise(const Dataset& data);
NoiseEstimate neighbourNoise(const Dataset& data);

// A model's residual against the pure error: the set points' mean residuals (steady rows) against
// the variance their noise gives them; F = sum n_b rbar_b^2 / (m - k) / (sigma^2 (1 + r) / (1 - r)),
// F(m - k, dof) under the model. Not tested without set points or with m <= k.
constexpr double kLackOfFitAlpha = 0.01;
struct LackOfFit {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  bool tested = false;
  double f = kNaN, dof1 = 0, dof2 = 0, p_value = kNaN;
  bool significant = false;      // p below kLackOfFitAlpha: the model misses the set points
  double setpoint_rms_g = kNaN;  // RMS of the set points' mean residuals
  double excess_g = kNaN;        // of it, beyond what the noise of a mean explains
  std::string why_not;           // when not tested
  std::string text;              // the test in words
};
LackOfFit lackOfFit(const NoiseEstimate& noise, const std::vector<double>& residual_g, int params);

// "0.52 g (0.47..0.58, 95 %)" or "not estimated (...)".
std::string describe(const NoiseEstimate& noise);

// The chi-square distribution's p-quantile (Wilson-Hilferty; within 1 % of the exact value
// from 5 degrees of freedom on).
double chiSquareQuantile(double p, double dof);

}  // namespace lab
