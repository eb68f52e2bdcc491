// The law over a session's operating points (thrustcal/dynamics_fit.hpp, DynamicsLawFit): 1/tau
// linear in sqrt(F) for spin-up and spin-down, by least squares, kept as its values at the
// lowest and highest measured force.
#include <math.h>

#include "thrustcal/dynamics_fit.hpp"

namespace tc {

bool DynamicsLawFit::add(float force_g, float tau_up_s, float tau_down_s) {
  if (count_ >= kDynMaxPoints || !(force_g > 0.0f) || !(tau_up_s > 0.0f) || !(tau_down_s > 0.0f)) return false;
  force_g_[count_] = force_g;
  tau_up_s_[count_] = tau_up_s;
  tau_down_s_[count_] = tau_down_s;
  ++count_;
  return true;
}

namespace {

// 1/tau = a + b sqrt(F) by least squares (b = 0 with one point or one force); values at lo, hi.
void lawEnds(const float* force_g, const float* tau_s, uint8_t n, float s_lo, float s_hi, float& tau_lo,
             float& tau_hi) {
  float ss = 0, sy = 0, sss = 0, ssy = 0;
  for (uint8_t i = 0; i < n; ++i) {
    const float sq = sqrtf(force_g[i]), y = 1.0f / tau_s[i];
    ss += sq, sy += y, sss += sq * sq, ssy += sq * y;
  }
  const float fn = static_cast<float>(n);
  const float den = fn * sss - ss * ss;
  float b = 0.0f;
  if (n >= 2 && den > 1e-6f * fn * sss) b = (fn * ssy - ss * sy) / den;
  const float a = (sy - b * ss) / fn;
  tau_lo = 1.0f / (a + b * s_lo);
  tau_hi = 1.0f / (a + b * s_hi);
}

bool tauStorable(float tau_s) {
  return tau_s >= kDynTauMin01ms * 1e-4f && tau_s <= kDynTauMax01ms * 1e-4f;
}

}  // namespace

bool DynamicsLawFit::build(MotorDynamics& out) const {
  out.clear();
  if (count_ == 0) return false;
  float lo = force_g_[0], hi = force_g_[0];
  for (uint8_t i = 1; i < count_; ++i) {
    if (force_g_[i] < lo) lo = force_g_[i];
    if (force_g_[i] > hi) hi = force_g_[i];
  }
  MotorDynamics d;
  d.points = count_;
  d.lo_dg = static_cast<uint16_t>(lo * 10.0f + 0.5f);
  d.hi_dg = static_cast<uint16_t>(hi * 10.0f + 0.5f);
  float up_lo, up_hi, down_lo, down_hi;
  const float s_lo = sqrtf(static_cast<float>(d.lo_dg) * 0.1f), s_hi = sqrtf(static_cast<float>(d.hi_dg) * 0.1f);
  lawEnds(force_g_, tau_up_s_, count_, s_lo, s_hi, up_lo, up_hi);
  lawEnds(force_g_, tau_down_s_, count_, s_lo, s_hi, down_lo, down_hi);
  if (!tauStorable(up_lo) || !tauStorable(up_hi) || !tauStorable(down_lo) || !tauStorable(down_hi)) return false;
  d.up_lo_01ms = secondsTo01ms(up_lo);
  d.up_hi_01ms = secondsTo01ms(up_hi);
  d.down_lo_01ms = secondsTo01ms(down_lo);
  d.down_hi_01ms = secondsTo01ms(down_hi);
  if (d.lo_dg == d.hi_dg) {
    d.up_hi_01ms = d.up_lo_01ms;
    d.down_hi_01ms = d.down_lo_01ms;
  }
  if (!d.isValid()) return false;
  out = d;
  return true;
}

}  // namespace tc
