// The noise floor's rows (noise.cpp, noise_rows.cpp): which logged columns are conditions and
// which rows are neighbours.
#pragma once
#include <cstddef>
#include <vector>

#include "lab/dataset.hpp"

namespace lab::noise_rows {

// The largest lag-1 autocorrelation of neighbouring readings the noise estimators accept: past
// it the correlated-sample correction (1 + rho) / (1 - rho) grows without bound.
inline constexpr double kMaxLag1 = 0.95;

// The logged conditions whose contrasts are regressed out: every other numeric column logged on
// every row, not constant, and not one that may be computed from the force (a thrust in other
// units, an efficiency in g/W).
std::vector<std::size_t> conditionColumns(const Dataset& d);

// The rows of each sweep (a run's rows in logging order, cut where the direction turns), sorted
// by PWM, then by time or logging order; held repeats of a reading left out (`held`: the logger
// held its reading between updates).
std::vector<std::vector<std::size_t>> neighbourGroups(const Dataset& d, bool& held);

}  // namespace lab::noise_rows
