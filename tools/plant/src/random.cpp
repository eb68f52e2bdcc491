#include "plant/random.hpp"

#include <algorithm>
#include <cmath>

namespace plant {

double Rng::normal() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  double u, v, s;
  do {
    u = 2.0 * uniform() - 1.0;
    v = 2.0 * uniform() - 1.0;
    s = u * u + v * v;
  } while (s >= 1.0 || s == 0.0);
  const double f = std::sqrt(-2.0 * std::log(s) / s);
  spare_ = v * f;
  has_spare_ = true;
  return u * f;
}

double Rng::normal(double sigma, double clamp_sigmas) {
  const double z = std::clamp(normal(), -clamp_sigmas, clamp_sigmas);
  return sigma * z;
}

}  // namespace plant
