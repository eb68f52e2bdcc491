// The mixer (mixer.hpp).
#include "mixer.hpp"

namespace fly {

namespace {

constexpr float kGramsPerNewton = 1000.0f / 9.80665f;
constexpr uint8_t kQuad = 4;

// The lowest and highest of the flown motors' values (motors 0..n-1).
void bounds(const ForceQ4 (&v)[4], uint8_t n, ForceQ4& lo, ForceQ4& hi) {
  lo = v[0];
  hi = v[0];
  for (uint8_t i = 1; i < n; ++i) {
    if (v[i] < lo) lo = v[i];
    if (v[i] > hi) hi = v[i];
  }
}

// A float already in 1/16 g, rounded.
ForceQ4 rounded(float q4) { return static_cast<ForceQ4>(q4 < 0 ? q4 - 0.5f : q4 + 0.5f); }

// a * num / den for the saturation path (rare): in float, the products exceed 32 bits.
ForceQ4 scaled(ForceQ4 a, ForceQ4 num, ForceQ4 den) {
  return toQ4(gramsOf(a) * (static_cast<float>(num) / static_cast<float>(den)));
}

}  // namespace

void Mixer::configure(Layout layout, float arm_m, float yaw_arm_m) {
  layout_ = layout;
  const float lever_m = layout == Layout::kX ? 2.0f * 1.41421356f * arm_m : 2.0f * arm_m;
  q4_per_nm_xy_ = kQ4PerGram * kGramsPerNewton / lever_m;
  q4_per_nm_z_ = kQ4PerGram * kGramsPerNewton / (4.0f * yaw_arm_m);
}

// Roll and pitch per motor, written out per layout (mixer.hpp's signs): no table, no branch per
// term. Yaw is -z, +z, -z, +z on both quad layouts (counter-clockwise motors 0 and 2).
void Mixer::rollPitch(ForceQ4 x, ForceQ4 y, ForceQ4 (&rp)[4]) const {
  switch (layout_) {
    case Layout::kPlus:
      rp[0] = -y;
      rp[1] = x;
      rp[2] = y;
      rp[3] = -x;
      break;
    case Layout::kX:
      rp[0] = x - y;
      rp[1] = x + y;
      rp[2] = y - x;
      rp[3] = -x - y;
      break;
    case Layout::kSeesaw:
      rp[0] = x;
      rp[1] = -x;
      rp[2] = 0;
      rp[3] = 0;
      break;
  }
}

uint8_t Mixer::mix(ForceQ4 collective, const Torque& torque, ForceQ4 min, ForceQ4 max,
                   ForceQ4 (&force)[4]) const {
  TorqueQ4 t;
  t.x = rounded(torque.x_nm * q4_per_nm_xy_);
  t.y = rounded(torque.y_nm * q4_per_nm_xy_);
  t.z = rounded(torque.z_nm * q4_per_nm_z_);
  return mixQ4(collective, t, min, max, force);
}

uint8_t Mixer::mixQ4(ForceQ4 collective, const TorqueQ4& torque, ForceQ4 min, ForceQ4 max,
                     ForceQ4 (&force)[4]) const {
  const uint8_t n = motorCount();
  const ForceQ4 z = layout_ == Layout::kSeesaw ? 0 : torque.z;
  ForceQ4 rp[4];
  rollPitch(torque.x, torque.y, rp);
  ForceQ4 e[4];
  for (uint8_t i = 0; i < kQuad; ++i) e[i] = (i & 1u) ? rp[i] + z : rp[i] - z;
  ForceQ4 lo, hi;
  bounds(e, n, lo, hi);
  const ForceQ4 range = max > min ? max - min : 0;
  uint8_t limits = 0;
  if (hi - lo > range) limits = fit(rp, z, range, e, lo, hi);
  ForceQ4 c = collective;
  if (c < min - lo) {
    c = min - lo;
    limits |= kMixCollectiveLimited;
  } else if (c > max - hi) {
    c = max - hi;
    limits |= kMixCollectiveLimited;
  }
  for (uint8_t i = 0; i < kQuad; ++i) force[i] = i < n ? c + e[i] : 0;
  return limits;
}

// The spread of roll, pitch and yaw exceeds the motors' range: roll and pitch keep what they
// can (all of it when they fit alone), yaw the rest. The spread is convex in the yaw share, so
// the share (range - rp spread) / (spread - rp spread) fits.
uint8_t Mixer::fit(const ForceQ4 (&rp)[4], ForceQ4 z, ForceQ4 range, ForceQ4 (&e)[4], ForceQ4& lo,
                   ForceQ4& hi) const {
  const uint8_t n = motorCount();
  const ForceQ4 full_spread = hi - lo;
  bounds(rp, n, lo, hi);
  const ForceQ4 rp_spread = hi - lo;
  if (rp_spread > range) {  // roll and pitch alone do not fit: scale them, no yaw
    for (uint8_t i = 0; i < kQuad; ++i) e[i] = scaled(rp[i], range, rp_spread);
    bounds(e, n, lo, hi);
    return kMixRollPitchLimited | kMixYawLimited;
  }
  const ForceQ4 share_z = scaled(z, range - rp_spread, full_spread - rp_spread);
  for (uint8_t i = 0; i < kQuad; ++i) e[i] = (i & 1u) ? rp[i] + share_z : rp[i] - share_z;
  bounds(e, n, lo, hi);
  return kMixYawLimited;
}

}  // namespace fly
