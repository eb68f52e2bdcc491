// Equal dynamics in flight: the per-motor shaping filter (thrustcal/dyn_shaper.hpp).
#include "thrustcal/dyn_shaper.hpp"

#include <math.h>

#include "model_v2_fixed_point.hpp"  // mulU16: the AVR's 16 x 16 multiply inline

namespace tc {

namespace {

constexpr uint8_t kRefShift = 8;  // the reference in 1/256 dg

// m * g / 2^16 (rounded down) for m < 2^31: two 16 x 16 -> 32 multiplications and
// byte-aligned shifts (avr-gcc would call its 32 x 32 multiply for the plain expression, four
// times the cycles).
// A difference under 256 dg (the usual frame: the reference trails a command that moves a few
// grams) takes one multiplication.
TC_INLINE uint32_t mulQ16(uint32_t m, uint16_t g) {
  const uint16_t high = static_cast<uint16_t>(m >> 16);
  const uint32_t low = mulU16(static_cast<uint16_t>(m), g) >> 16;
  return high == 0 ? low : low + mulU16(high, g);
}

// d * g / 2^16, rounded toward zero alike for both signs.
TC_INLINE int32_t mulQ16(int32_t d, uint16_t g) {
  const uint32_t p = mulQ16(static_cast<uint32_t>(d < 0 ? -d : d), g);
  return d < 0 ? -static_cast<int32_t>(p) : static_cast<int32_t>(p);
}

// Where the reference (in 1/256 dg) lies among the table's points: its interval (0..kShaperBins,
// the last at and beyond the last point) and its place in it (1/256 of the interval). Its
// decigrams (a byte shift) times 2^-bin_shift as one 16 x 16 multiplication by bin_scale_q16 (a
// variable shift is a loop on the AVR).
struct Place {
  uint8_t bin;
  uint8_t frac;
};

TC_INLINE Place placeOf(int32_t ref_q8, uint16_t bin_scale_q16) {
  Place p = {0, 0};
  if (ref_q8 <= 0) return p;
  const uint16_t dg = static_cast<uint16_t>(static_cast<uint32_t>(ref_q8) >> kRefShift);
  const uint32_t pos = mulU16(dg, bin_scale_q16);
  const uint16_t bin = static_cast<uint16_t>(pos >> 16);
  if (bin >= kShaperBins) {
    p.bin = kShaperBins;  // the last point (the table repeats it: frac 0 reads it alone)
    return p;
  }
  p.bin = static_cast<uint8_t>(bin);
  p.frac = static_cast<uint8_t>(pos >> 8);
  return p;
}

// The table's value at `p`: linear between the interval's two points (16 x 8 multiplication).
TC_INLINE uint16_t lerp(const uint16_t* t, Place p) {
  const uint16_t a = t[p.bin], b = t[p.bin + 1];
  return b >= a ? static_cast<uint16_t>(a + static_cast<uint16_t>(mulU16(static_cast<uint16_t>(b - a), p.frac) >> 8))
                : static_cast<uint16_t>(a - static_cast<uint16_t>(mulU16(static_cast<uint16_t>(a - b), p.frac) >> 8));
}

// The force a table point stands for, grams.
float pointForceG(uint8_t point, uint8_t bin_shift) {
  return static_cast<float>(point) * static_cast<float>(1ul << bin_shift) * 0.1f;
}

float tauS(const MotorDynamics& d, uint8_t dir, float force_g) {
  return dir == kShaperUp ? d.tauUpS(force_g) : d.tauDownS(force_g);
}

}  // namespace

bool ShaperReference::isValid() const {
  if (isSlowest()) return true;
  return tau_up_01ms >= kDynTauMin01ms && tau_up_01ms <= kDynTauMax01ms && tau_down_01ms >= kDynTauMin01ms &&
         tau_down_01ms <= kDynTauMax01ms;
}

uint16_t frameGainQ16(float tau_s, uint16_t frame_hz) {
  if (!(tau_s > 0.0f) || frame_hz == 0) return 0xFFFF;
  const float a = 1.0f - expf(-1.0f / (static_cast<float>(frame_hz) * tau_s));
  const float q = a * 65536.0f + 0.5f;
  if (q < 1.0f) return 1;
  return q >= 65535.0f ? 0xFFFF : static_cast<uint16_t>(q);
}

bool buildShaperReference(ShaperReferenceTable& table, const ShaperReference& reference,
                          const MotorDynamics* const* motors, uint8_t count, uint16_t max_dg,
                          uint16_t frame_hz) {
  table = ShaperReferenceTable();
  if (!reference.isValid() || frame_hz == 0) return false;
  table.fixed = reference.isSlowest() ? 0 : 1;
  while ((static_cast<uint32_t>(max_dg) >> table.bin_shift) >= kShaperBins) ++table.bin_shift;
  table.bin_scale_q16 = static_cast<uint16_t>(1ul << (16 - table.bin_shift));
  bool any = false;
  for (uint8_t i = 0; i < count; ++i) any = any || (motors[i] != nullptr && motors[i]->isValid());
  if (reference.isSlowest() && !any) return false;
  for (uint8_t dir = 0; dir < 2; ++dir) {
    for (uint8_t point = 0; point <= kShaperBins; ++point) {
      const float force_g = pointForceG(point, table.bin_shift);
      float tau = 1e-4f * static_cast<float>(dir == kShaperUp ? reference.tau_up_01ms : reference.tau_down_01ms);
      if (reference.isSlowest()) {
        for (uint8_t i = 0; i < count; ++i) {
          if (motors[i] == nullptr || !motors[i]->isValid()) continue;
          const float t = tauS(*motors[i], dir, force_g);
          if (t > tau) tau = t;
        }
      }
      table.a_ref_q16[dir][point] = frameGainQ16(tau, frame_hz);
    }
    table.a_ref_q16[dir][kShaperBins + 1] = table.a_ref_q16[dir][kShaperBins];
  }
  return true;
}

void DynShaper::configure(const MotorDynamics& dynamics, const ShaperReferenceTable& table, uint16_t frame_hz,
                          uint16_t force_dg) {
  active_ = dynamics.isValid() && frame_hz != 0 && table.a_ref_q16[kShaperUp][0] != 0;
  ref_q8_ = static_cast<int32_t>(force_dg) << kRefShift;
  if (!active_) return;
  for (uint8_t dir = 0; dir < 2; ++dir) {
    for (uint8_t point = 0; point <= kShaperBins; ++point) {
      const uint16_t a_m = frameGainQ16(tauS(dynamics, dir, pointForceG(point, table.bin_shift)), frame_hz);
      const float gain = static_cast<float>(table.a_ref_q16[dir][point]) / static_cast<float>(a_m);
      const float q = gain * 16384.0f + 0.5f;
      a_motor_q16_[dir][point] = a_m;
      gain_q14_[dir][point] = q >= 65535.0f ? kShaperGainMaxQ14 : static_cast<uint16_t>(q);
    }
    a_motor_q16_[dir][kShaperBins + 1] = a_motor_q16_[dir][kShaperBins];
    gain_q14_[dir][kShaperBins + 1] = gain_q14_[dir][kShaperBins];
  }
}

TC_INLINE uint16_t DynShaper::frame(uint16_t force_dg, uint16_t max_dg, const ShaperReferenceTable& table) {
  if (!active_) return force_dg;
  const Place at = placeOf(ref_q8_, table.bin_scale_q16);
  if (force_dg == 0) {  // a stop: at once; the reference spins down with the motor
    ref_q8_ += mulQ16(-ref_q8_, lerp(a_motor_q16_[kShaperDown], at));
    return 0;
  }
  if (force_dg > max_dg) force_dg = max_dg;
  // |F - r| and its direction once; both products from the magnitude, rounded toward zero
  const int32_t d = (static_cast<int32_t>(force_dg) << kRefShift) - ref_q8_;
  const bool down = d < 0;
  const uint32_t m = static_cast<uint32_t>(down ? -d : d);
  // the direction's rows by address (an index times 16 is a shift loop on the AVR)
  const uint16_t* const gain = down ? gain_q14_[kShaperDown] : gain_q14_[kShaperUp];
  const uint16_t* const a_motor = down ? a_motor_q16_[kShaperDown] : a_motor_q16_[kShaperUp];
  const uint16_t* const a_ref = down ? table.a_ref_q16[kShaperDown] : table.a_ref_q16[kShaperUp];
  uint32_t toward = mulQ16(m, lerp(gain, at));  // Q14 gain: times 4 (1/64 dg lost)
  toward += toward;
  toward += toward;
  const int32_t hi = static_cast<int32_t>(max_dg) << kRefShift;
  const int32_t lo = 1l << kRefShift;
  int32_t u = down ? ref_q8_ - static_cast<int32_t>(toward) : ref_q8_ + static_cast<int32_t>(toward);
  if (u > hi || u < lo) {  // beyond what the motor can be given: the reference follows the motor
    u = u > hi ? hi : lo;
    ref_q8_ += mulQ16(u - ref_q8_, lerp(a_motor, at));
  } else {
    const uint16_t a_r = table.fixed ? a_ref[0] : lerp(a_ref, at);
    const int32_t moved = static_cast<int32_t>(mulQ16(m, a_r));
    ref_q8_ += down ? -moved : moved;
  }
  return static_cast<uint16_t>((u + (1l << (kRefShift - 1))) >> kRefShift);
}

uint16_t DynShaper::step(uint16_t force_dg, uint16_t max_dg, const ShaperReferenceTable& table) {
  return frame(force_dg, max_dg, table);
}

#if defined(__AVR__)
__attribute__((optimize("O2")))  // the per-frame loop: -Os spills the 32-bit state to the stack
#endif
void DynShaper::stepAll(DynShaper* const* shapers, const uint16_t* force_dg, const uint16_t* max_dg, uint16_t* out_dg,
                        uint8_t count, const ShaperReferenceTable& table) {
  for (uint8_t i = 0; i < count; ++i) out_dg[i] = shapers[i]->frame(force_dg[i], max_dg[i], table);
}

}  // namespace tc
