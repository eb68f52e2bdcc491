// The mixer (mixer.hpp).
#include "mixer.hpp"

#include "fixed_point.hpp"

namespace fly {

namespace {

constexpr float kGramsPerNewton = 1000.0f / 9.80665f;
constexpr uint8_t kQuad = 4;

// The lowest and highest of the flown motors' values (motors 0..n-1).
void bounds(const ForceDg (&v)[4], uint8_t n, ForceDg& lo, ForceDg& hi) {
  lo = v[0];
  hi = v[0];
  for (uint8_t i = 1; i < n; ++i) {
    if (v[i] < lo) lo = v[i];
    if (v[i] > hi) hi = v[i];
  }
}

// A float already in decigrams, rounded.
ForceDg rounded(float dg) { return static_cast<ForceDg>(dg < 0 ? dg - 0.5f : dg + 0.5f); }

// num / den for 0 <= num < den (the saturation path's two ratios are strictly below 1) as a
// 16-bit mantissa and a shift: f = floor(num * 2^s / den) in [2^15, 2^16), exact, by restoring
// division (the remainder stays below den < 2^31, so its double fits 32 bits): ~50 turns of a
// shift, a compare and a subtraction at most, against a float division and four float products,
// conversions and roundings per motor before. Relative error below 2^-15, so a scaled value is
// off by less than its own size * 2^-15 (not the size of the value scaled).
struct Fraction {
  uint16_t f = 0;
  uint8_t s = 16;  // 16..47; f 0: the ratio is below 2^-32 (or num <= 0), nothing of it is left
};
Fraction fraction(ForceDg num, ForceDg den) {
  Fraction out;
  if (num <= 0 || den <= num) return out;
  const uint32_t d = static_cast<uint32_t>(den);
  uint32_t r = static_cast<uint32_t>(num);
  uint8_t s = 0;
  while ((r << 1) < d) {  // the leading zeros of the ratio
    r <<= 1;
    if (++s > 31) return out;
  }
  uint16_t f = 0;
  for (uint8_t bit = 0; bit < 16; ++bit) {
    r <<= 1;
    f = static_cast<uint16_t>(f << 1);
    if (r >= d) {
      r -= d;
      f |= 1u;
    }
  }
  out.f = f;
  out.s = static_cast<uint8_t>(s + 16);
  return out;
}

// floor(a * f / 2^s): a = hi * 2^16 + lo, two 16 x 16 products (the AVR's MUL) give
// floor(a * f / 2^16) exactly, then an arithmetic shift (a floor of a floor).
ForceDg floorScaled(ForceDg a, const Fraction& q) {
  const int32_t hi = static_cast<int32_t>(static_cast<int16_t>(a >> 16)) * q.f;
  const uint32_t lo = static_cast<uint32_t>(static_cast<uint16_t>(a)) * q.f;
  return shiftRight(hi + static_cast<int32_t>(lo >> 16), static_cast<uint8_t>(q.s - 16));
}

// a * f / 2^s towards zero: a share that never exceeds the exact one in magnitude.
ForceDg truncScaled(ForceDg a, const Fraction& q) { return a < 0 ? -floorScaled(-a, q) : floorScaled(a, q); }

}  // namespace

void Mixer::configure(const MixerSettings& settings) {
  settings_ = settings;
  const float arm_m = settings.arm_m;
  const float lever_m = settings.layout == Layout::kX ? 2.0f * 1.41421356f * arm_m : 2.0f * arm_m;
  dg_per_nm_xy_ = kDgPerGram * kGramsPerNewton / lever_m;
  dg_per_nm_z_ = kDgPerGram * kGramsPerNewton / (4.0f * settings.yaw_arm_m);
}

// Roll and pitch per motor, written out per layout (mixer.hpp's signs): no table, no branch per
// term. Yaw is -z, +z, -z, +z on both quad layouts (counter-clockwise motors 0 and 2).
void Mixer::rollPitch(ForceDg x, ForceDg y, ForceDg (&rp)[4]) const {
  switch (layout()) {
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

uint8_t Mixer::mix(ForceDg collective, const Torque& torque, ForceDg min, ForceDg max, Forces& force) const {
  TorqueDg t;
  t.x = rounded(torque.x_nm * dg_per_nm_xy_);
  t.y = rounded(torque.y_nm * dg_per_nm_xy_);
  t.z = rounded(torque.z_nm * dg_per_nm_z_);
  return mixDg(collective, t, min, max, force);
}

uint8_t Mixer::mixDg(ForceDg collective, const TorqueDg& torque, ForceDg min, ForceDg max, Forces& force) const {
  const uint8_t n = motorCount();
  const ForceDg z = layout() == Layout::kSeesaw ? 0 : torque.z;
  ForceDg rp[4];
  rollPitch(torque.x, torque.y, rp);
  ForceDg e[4];
  for (uint8_t i = 0; i < kQuad; ++i) e[i] = (i & 1u) ? rp[i] + z : rp[i] - z;
  ForceDg lo, hi;
  bounds(e, n, lo, hi);
  const ForceDg range = max > min ? max - min : 0;
  uint8_t limits = 0;
  if (hi - lo > range) limits = fit(rp, z, range, e, lo, hi);
  ForceDg c = collective;
  if (c < min - lo) {
    c = min - lo;
    limits |= kMixCollectiveLimited;
  } else if (c > max - hi) {
    c = max - hi;
    limits |= kMixCollectiveLimited;
  }
  for (uint8_t i = 0; i < kQuad; ++i) force.dg[i] = i < n ? c + e[i] : 0;
  return limits;
}

// The spread of roll, pitch and yaw exceeds the motors' range: roll and pitch keep what they
// can (all of it when they fit alone), yaw the rest. The spread is convex in the yaw share, so
// the share (range - rp spread) / (spread - rp spread) fits.
uint8_t Mixer::fit(const ForceDg (&rp)[4], ForceDg z, ForceDg range, ForceDg (&e)[4], ForceDg& lo,
                   ForceDg& hi) const {
  const uint8_t n = motorCount();
  const ForceDg full_spread = hi - lo;
  bounds(rp, n, lo, hi);
  const ForceDg rp_spread = hi - lo;
  if (rp_spread > range) {  // roll and pitch alone do not fit: scale them, no yaw
    // Each floored with a floored fraction: floor(hi f) - floor(lo f) < (hi - lo) f + 1 <=
    // range + 1, so the scaled spread is at most the range (an integer).
    const Fraction f = fraction(range, rp_spread);
    for (uint8_t i = 0; i < kQuad; ++i) e[i] = floorScaled(rp[i], f);
    bounds(e, n, lo, hi);
    return kMixRollPitchLimited | kMixYawLimited;
  }
  // Towards zero: the share lies between 0 and the exact share, where the (convex) spread is at
  // most the range at both ends, so it is at most the range.
  const ForceDg share_z = truncScaled(z, fraction(range - rp_spread, full_spread - rp_spread));
  for (uint8_t i = 0; i < kQuad; ++i) e[i] = (i & 1u) ? rp[i] + share_z : rp[i] - share_z;
  bounds(e, n, lo, hi);
  return kMixYawLimited;
}

}  // namespace fly
