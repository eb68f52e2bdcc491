// The measurement noise estimated from the data alone, so a fit's error can be compared with
// what no model can explain (the noise floor).
//
// Method (differences of neighbours at the same conditions, corrected for the curve's local
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
// chi-square one with the effective degrees of freedom of the overlapping windows.
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
  bool known() const;
};

NoiseEstimate estimateNoise(const Dataset& data);

// "0.52 g (0.47..0.58, 95 %)" or "not estimated (...)".
std::string describe(const NoiseEstimate& noise);

// The chi-square distribution's p-quantile (Wilson-Hilferty; within 1 % of the exact value
// from 5 degrees of freedom on).
double chiSquareQuantile(double p, double dof);

}  // namespace lab
