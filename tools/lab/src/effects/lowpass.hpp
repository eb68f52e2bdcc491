// A first-order low-pass of the drive along each run in logging order, shared by `lag` (the
// motor's dynamics) and `cell` (the bench's filter stages after it).
#pragma once
#include <algorithm>
#include <cmath>
#include <vector>

#include "lab/effect.hpp"

namespace lab::effects {

// x[i] <- x[prev] + (1 - exp(-dt / tau)) * (x[i] - x[prev]), prev the run's previous row; dt from
// t_s when `by_time`, else from the rows' sample index (or 1 a row). `tau(i, rising)` is row i's
// time constant, `rising` when the input is above the filter's last output.
template <class Tau>
void lowPassPerRun(const Rows& b, bool by_time, std::vector<double>& x, Tau tau) {
  std::vector<long> last_row;  // per run: last row seen (-1: none)
  std::vector<double> last_x;
  for (std::size_t i = 0; i < b.n; ++i) {
    const auto r = static_cast<std::size_t>(std::max((*b.run)[i], 0));
    if (r >= last_row.size()) {
      last_row.resize(r + 1, -1);
      last_x.resize(r + 1, 0.0);
    }
    if (last_row[r] >= 0) {
      const auto prev = static_cast<std::size_t>(last_row[r]);
      const double dt = by_time          ? (*b.t)[i] - (*b.t)[prev]
                        : b.sample_index ? (*b.sample_index)[i] - (*b.sample_index)[prev]
                                         : 1.0;
      if (dt > 0 && std::isfinite(dt)) x[i] = last_x[r] + (1 - std::exp(-dt / tau(i, x[i] > last_x[r]))) * (x[i] - last_x[r]);
    }
    last_row[r] = static_cast<long>(i);
    last_x[r] = x[i];
  }
}

}  // namespace lab::effects
