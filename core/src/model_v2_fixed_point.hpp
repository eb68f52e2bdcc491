// Model v2's fixed-point helpers for the run time (model_v2_runtime.cpp includes this, and
// only it): 16 x 16 multiplications as inline AVR assembly, the knot position and the
// interpolation between knots, the duty and the rounding to whole microseconds. Private to
// core/src: everything is in an unnamed namespace and always inlined, so it costs nothing
// where it is not used. Every multiplication states its bound; `int` is 16 bits on the AVR,
// so every product that can exceed 16 bits is cast to 32 bits first.
#pragma once
#include <stdint.h>

#include "thrustcal/model_v2.hpp"

namespace tc {

namespace {

constexpr int32_t kNewtonLimit = 1l << 20;  // |e| above: re-seed by division (jump > 1/128)

// Where a force falls between the knots: segment index (0 = between the origin and knot 0)
// and the fraction inside it (Q16). force_dg must be <= maxForceDg().
// AVR note: avr-gcc -Os turns 32-bit shifts by a constant that is not a multiple of 8 into
// loops (several cycles per bit), so every shift on the per-frame path is by 8, 16 or 24, or is
// a 16-bit shift.
struct KnotPos {
  uint8_t index;
  uint16_t frac_q16;
};

#define TC_INLINE __attribute__((always_inline)) inline

// 16 x 16 -> 32 bits, unsigned. On the AVR this is libgcc's __umulhisi3 without the call,
// the return and the register shuffling around it (about half the cycles): the per-frame
// path does three per motor. Elsewhere a plain multiplication.
TC_INLINE uint32_t mulU16(uint16_t a, uint16_t b) {
#if defined(__AVR_HAVE_MUL__)
  uint32_t r;
  __asm__(
      "mul  %A1, %A2\n\t"
      "movw %A0, r0\n\t"
      "mul  %B1, %B2\n\t"
      "movw %C0, r0\n\t"
      "mul  %A1, %B2\n\t"
      "add  %B0, r0\n\t"
      "adc  %C0, r1\n\t"
      "clr  __zero_reg__\n\t"
      "adc  %D0, __zero_reg__\n\t"
      "mul  %B1, %A2\n\t"
      "add  %B0, r0\n\t"
      "adc  %C0, r1\n\t"
      "clr  __zero_reg__\n\t"
      "adc  %D0, __zero_reg__"
      : "=&r"(r)
      : "r"(a), "r"(b));
  return r;
#else
  return static_cast<uint32_t>(a) * b;
#endif
}

// (ModelV2 or ModelV2Run: the same fields.)
// (a * b + 2^15) / 2^16: a product rounded to its top 16 bits.
TC_INLINE uint16_t mulU16RoundHi(uint16_t a, uint16_t b) {
#if defined(__AVR_HAVE_MUL__)
  // Bit 15 of the product decides the rounding: the low byte's partial product only feeds
  // the carries into byte 1.
  uint16_t hi;
  uint8_t b1, b0;
  __asm__(
      "mul  %A3, %A4\n\t"
      "mov  %2, r0\n\t"
      "mov  %1, r1\n\t"
      "mul  %B3, %B4\n\t"
      "movw %A0, r0\n\t"
      "mul  %A3, %B4\n\t"
      "add  %1, r0\n\t"
      "adc  %A0, r1\n\t"
      "clr  __zero_reg__\n\t"
      "adc  %B0, __zero_reg__\n\t"
      "mul  %B3, %A4\n\t"
      "add  %1, r0\n\t"
      "adc  %A0, r1\n\t"
      "clr  __zero_reg__\n\t"
      "adc  %B0, __zero_reg__\n\t"
      "lsl  %1\n\t"
      "adc  %A0, __zero_reg__\n\t"
      "adc  %B0, __zero_reg__"
      : "=&r"(hi), "=&r"(b1), "=&r"(b0)
      : "r"(a), "r"(b));
  (void)b0;
  return hi;
#else
  return static_cast<uint16_t>((static_cast<uint32_t>(a) * b + 0x8000u) >> 16);
#endif
}

template <class Model>
TC_INLINE KnotPos knotPos(const Model& m, uint16_t force_dg) {
  // In each run: force * inv ~ force * 2^22 / step, < 16 * 2^22 * (1 + 1/step) < 2^27 (or
  // 32 * 2^22 for a single run); times 4 < 2^29: the index in the run is the top byte, the
  // fraction the two below. (ModelV2 or ModelV2Run: the same fields.)
  // One run only: split = the last knot and inv_coarse = 0, so force == split lands on
  // index fine_knots == knots, which driveAt() reads as the last knot.
  uint8_t base = 0;
  uint16_t inv = m.inv_step_q22;
  if (force_dg >= m.split_dg) {
    force_dg = static_cast<uint16_t>(force_dg - m.split_dg);
    inv = m.inv_coarse_q22;
    base = m.fine_knots;
  }
  uint32_t pos = mulU16(force_dg, inv);
  // Small motors (one run, step < kV2MinStepDg): inv is 2^16 / step, 2^6 below the Q22 scale.
  // force < 32 steps: pos < 2^21 before, < 2^29 after both shifts.
  if (m.q16_inverse) pos <<= 6;
  pos += pos;
  pos += pos;
  KnotPos p;
  p.index = static_cast<uint8_t>(base + static_cast<uint8_t>(pos >> 24));
  p.frac_q16 = static_cast<uint16_t>(pos >> 8);
  return p;
}

TC_INLINE uint16_t driveAt(const ModelV2& m, KnotPos p) {
  if (p.index >= m.knots) return m.drive_512usmv[m.knots - 1];
  const uint16_t* const hi_p = m.drive_512usmv + p.index;
  const uint16_t hi = *hi_p;
  const uint16_t lo = p.index ? hi_p[-1] : 0;
  // (hi - lo) < 2^16, frac < 2^16: product + 2^15 < 2^32.
  return static_cast<uint16_t>(
      lo + ((mulU16(static_cast<uint16_t>(hi - lo), p.frac_q16) + 0x8000u) >> 16));
}

// (a * b) / 2^16 for a signed a, rounded toward zero: sign and magnitude around mulU16.
TC_INLINE int16_t mulS16U16Hi(int16_t a, uint16_t b) {
  if (a < 0) return static_cast<int16_t>(-static_cast<int16_t>(mulU16(static_cast<uint16_t>(-a), b) >> 16));
  return static_cast<int16_t>(mulU16(static_cast<uint16_t>(a), b) >> 16);
}

// (a * b) / 2^15 for a signed a, rounded toward zero and saturated to +-16384. The shift by
// 15 is a byte move, a 16-bit shift by one and one bit from the low half.
TC_INLINE int16_t mulS16U16Shr15Sat(int16_t a, uint16_t b) {
  const uint16_t mag = static_cast<uint16_t>(a < 0 ? -a : a);
  const uint32_t p = mulU16(mag, b);  // < 2^31
  uint16_t q = static_cast<uint16_t>(static_cast<uint16_t>(p >> 16) << 1);
  q = static_cast<uint16_t>(q | (static_cast<uint16_t>(p) >> 15));
  if (q > 16384) q = 16384;
  return static_cast<int16_t>(a < 0 ? -static_cast<int16_t>(q) : static_cast<int16_t>(q));
}

// Sag at a knot position in 1/256 of 10 mV (< 2^16), linear between knots (origin: 0).
TC_INLINE uint16_t sagAtQ8(const ModelV2& m, KnotPos p) {
  // (uint16_t casts before the shifts: 255 << 8 does not fit the AVR's 16-bit int.)
  if (p.index >= m.knots) return static_cast<uint16_t>(static_cast<uint16_t>(m.sag_10mv[m.knots - 1]) << 8);
  const uint8_t lo = p.index ? m.sag_10mv[p.index - 1] : 0;
  const uint8_t hi = m.sag_10mv[p.index];
  // (hi - lo) * 256 * frac / 2^16, computed as 2 * ((hi - lo) * 128 * frac / 2^16) so that
  // the signed factor fits 16 bits: |hi - lo| * 128 < 2^15.
  const int16_t d = mulS16U16Hi(static_cast<int16_t>((hi - lo) * 128), p.frac_q16);
  return static_cast<uint16_t>((static_cast<uint16_t>(lo) << 8) + 2 * d);
}

TC_INLINE uint16_t clampForce(const ModelV2& m, uint16_t force_dg, uint8_t& flags) {
  const uint16_t max_dg = m.max_force_dg;
  if (force_dg > max_dg) {
    flags |= kSaturated;
    return max_dg;
  }
  return force_dg;
}

// 2^26 / mV from the filter's 2^27 / mV: once per frame. 2^26 / 3000 < 22370.
TC_INLINE uint16_t recip26Of(uint16_t recip_q27) {
  return static_cast<uint16_t>((recip_q27 + 1u) >> 1);
}

// drive (512 us*mV) * recip26 (2^26 / mV) = (drive * 512 / mV) us * 2^17: the duty in 2^-17 us.
// drive < 2^16, recip26 < 22370: product < 2^31.
TC_INLINE uint32_t dutyQ17(uint16_t drive, uint16_t recip26) { return mulU16(drive, recip26); }

struct PwmRange {
  uint16_t min_us;
  uint16_t max_us;
};

TC_INLINE ForcePwmResult finishPwm(const ModelV2& m, uint32_t duty_q17, uint8_t flags,
                                   PwmRange limits) {
  // start <= 1800 us (< 2^28 in 2^-17 us) + duty < 2^31 + 1/2 us to round: < 2^32. The
  // shift by 17 is a byte move and one 16-bit shift.
  const uint32_t pwm_q17 = m.start_q17_us + duty_q17 + 0x10000ul;
  const uint16_t pwm_us = static_cast<uint16_t>(static_cast<uint16_t>(pwm_q17 >> 16) >> 1);
  ForcePwmResult r;
  r.flags = flags;
  if (pwm_us > limits.max_us) {
    r.pwm_us = limits.max_us;
    r.flags |= kSaturated;
  } else if (pwm_us < limits.min_us) {
    r.pwm_us = limits.min_us;
    r.flags |= kClamped;
  } else {
    r.pwm_us = pwm_us;
  }
  return r;
}

}  // namespace

}  // namespace tc
