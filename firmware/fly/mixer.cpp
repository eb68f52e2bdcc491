// The mixer (mixer.hpp).
#include "mixer.hpp"

namespace fly {

namespace {

constexpr float kGramsPerNewton = 1000.0f / 9.80665f;
constexpr uint8_t kQuad = 4;

// The lowest and highest of the flown motors' values (motors 0..n-1).
void bounds(const float (&v)[4], uint8_t n, float& lo, float& hi) {
  lo = v[0];
  hi = v[0];
  for (uint8_t i = 1; i < n; ++i) {
    if (v[i] < lo) lo = v[i];
    if (v[i] > hi) hi = v[i];
  }
}

}  // namespace

void Mixer::configure(Layout layout, float arm_m, float yaw_arm_m) {
  layout_ = layout;
  const float lever_m = layout == Layout::kX ? 2.0f * 1.41421356f * arm_m : 2.0f * arm_m;
  g_per_nm_xy_ = kGramsPerNewton / lever_m;
  g_per_nm_z_ = kGramsPerNewton / (4.0f * yaw_arm_m);
}

// Roll and pitch per motor, written out per layout (mixer.hpp's signs): no table, no branch per
// term. Yaw is -z, +z, -z, +z on both quad layouts (counter-clockwise motors 0 and 2).
void Mixer::rollPitch(float x, float y, float (&rp)[4]) const {
  switch (layout_) {
    case Layout::kPlus:
      rp[0] = -y;
      rp[1] = x;
      rp[2] = y;
      rp[3] = -x;
      break;
    case Layout::kX: {
      const float a = x - y, b = x + y;
      rp[0] = a;
      rp[1] = b;
      rp[2] = -a;
      rp[3] = -b;
      break;
    }
    case Layout::kSeesaw:
      rp[0] = x;
      rp[1] = -x;
      rp[2] = 0;
      rp[3] = 0;
      break;
  }
}

uint8_t Mixer::mix(float collective_g, const Torque& torque, float min_g, float max_g, float (&force_g)[4]) const {
  const uint8_t n = motorCount();
  const float z = layout_ == Layout::kSeesaw ? 0.0f : torque.z_nm * g_per_nm_z_;
  float rp[4];
  rollPitch(torque.x_nm * g_per_nm_xy_, torque.y_nm * g_per_nm_xy_, rp);
  float e[4];
  for (uint8_t i = 0; i < kQuad; ++i) e[i] = (i & 1u) ? rp[i] + z : rp[i] - z;
  const float range = max_g > min_g ? max_g - min_g : 0.0f;
  float lo, hi;
  bounds(e, n, lo, hi);
  uint8_t limits = 0;
  if (hi - lo > range) limits = fit(rp, z, range, e, lo, hi);
  float c = collective_g;
  if (c < min_g - lo) c = min_g - lo;
  if (c > max_g - hi) c = max_g - hi;
  if (c != collective_g) limits |= kMixCollectiveLimited;
  for (uint8_t i = 0; i < kQuad; ++i) force_g[i] = i < n ? c + e[i] : 0.0f;
  return limits;
}

// The spread of roll, pitch and yaw exceeds the motors' range: roll and pitch keep what they
// can (all of it when they fit alone), yaw the rest. The spread is convex in the yaw share, so
// the share (range - rp spread) / (spread - rp spread) fits.
uint8_t Mixer::fit(const float (&rp)[4], float z, float range, float (&e)[4], float& lo, float& hi) const {
  const uint8_t n = motorCount();
  const float full_spread = hi - lo;
  bounds(rp, n, lo, hi);
  const float rp_spread = hi - lo;
  if (rp_spread > range) {  // roll and pitch alone do not fit: scale them, no yaw
    const float scale = range / rp_spread;
    for (uint8_t i = 0; i < kQuad; ++i) e[i] = rp[i] * scale;
    lo *= scale;
    hi *= scale;
    return kMixRollPitchLimited | kMixYawLimited;
  }
  const float share_z = z * ((range - rp_spread) / (full_spread - rp_spread));
  for (uint8_t i = 0; i < kQuad; ++i) e[i] = (i & 1u) ? rp[i] + share_z : rp[i] - share_z;
  bounds(e, n, lo, hi);
  return kMixYawLimited;
}

}  // namespace fly
