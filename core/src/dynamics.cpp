// The dynamics law and its stored form (thrustcal/dynamics.hpp).
#include "thrustcal/dynamics.hpp"

#include <math.h>

namespace tc {

namespace {

bool tauInRange(uint16_t tau_01ms) { return tau_01ms >= kDynTauMin01ms && tau_01ms <= kDynTauMax01ms; }

// 1/tau linear in sqrt(force) through the two stored ends, bounded to the stored range.
float lawTauS(const MotorDynamics& d, uint16_t lo_01ms, uint16_t hi_01ms, float force_g) {
  if (!d.isPresent()) return 0.0f;
  const float inv_lo = 1e4f / static_cast<float>(lo_01ms);
  const float inv_hi = 1e4f / static_cast<float>(hi_01ms);
  float inv = inv_lo;
  if (d.hi_dg > d.lo_dg) {
    const float s_lo = sqrtf(static_cast<float>(d.lo_dg) * 0.1f);
    const float s_hi = sqrtf(static_cast<float>(d.hi_dg) * 0.1f);
    const float s = sqrtf(force_g > 0.0f ? force_g : 0.0f);
    inv = inv_lo + (inv_hi - inv_lo) * (s - s_lo) / (s_hi - s_lo);
  }
  const float inv_min = 1e4f / static_cast<float>(kDynTauMax01ms);
  const float inv_max = 1e4f / static_cast<float>(kDynTauMin01ms);
  if (inv < inv_min) inv = inv_min;
  if (inv > inv_max) inv = inv_max;
  return 1.0f / inv;
}

}  // namespace

bool MotorDynamics::isValid() const {
  if (points < 1 || points > kDynMaxPoints || lo_dg == 0 || lo_dg > hi_dg) return false;
  if (!tauInRange(up_lo_01ms) || !tauInRange(up_hi_01ms) || !tauInRange(down_lo_01ms) ||
      !tauInRange(down_hi_01ms))
    return false;
  if (lo_dg == hi_dg) return up_lo_01ms == up_hi_01ms && down_lo_01ms == down_hi_01ms;
  return true;
}

float MotorDynamics::tauUpS(float force_g) const { return lawTauS(*this, up_lo_01ms, up_hi_01ms, force_g); }

float MotorDynamics::tauDownS(float force_g) const {
  return lawTauS(*this, down_lo_01ms, down_hi_01ms, force_g);
}

bool operator==(const MotorDynamics& a, const MotorDynamics& b) {
  return a.points == b.points && a.lo_dg == b.lo_dg && a.hi_dg == b.hi_dg && a.up_lo_01ms == b.up_lo_01ms &&
         a.up_hi_01ms == b.up_hi_01ms && a.down_lo_01ms == b.down_lo_01ms && a.down_hi_01ms == b.down_hi_01ms;
}

uint16_t secondsTo01ms(float seconds) {
  const float q = seconds * 1e4f + 0.5f;
  if (!(q > 0.0f)) return 0;
  if (q >= 65535.0f) return 65535u;
  return static_cast<uint16_t>(q);
}

}  // namespace tc
