// Force model v2 at run time: the bus voltage filter, force -> PWM (one motor, one frame of
// several motors, with the bench sag of the step predicted) and the inverse for the status
// line. Fixed point, no float, no division per frame: see model_v2.hpp for the formats and
// model_v2_runtime.hpp for the per-frame path read_run flies. Every multiplication below
// states its bound; `int` is 16 bits on the AVR, so every product that can exceed 16 bits is
// cast to 32 bits first.
#include "thrustcal/model_v2_runtime.hpp"

#include <stddef.h>

namespace tc {

namespace {

constexpr int32_t kNewtonLimit = 1l << 20;  // |e| above: re-seed by division (jump > 1/128)

bool saneMv(uint16_t mv) { return mv >= kV2SaneMinMv && mv <= kV2SaneMaxMv; }


// Where a force falls between the knots: segment index (0 = between the origin and knot 0)
// and the fraction inside it (Q16). force_dg must be <= maxForceDg().
// AVR note: avr-gcc -Os turns 32-bit shifts by a constant that is not a multiple of 8 into
// loops (~6 cycles per bit), so every shift on the per-frame path is by 8, 16 or 24, or is a
// 16-bit shift.
struct KnotPos {
  uint8_t index;
  uint16_t frac_q16;
};

#define TC_INLINE __attribute__((always_inline)) inline

// 16 x 16 -> 32 bits, unsigned. On the AVR this is libgcc's __umulhisi3 without the call,
// the return and the register shuffling around it (~18 instead of ~40 cycles): the
// per-frame path does three per motor. Elsewhere a plain multiplication.
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

// ---- BusVoltageFilter ----------------------------------------------------------------------

void BusVoltageFilter::reset(uint16_t mv_now) {
  if (shift > 6) shift = 6;
  rem = 0;
  if (!saneMv(mv_now)) {
    mv = 0;
    recip_q27 = 0;
    return;
  }
  mv = mv_now;
  recip_q27 = static_cast<uint16_t>(kRecipOne / mv_now);  // the one division
}

namespace {

// 2^(8 - shift) for the filter's shifts 1..6 (shift 0: 256, handled apart).
const uint8_t kShiftMul[7] = {0, 128, 64, 32, 16, 8, 4};

// t * m for a signed 16-bit t and 0 < m < 256, plus r (< 256): 24 bits, |t| * m < 2^23.
// Returned as the product's bytes 1..2 (floor of the sum / 256) and byte 0.
TC_INLINE int16_t mulS16U8PlusHi(int16_t t, uint8_t m, uint8_t r, uint8_t& low) {
#if defined(__AVR_HAVE_MUL__)
  int16_t hi;
  uint8_t lo;
  __asm__(
      "mul   %A[t], %[m]\n\t"  // unsigned low byte * m
      "mov   %[lo], r0\n\t"
      "mov   %A[hi], r1\n\t"
      "mulsu %B[t], %[m]\n\t"  // signed high byte * m
      "mov   %B[hi], r1\n\t"
      "add   %A[hi], r0\n\t"
      "clr   __zero_reg__\n\t"
      "adc   %B[hi], __zero_reg__\n\t"
      "add   %[lo], %[r]\n\t"
      "adc   %A[hi], __zero_reg__\n\t"
      "adc   %B[hi], __zero_reg__"
      : [hi] "=&r"(hi), [lo] "=&r"(lo)
      : [t] "a"(t), [m] "a"(m), [r] "r"(r));
  low = lo;
  return hi;
#else
  const int32_t v = static_cast<int32_t>(t) * m + r;
  low = static_cast<uint8_t>(v & 0xFF);
  return static_cast<int16_t>(v >> 8);  // arithmetic: floor
#endif
}

// One first-order step of y += (x - y) / 2^shift in integers, y = value + rem / 256 (rem the
// fraction, in 1/256): value * 2^s + t with t = rem / 2^(8-s) + x - value; scaled by
// m = 2^(8-s), t * m = rem + (x - value) * m, whose bytes 1..2 are the step floor(t / 2^s)
// and byte 0 the new rem. Exact in steady state. |x - value| < 2^15. Returns the step.
TC_INLINE int16_t firstOrderStep(uint16_t& value, uint8_t& rem, uint16_t x, uint8_t shift) {
  const int16_t d = static_cast<int16_t>(x - value);
  int16_t step;
  if (shift == 0) {
    step = d;  // y = x
    rem = 0;
  } else {
    uint8_t low;
    step = mulS16U8PlusHi(d, kShiftMul[shift], rem, low);
    rem = low;
  }
  value = static_cast<uint16_t>(value + step);
  return step;
}

// x / 8 for a 16-bit x (avr-g++ -Os loops 3 times for it).
TC_INLINE uint16_t shr3(uint16_t x) {
#if defined(__AVR__)
  __asm__(
      "lsr  %B0\n\t"
      "ror  %A0\n\t"
      "lsr  %B0\n\t"
      "ror  %A0\n\t"
      "lsr  %B0\n\t"
      "ror  %A0"
      : "+r"(x));
  return x;
#else
  return static_cast<uint16_t>(x >> 3);
#endif
}

}  // namespace

void BusVoltageFilter::update(uint16_t sample_mv) {
  if (!saneMv(sample_mv)) {
    if (rejected != 255) ++rejected;
    return;
  }
  if (!isValid()) {
    reset(sample_mv);
    return;
  }
  if (firstOrderStep(mv, rem, sample_mv, shift) == 0) return;  // steady: the reciprocal holds
  // Newton step on r = 2^27 / mv: e = 2^27 - mv * r, r += r * e / 2^27.
  // mv * r <= 26000 * 44739 < 2^31.
  const int32_t e = static_cast<int32_t>(kRecipOne - mulU16(mv, recip_q27));
  if (e > kNewtonLimit || e < -kNewtonLimit) {
    recip_q27 = static_cast<uint16_t>(kRecipOne / mv);
    if (reseeds != 255) ++reseeds;
    return;
  }
  // r * e / 2^27 = ((e / 2^8) * r / 2^16) / 2^3: |e / 2^8| <= 2^12, r < 2^16: |product| < 2^28.
  const int16_t e8 = static_cast<int16_t>(e >> 8);
  const uint16_t mag = static_cast<uint16_t>(e8 < 0 ? -e8 : e8);
  const uint16_t corr = shr3(static_cast<uint16_t>(mulU16(mag, recip_q27) >> 16));
  recip_q27 = static_cast<uint16_t>(e8 < 0 ? recip_q27 - corr : recip_q27 + corr);
}

// ---- Run time ------------------------------------------------------------------------------

namespace {

// The per-motor path of forceToPwmV2 (V2Frame has its own, the same arithmetic).
TC_INLINE ForcePwmResult pwmFor(const ModelV2& model, uint16_t force_dg, uint16_t recip26,
                                uint8_t flags, PwmRange limits) {
  if (model.max_force_dg == 0)  // finalize() sets it for every valid model, clear() zeroes it
    return ForcePwmResult{limits.min_us, kNotCalibrated};
  if (force_dg == 0) return ForcePwmResult{limits.min_us, kStopped};
  if (flags & kVoltageInvalid) recip26 = recip26Of(model.rest_recip_q27);
  const uint16_t drive = driveAt(model, knotPos(model, clampForce(model, force_dg, flags)));
  return finishPwm(model, dutyQ17(drive, recip26), flags, limits);
}

}  // namespace

ForcePwmResult forceToPwmV2(const ModelV2& model, uint16_t force_dg, const BusVoltageFilter& bus,
                            const ForcePwmLimits& limits) {
  return pwmFor(model, force_dg, recip26Of(bus.recip_q27), bus.isValid() ? 0 : kVoltageInvalid,
                PwmRange{limits.pwm_min_us, limits.pwm_max_us});
}

ForcePwmResult forceToPwmV2(const ModelV2& model, uint16_t force_dg, const BusVoltageFilter& bus,
                            uint16_t force_now_dg, const ForcePwmLimits& limits) {
  if (model.max_force_dg == 0) return ForcePwmResult{limits.pwm_min_us, kNotCalibrated};
  if (force_dg == 0) return ForcePwmResult{limits.pwm_min_us, kStopped};
  uint8_t flags = 0;
  uint16_t recip = bus.recip_q27;
  if (!bus.isValid()) {
    recip = model.rest_recip_q27;
    flags |= kVoltageInvalid;
  }
  const KnotPos p = knotPos(model, clampForce(model, force_dg, flags));
  uint32_t duty_q17 = dutyQ17(driveAt(model, p), recip26Of(recip));
  if (force_now_dg != force_dg) {
    uint8_t ignored = 0;
    const KnotPos now = knotPos(model, clampForce(model, force_now_dg, ignored));
    // Extra drop expected at the command: d = sag(cmd) - sag(now), in 1/128 of 10 mV
    // (|d| < 2^15). delta = d_mv / V in Q16 = d * (1.25 * 2^27 / mV) / 2^15: the factor
    // 1.25 * recip fits 16 bits (< 55924 at 3 V). A predicted change of more than 25 % is
    // not sag: saturated at 16384.
    const int16_t d_q7 = static_cast<int16_t>((sagAtQ8(model, p) >> 1) - (sagAtQ8(model, now) >> 1));
    const uint16_t recip_x125 = static_cast<uint16_t>(recip + (recip >> 2));
    const int16_t delta = mulS16U16Shr15Sat(d_q7, recip_x125);
    // duty / (1 - delta) ~ duty * (1 + delta + delta^2): error delta^3 (< 0.01 % at 5 %).
    const uint16_t mag = static_cast<uint16_t>(delta < 0 ? -delta : delta);
    const int16_t factor = static_cast<int16_t>(delta + static_cast<int16_t>(mulU16(mag, mag) >> 16));
    // duty * (1 + factor / 2^16), factor in -16384..20480. With duty = hi * 2^16 + lo:
    // duty * factor / 2^16 = hi * factor + lo * factor / 2^16 (hi < 2^15): byte-aligned.
    const uint16_t hi = static_cast<uint16_t>(duty_q17 >> 16);
    const uint16_t lo = static_cast<uint16_t>(duty_q17);
    const uint16_t fmag = static_cast<uint16_t>(factor < 0 ? -factor : factor);
    const uint32_t corr = mulU16(hi, fmag) + (mulU16(lo, fmag) >> 16);
    if (factor >= 0) {
      duty_q17 += corr;
    } else {
      duty_q17 = corr > duty_q17 ? 0u : duty_q17 - corr;
    }
  }
  return finishPwm(model, duty_q17, flags, PwmRange{limits.pwm_min_us, limits.pwm_max_us});
}

uint16_t forceForPwmDg(const ModelV2& model, uint16_t pwm_us, uint16_t vbus_mv) {
  if (!model.isPresent() || vbus_mv == 0) return 0;
  if (pwm_us > 4000) pwm_us = 4000;  // keeps (pwm - start) * mV below 2^32
  const uint32_t pwm_q4 = static_cast<uint32_t>(pwm_us) << 4;
  if (pwm_q4 <= model.start_q4_us) return 0;
  // (pwm - start) in 1/16 us times mV, / (16 * 512): < 64000 * 65536 < 2^32.
  const uint32_t drive = ((pwm_q4 - model.start_q4_us) * vbus_mv) >> 13;
  uint8_t k = 0;
  while (k < model.knots && model.drive_512usmv[k] < drive) ++k;
  if (k == model.knots) return model.maxForceDg();
  const uint16_t lo = k ? model.drive_512usmv[k - 1] : 0;
  const uint16_t hi = model.drive_512usmv[k];
  const uint32_t base = k ? model.knotForceDg(static_cast<uint8_t>(k - 1)) : 0;
  const uint32_t step = model.knotForceDg(k) - base;
  if (hi == lo) return static_cast<uint16_t>(base + step);
  // (drive - lo) < 2^16, step < 2^15: product < 2^31. The one division.
  return static_cast<uint16_t>(base + ((drive - lo) * step + (hi - lo) / 2) / (hi - lo));
}

uint16_t headroomDg(const ModelV2& model, uint16_t vbus_mv, const ForcePwmLimits& limits) {
  return forceForPwmDg(model, limits.pwm_max_us, vbus_mv);
}

// ---- One frame (read_run) -------------------------------------------------------------------
static_assert(static_cast<uint32_t>(kV2FrameMaxMotors) * 255u * 16u <= 32767u,
              "the frame's total sag (1/16 of a sag unit) must fit int16");

bool ModelV2Run::load(const ModelV2& m) {
  clear();
  if (!m.isPresent() || m.max_force_dg == 0) return false;  // not finalized: no model
  max_force_dg = m.max_force_dg;
  split_dg = m.split_dg;
  inv_step_q22 = m.inv_step_q22;
  inv_coarse_q22 = m.inv_coarse_q22;
  fine_knots = m.fine_knots;
  knots = m.knots;
  start_round_q17_us = m.start_q17_us + 0x10000ul;  // + 1/2 us: rounds to whole us
  rest_recip_q27 = m.rest_recip_q27;
  q16_inverse = m.q16_inverse;
  step_dg = m.step_dg;
  coarse_step_dg = m.coarse_step_dg;
  rest_mv = m.rest_mv;
  for (uint8_t k = 0; k < knots; ++k) {
    knot[k + 1].drive_512usmv = m.drive_512usmv[k];
    knot[k + 1].sag_10mv = m.sag_10mv[k];
  }
  knot[knots + 1] = knot[knots];
  return true;
}

namespace {

// The sag filter's step: the bus filter's (same shift, same arithmetic).
TC_INLINE void filterSag(BusSagFilter& f, uint16_t total_q4, uint8_t shift) {
  firstOrderStep(f.seen_q4, f.rem, total_q4, shift);
}

// 2^27 / V_cmd from 2^27 / V and x = V_cmd - V in 1/16 of kV2SagUnitMv: (1/V)(1 - e + e^2),
// e = x / V clamped to +-1/4.
TC_INLINE uint16_t predictedRecip(uint16_t recip_q27, int16_t x_q4) {
  static_assert(kV2SagUnitMv == 10, "e's scale below assumes 10 mV sag units");
  // e = x_mv / V = x_q4 * (10 / 16) * recip / 2^27 = x_q4 * (recip * 5 / 4) / 2^28: the
  // product / 2^15 is e in Q13 (1/8192 of V, ~1.4 mV at 11 V). recip * 5 / 4 < 55924 (3 V),
  // |x_q4| < 2^14: product < 2^30, / 2^15 < 2^15. The shift by 15: the top 16 bits times 2
  // and bit 15.
  const uint16_t k = static_cast<uint16_t>(recip_q27 + (recip_q27 >> 2));
  const uint16_t x_mag = static_cast<uint16_t>(x_q4 < 0 ? -x_q4 : x_q4);
  const uint32_t prod = mulU16(x_mag, k);
  uint16_t e13 = static_cast<uint16_t>(static_cast<uint16_t>(static_cast<uint16_t>(prod >> 16) << 1) |
                                       (static_cast<uint16_t>(prod) >> 15));
  if (e13 > 2048u) e13 = 2048u;  // a predicted change of more than 25 % is not sag
  const uint16_t e_mag = static_cast<uint16_t>(e13 << 3);  // Q16, <= 16384
  // e^2 from e rounded to 1/256 (one 8 x 8 product; e^2 is the small term): <= 4096.
  const uint8_t e8 = static_cast<uint8_t>((e_mag + 0x80u) >> 8);
  const uint16_t e2 = static_cast<uint16_t>(e8 * e8);
  // factor = e^2 - e: -12288..20480; recip * |factor| < 2^30.
  const int16_t factor = static_cast<int16_t>(x_q4 < 0 ? e2 + e_mag : e2 - e_mag);
  const uint16_t f_mag = static_cast<uint16_t>(factor < 0 ? -factor : factor);
  const uint16_t corr = static_cast<uint16_t>(mulU16(recip_q27, f_mag) >> 16);
  return static_cast<uint16_t>(factor < 0 ? recip_q27 - corr : recip_q27 + corr);  // < 58721 (3 V)
}

// A frame's inputs for the portable pass.
struct FrameArgs {
  V2Lane* lanes;
  uint8_t count;
  uint8_t flags;       // ForcePwmFlag bits for every lane, plus kUseRestVoltage
  uint16_t recip_q27;  // the bus filter's 2^27 / V
  uint16_t min_us;
  uint16_t max_us;
  uint8_t shift;       // the bus filter's
};
constexpr uint8_t kUseRestVoltage = 0x80;  // bus not valid: each model's resting voltage
static_assert((kUseRestVoltage & (kStopped | kNotCalibrated | kSaturated | kVoltageInvalid |
                                  kSingleCurve | kEqualVoltages | kClamped)) == 0,
              "kUseRestVoltage must not be a ForcePwmFlag");

// The pass, portable. Per lane (a loaded model, see V2Frame::fly): force 0 -> pwm_min, kStopped;
// else the force clamped to the curve (kSaturated), its knot position (as knotPos), the drive
// there (as driveAt), start + drive * recip26 rounded to whole us and limited (as finishPwm),
// and the bench sag at the force, added to the total (returned in 1/16 unit).
uint16_t passPortable(const FrameArgs& a, uint16_t recip26) {
  uint16_t total_q4 = 0;
  for (V2Lane* l = a.lanes; l != a.lanes + a.count; ++l) {
    const ModelV2Run& m = *l->model;
    uint16_t force_dg = l->force_dg;
    if (force_dg == 0) {
      l->flags = kStopped;
      l->pwm_us = a.min_us;
      continue;
    }
    uint8_t flags = static_cast<uint8_t>(a.flags & ~kUseRestVoltage);
    if (force_dg > m.max_force_dg) {
      force_dg = m.max_force_dg;
      flags = static_cast<uint8_t>(flags | kSaturated);
    }
    const KnotPos p = knotPos(m, force_dg);
    const ModelV2Run::Knot* const k = m.knot + p.index;
    const uint16_t lo = k[0].drive_512usmv;
    const uint16_t drive = static_cast<uint16_t>(
        lo + mulU16RoundHi(static_cast<uint16_t>(k[1].drive_512usmv - lo), p.frac_q16));
    // Bench sag in 1/16 unit, linear between the knots on the fraction's top nibble.
    const uint8_t f4 = static_cast<uint8_t>(p.frac_q16 >> 12);
    total_q4 = static_cast<uint16_t>(total_q4 + k[0].sag_10mv * (16u - f4) + k[1].sag_10mv * f4);
    const uint16_t r26 = (a.flags & kUseRestVoltage) ? recip26Of(m.rest_recip_q27) : recip26;
    const uint32_t pwm_q17 = l->startRoundQ17() + mulU16(drive, r26);
    uint16_t pwm_us = static_cast<uint16_t>(static_cast<uint16_t>(pwm_q17 >> 16) >> 1);
    if (pwm_us > a.max_us) {
      pwm_us = a.max_us;
      flags = static_cast<uint8_t>(flags | kSaturated);
    } else if (pwm_us < a.min_us) {
      pwm_us = a.min_us;
      flags = static_cast<uint8_t>(flags | kClamped);
    }
    l->flags = flags;
    l->pwm_us = pwm_us;
  }
  return total_q4;
}

// The frame, portable: the bus filter's update, the sag filter, the prediction, the pass.
void framePortable(V2Frame& f, uint16_t sample_mv, uint8_t extra_flags) {
  f.bus.update(sample_mv);
  FrameArgs a;
  a.lanes = f.lane;
  a.count = f.count;
  a.flags = static_cast<uint8_t>(extra_flags | (f.bus.isValid() ? 0 : kVoltageInvalid | kUseRestVoltage));
  a.recip_q27 = f.bus.recip_q27;
  a.min_us = f.pwm_min_us;
  a.max_us = f.pwm_max_us;
  a.shift = f.bus.shift;
  BusSagFilter& sag = f.sag;
  // The bus voltage at the commands of the last frame (one prediction for all motors): the
  // filtered reading plus the sag it shows minus the sag of those commands.
  const int16_t x_q4 = static_cast<int16_t>(sag.seen_q4 - sag.last_q4);
  filterSag(sag, sag.last_q4, a.shift);
  uint16_t recip = a.recip_q27;
  if (x_q4 != 0 && !(a.flags & kUseRestVoltage)) recip = predictedRecip(recip, x_q4);
  sag.last_q4 = passPortable(a, recip26Of(recip));
}

#if defined(__AVR_HAVE_MUL__)
// The frame as AVR assembly: the bus filter's step (as BusVoltageFilter::update), the sag
// filter, the prediction and the pass, the same arithmetic to the bit (the bench probe runs
// both versions on the same frames and counts differences). Why assembly: avr-g++ 5.4 kept
// the lane and model pointers of the C pass on the stack and reached every field through X
// with adiw/sbiw pairs (~400 cycles per motor; here ~150), and its 32-bit shifts by a variable
// count are loops. X walks the lanes (their fields in order, post-increment; each lane carries
// its model's start threshold), Z reads each model's fields and its knots, Y the frame. The
// labels tc_v2fly_* mark its steps (`thrustcal bench compute` attributes cycles by them).
// Registers: r3 holds the extra flags on entry; after the set-up every lane's flags are in
// g_lane_flags, the T bit says "fly each model's resting voltage" and r3 is a second zero
// register (avr-gcc's r1 is used by mul). The pass:
//   r2 lanes left, r5:r4 recip26,
//   r7:r6 min, r9:r8 max, r11:r10 total sag, r13:r12 force (then the upper knot's drive),
//   r15:r14 product bytes, r16 a lane's flags, r17 index base (then the fraction's nibble),
//   r21..r18 knot position (then the duty), r23:r22 inverse step (then temporaries, the upper
//   knot's sag), r25:r24 drive.
static_assert(offsetof(V2Lane, model) == 0 && offsetof(V2Lane, force_dg) == 2 &&
                  offsetof(V2Lane, start_q17) == 4 && offsetof(V2Lane, flags) == 7 &&
                  offsetof(V2Lane, pwm_us) == 8 && sizeof(V2Lane) == 10,
              "the pass walks the lane fields in this order");
static_assert(offsetof(ModelV2Run, knot) <= 63 && sizeof(ModelV2Run::Knot) == 4 &&
                  offsetof(ModelV2Run::Knot, sag_10mv) == 2 && (kV2MaxKnots + 1) * 4 < 256,
              "adiw reaches the knots; 4 bytes per knot, the index times 4 fits a byte");
static_assert(offsetof(BusVoltageFilter, mv) == 0 && offsetof(BusVoltageFilter, rem) == 2 &&
                  offsetof(BusVoltageFilter, shift) == 3 && offsetof(BusVoltageFilter, recip_q27) == 4,
              "the frame reads the bus filter at these offsets");
static_assert(offsetof(BusSagFilter, seen_q4) == 0 && offsetof(BusSagFilter, rem) == 2 &&
                  offsetof(BusSagFilter, last_q4) == 3,
              "the frame reads the sag filter at these offsets");
static_assert(kUseRestVoltage == 0x80, "the frame tests bit 7");
static_assert(offsetof(V2Frame, bus) == 0 && offsetof(V2Frame, sag) == 8 &&
                  offsetof(V2Frame, pwm_min_us) == 13 && offsetof(V2Frame, pwm_max_us) == 15 &&
                  offsetof(V2Frame, count) == 17 && offsetof(V2Frame, lane) == 18,
              "the frame reaches its state at these offsets");
static_assert(kStopped == 1 && kSaturated == 4 && kClamped == 0x40,
              "the frame writes these flags as numbers (an asm statement takes at most 30 operands)");
static_assert(kNewtonLimit == 1l << 20 && kRecipOne == 1ul << 27,
              "the Newton step below is written for a Q27 reciprocal and a range of 2^20");

// 2^27 / mv: the bus filter's re-seed after a jump (the frame's only division, rare).
__attribute__((noinline, used)) uint16_t reseedRecipQ27(uint16_t mv) {
  return static_cast<uint16_t>(kRecipOne / mv);
}

// Every lane's flags of the frame running (the frame's registers are all taken).
uint8_t g_lane_flags;

// An insane sample or a filter not valid yet: the frame calls BusVoltageFilter::update (rare).
// Returns the flags every lane then gets.
__attribute__((noinline, used)) uint8_t slowFilterStep(BusVoltageFilter* bus, uint16_t sample_mv) {
  bus->update(sample_mv);
  return bus->isValid() ? 0 : static_cast<uint8_t>(kVoltageInvalid | kUseRestVoltage);
}

// The frame's state at fixed offsets from Y.
constexpr uint8_t kOffBus = 0, kOffSag = 8, kOffMin = 13, kOffMax = 15, kOffCount = 17, kOffLanes = 18;

// The frame's set-up, the same after the fast check (then the filter step in assembly) and
// after the C filter step: the limits, the lane count, every lane's flags (T: fly each model's
// resting voltage; r3 becomes a second zero register), recip and m = 2^(8 - shift). Spelled once
// and pasted into both paths (a shared tail would cost a branch in the per-frame path).
#define TC_V2FLY_SETUP \
      "ldd  r6, Y+%[o_min]\n\t" \
      "ldd  r7, Y+%[o_min]+1\n\t" \
      "ldd  r8, Y+%[o_max]\n\t" \
      "ldd  r9, Y+%[o_max]+1\n\t" \
      "ldd  r2, Y+%[o_count]\n\t" \
      "bst  r3, 7\n\t" \
      "mov  r16, r3\n\t" \
      "andi r16, 0x7F\n\t" \
      "sts  %[lflags], r16\n\t" \
      "clr  r3\n\t" \
      "ldd  r4, Y+4\n\t" \
      "ldd  r5, Y+5\n\t" \
      "ldd  r16, Y+3\n\t" \
      "ldi  r30, lo8(%[mtab])\n\t" \
      "ldi  r31, hi8(%[mtab])\n\t" \
      "add  r30, r16\n\t" \
      "adc  r31, r3\n\t" \
      "ld   r16, Z\n\t" \
      "mov  r10, r16\n\t"

TC_INLINE void frameAvr(V2Frame& frame, uint16_t sample_mv, uint8_t extra_flags) {
  register V2Frame* y asm("r28") = &frame;
  register uint16_t sample asm("r22") = sample_mv;
  register uint8_t fl asm("r3") = extra_flags;
  __asm__ volatile(
      "tc_v2fly_check:\n\t"
      // an insane sample or a filter not valid yet: BusVoltageFilter::update in C
      "ldd  r12, Y+0\n\t"
      "ldd  r13, Y+1\n\t"
      "cp   r12, __zero_reg__\n\t"
      "cpc  r13, __zero_reg__\n\t"
      "breq 36f\n\t"
      "movw r24, r22\n\t"
      "subi r24, lo8(%[sane_lo])\n\t"
      "sbci r25, hi8(%[sane_lo])\n\t"
      "cpi  r24, lo8(%[sane_span])\n\t"
      "ldi  r16, hi8(%[sane_span])\n\t"
      "cpc  r25, r16\n\t"
      "brsh 36f\n\t"
      TC_V2FLY_SETUP
      "rjmp 42f\n"
      "36:\n\t"  // the C step (BusVoltageFilter::update), then the same setup, then the sag
      "movw r24, r28\n\t"
      "call %x[slow]\n\t"  // r24: kVoltageInvalid | kUseRestVoltage while not valid
      "or   r3, r24\n\t"
      TC_V2FLY_SETUP
      "rjmp 49f\n"
      "tc_v2fly_filter:\n\t"
      "42:\n\t"
      // bus filter: mv += step, rem from t * m = rem + (sample - mv) * m
      "sub  r22, r12\n\t"  // r13:r12 = mv (loaded by the check above)
      "sbc  r23, r13\n\t"
      "tst  r16\n\t"
      "brne 43f\n\t"
      "movw r24, r22\n\t"  // shift 0: step = sample - mv, rem 0
      "clr  r14\n\t"
      "rjmp 44f\n"
      "43:\n\t"
      "ldd  r14, Y+2\n\t"
      "mulsu r23, r16\n\t"  // (MUL sets C: the products first, the sums after)
      "movw r24, r0\n\t"
      "mul  r22, r16\n\t"
      "add  r24, r1\n\t"
      "adc  r25, r3\n\t"
      "add  r14, r0\n\t"
      "adc  r24, r3\n\t"
      "adc  r25, r3\n"
      "44:\n\t"
      "std  Y+2, r14\n\t"
      "cp   r24, r3\n\t"
      "cpc  r25, r3\n\t"
      "brne 45f\n\t"
      "rjmp 49f\n"  // steady: the reciprocal holds
      "45:\n\t"
      "add  r12, r24\n\t"
      "adc  r13, r25\n\t"
      "std  Y+0, r12\n\t"
      "std  Y+1, r13\n\t"
      // Newton (as BusVoltageFilter::update): mv * recip in r19..r16
      "mul  r12, r4\n\t"
      "movw r16, r0\n\t"
      "mul  r13, r5\n\t"
      "movw r18, r0\n\t"
      "mul  r12, r5\n\t"
      "add  r17, r0\n\t"
      "adc  r18, r1\n\t"
      "adc  r19, r3\n\t"
      "mul  r13, r4\n\t"
      "add  r17, r0\n\t"
      "adc  r18, r1\n\t"
      "adc  r19, r3\n\t"
      "subi r19, 0x08\n\t"  // D = mv * recip - 2^27 = -e
      // |D| <= 2^20, else re-seed by division
      "tst  r19\n\t"
      "breq 46f\n\t"
      "cpi  r19, 0xFF\n\t"
      "brne 48f\n\t"
      "cpi  r18, 0xF0\n\t"
      "brsh 47f\n\t"
      "rjmp 48f\n"
      "46:\n\t"
      "cpi  r18, 0x10\n\t"
      "brlo 47f\n\t"
      "brne 48f\n\t"
      "mov  r0, r17\n\t"
      "or   r0, r16\n\t"
      "brne 48f\n"
      "47:\n\t"
      // e / 2^8 = floor(-D / 2^8) = -T, T = (D + 255) / 2^8 in r18:r17; corr = |T| * recip / 2^19
      "subi r16, 0x01\n\t"
      "sbci r17, 0xFF\n\t"
      "sbci r18, 0xFF\n\t"
      "mov  r16, r18\n\t"  // sign of T
      "sbrs r18, 7\n\t"
      "rjmp 50f\n\t"
      "com  r18\n\t"
      "neg  r17\n\t"
      "sbci r18, 0xFF\n"
      "50:\n\t"
      "mul  r17, r4\n\t"
      "mov  r19, r1\n\t"
      "mul  r18, r5\n\t"
      "movw r24, r0\n\t"
      "mul  r17, r5\n\t"
      "add  r19, r0\n\t"
      "adc  r24, r1\n\t"
      "adc  r25, r3\n\t"
      "mul  r18, r4\n\t"
      "add  r19, r0\n\t"
      "adc  r24, r1\n\t"
      "adc  r25, r3\n\t"
      "lsr  r25\n\t"  // / 8
      "ror  r24\n\t"
      "lsr  r25\n\t"
      "ror  r24\n\t"
      "lsr  r25\n\t"
      "ror  r24\n\t"
      "sbrc r16, 7\n\t"  // T < 0 (e > 0): up; T > 0: down
      "rjmp 51f\n\t"
      "sub  r4, r24\n\t"
      "sbc  r5, r25\n\t"
      "rjmp 52f\n"
      "51:\n\t"
      "add  r4, r24\n\t"
      "adc  r5, r25\n"
      "52:\n\t"
      "std  Y+4, r4\n\t"
      "std  Y+5, r5\n\t"
      "rjmp 49f\n"
      "48:\n\t"  // out of range: re-seed by division (as BusVoltageFilter::update)
      "movw r24, r12\n\t"
      "clr  r1\n\t"
      "call %x[reseed]\n\t"
      "movw r4, r24\n\t"
      "std  Y+4, r24\n\t"
      "std  Y+5, r25\n\t"
      "ldd  r16, Y+%[o_reseeds]\n\t"
      "cpi  r16, 0xFF\n\t"
      "breq 49f\n\t"
      "inc  r16\n\t"
      "std  Y+%[o_reseeds], r16\n"
      "tc_v2fly_sag:\n\t"
      "49:\n\t"
      // sag filter: seen += floor((rem + (last - seen) * m) / 256); x = seen - last = -d (r23:r22)
      "ldd  r12, Y+%[o_sag]\n\t"
      "ldd  r13, Y+%[o_sag]+1\n\t"
      "ldd  r22, Y+%[o_sag]+3\n\t"
      "ldd  r23, Y+%[o_sag]+4\n\t"
      "sub  r22, r12\n\t"  // d = last - seen = -x
      "sbc  r23, r13\n\t"
      "mov  r17, r10\n\t"
      "tst  r17\n\t"
      "brne 53f\n\t"
      "movw r24, r22\n\t"  // shift 0: seen = last
      "clr  r16\n\t"
      "rjmp 54f\n"
      "53:\n\t"
      "ldd  r16, Y+%[o_sag]+2\n\t"
      "mulsu r23, r17\n\t"
      "movw r24, r0\n\t"
      "mul  r22, r17\n\t"
      "add  r24, r1\n\t"
      "adc  r25, r3\n\t"
      "add  r16, r0\n\t"
      "adc  r24, r3\n\t"
      "adc  r25, r3\n"
      "54:\n\t"
      "std  Y+%[o_sag]+2, r16\n\t"
      "add  r12, r24\n\t"
      "adc  r13, r25\n\t"
      "std  Y+%[o_sag], r12\n\t"
      "std  Y+%[o_sag]+1, r13\n\t"
      "tc_v2fly_predict:\n\t"
      // prediction (as predictedRecip): skipped when x = 0 or the bus is not valid
      "brts 30f\n\t"
      "cp   r22, r3\n\t"
      "cpc  r23, r3\n\t"
      "brne 31f\n"
      "30:\n\t"
      "rjmp 9f\n"
      "31:\n\t"
      "mov  r16, r23\n\t"  // sign of d = -x
      "movw r24, r22\n\t"  // |x|
      "sbrs r23, 7\n\t"
      "rjmp 5f\n\t"
      "com  r25\n\t"
      "neg  r24\n\t"
      "sbci r25, 0xFF\n"
      "5:\n\t"
      "movw r20, r4\n\t"  // k = recip * 5 / 4
      "lsr  r21\n\t"
      "ror  r20\n\t"
      "lsr  r21\n\t"
      "ror  r20\n\t"
      "add  r20, r4\n\t"
      "adc  r21, r5\n\t"
      "mul  r24, r20\n\t"  // e13 = |x| * k / 2^15
      "mov  r18, r1\n\t"
      "mul  r25, r21\n\t"
      "movw r22, r0\n\t"
      "mul  r24, r21\n\t"
      "add  r18, r0\n\t"
      "adc  r22, r1\n\t"
      "adc  r23, r3\n\t"
      "mul  r25, r20\n\t"
      "add  r18, r0\n\t"
      "adc  r22, r1\n\t"
      "adc  r23, r3\n\t"
      "lsl  r18\n\t"  // / 2^15: bytes 3..2 times 2 and bit 15
      "rol  r22\n\t"
      "rol  r23\n\t"
      "cpi  r22, 0x01\n\t"  // at most 2048 (e = 1/4)
      "ldi  r18, 0x08\n\t"
      "cpc  r23, r18\n\t"
      "brlo 6f\n\t"
      "ldi  r22, 0x00\n\t"
      "ldi  r23, 0x08\n"
      "6:\n\t"
      "lsl  r22\n\t"  // e = e13 * 8 (Q16)
      "rol  r23\n\t"
      "lsl  r22\n\t"
      "rol  r23\n\t"
      "lsl  r22\n\t"
      "rol  r23\n\t"
      "mov  r18, r23\n\t"  // e2 = e8^2 (Q16), e8 = e / 2^8 rounded (<= 64)
      "sbrc r22, 7\n\t"
      "inc  r18\n\t"
      "mul  r18, r18\n\t"
      "movw r20, r0\n\t"
      "sbrc r16, 7\n\t"  // g = e + e2 (x < 0, d > 0) or e - e2 (x > 0)
      "rjmp 7f\n\t"
      "add  r22, r20\n\t"
      "adc  r23, r21\n\t"
      "rjmp 8f\n"
      "7:\n\t"
      "sub  r22, r20\n\t"
      "sbc  r23, r21\n"
      "8:\n\t"
      "mul  r4, r22\n\t"  // corr = recip * g / 2^16
      "mov  r18, r1\n\t"
      "mul  r5, r23\n\t"
      "movw r20, r0\n\t"
      "mul  r4, r23\n\t"
      "add  r18, r0\n\t"
      "adc  r20, r1\n\t"
      "adc  r21, r3\n\t"
      "mul  r5, r22\n\t"
      "add  r18, r0\n\t"
      "adc  r20, r1\n\t"
      "adc  r21, r3\n\t"
      "sbrs r16, 7\n\t"
      "rjmp 3f\n\t"
      "sub  r4, r20\n\t"  // x > 0: the bus will rise
      "sbc  r5, r21\n\t"
      "rjmp 9f\n"
      "3:\n\t"
      "add  r4, r20\n\t"  // x < 0: the bus will sag
      "adc  r5, r21\n"
      "9:\n\t"
      "movw r20, r4\n\t"  // recip26 = (recip + 1) / 2
      "subi r20, 0xFF\n\t"
      "sbci r21, 0xFF\n\t"
      "lsr  r21\n\t"
      "ror  r20\n\t"
      "movw r4, r20\n\t"
      "clr  r10\n\t"
      "clr  r11\n\t"
      "movw r26, r28\n\t"  // X = the lanes
      "adiw r26, %[o_lanes]\n\t"
      "tst  r2\n\t"
      "brne 10f\n\t"
      "rjmp 19f\n"
      "rjmp 10f\n"
      "tc_v2fly_rare_a:\n\t"
      // out of line, ahead of the loop (within a branch's reach of its start)
      "20:\n\t"  // force 0: stopped, pwm_min
      "ldi  r16, 1\n\t"
      "movw r20, r6\n\t"
      "adiw r26, 3\n\t"  // past the lane's start threshold
      "rjmp 17f\n"
      "21:\n\t"  // fine run (below the split, so below the curve's end)
      "ldd  r22, Z+%[o_inv]\n\t"
      "ldd  r23, Z+%[o_inv]+1\n\t"
      "clr  r17\n\t"
      "ldd  r14, Z+%[o_q16]\n\t"
      "tst  r14\n\t"
      "breq 14f\n\t"
      // small motor: inv = 2^16 / step, force * inv * 2^8: index = byte 2, fraction = bytes 1..0
      // (the knot multiply below again, out of line: the other models' fine runs pay 4 cycles
      // for the flag test and no branch back into a shared multiply)
      "mul  r12, r22\n\t"
      "movw r18, r0\n\t"
      "mul  r13, r23\n\t"
      "movw r20, r0\n\t"
      "mul  r12, r23\n\t"
      "add  r19, r0\n\t"
      "adc  r20, r1\n\t"
      "adc  r21, r3\n\t"
      "mul  r13, r22\n\t"
      "add  r19, r0\n\t"
      "adc  r20, r1\n\t"
      "adc  r21, r3\n\t"
      "mov  r21, r20\n\t"
      "mov  r20, r19\n\t"
      "mov  r19, r18\n\t"
      "rjmp 27f\n"
      "22:\n\t"  // above the curve's end: its end, saturated
      "movw r12, r18\n\t"
      "ori  r16, 4\n\t"
      "rjmp 13f\n"
      "tc_v2fly_lane:\n\t"
      "10:\n\t"
      "ld   r30, X+\n\t"  // model
      "ld   r31, X+\n\t"
      "ld   r12, X+\n\t"  // force
      "ld   r13, X+\n\t"
      "cp   r12, r3\n\t"
      "cpc  r13, r3\n\t"
      "breq 20b\n\t"
      "lds  r16, %[lflags]\n\t"
      "ldd  r22, Z+%[o_split]\n\t"
      "ldd  r23, Z+%[o_split]+1\n\t"
      "cp   r12, r22\n\t"
      "cpc  r13, r23\n\t"
      "brlo 21b\n\t"
      "ldd  r18, Z+%[o_fmax]\n\t"  // coarse run: clamp to the curve's end first
      "ldd  r19, Z+%[o_fmax]+1\n\t"
      "cp   r18, r12\n\t"
      "cpc  r19, r13\n\t"
      "brlo 22b\n"
      "13:\n\t"
      "sub  r12, r22\n\t"
      "sbc  r13, r23\n\t"
      "ldd  r22, Z+%[o_invc]\n\t"
      "ldd  r23, Z+%[o_invc]+1\n\t"
      "ldd  r17, Z+%[o_fine]\n"
      "14:\n\t"
      "tc_v2fly_knot:\n\t"
      // r21..r18 = force * inv * 4: index = r21, fraction = r20:r19
      "mul  r12, r22\n\t"
      "movw r18, r0\n\t"
      "mul  r13, r23\n\t"
      "movw r20, r0\n\t"
      "mul  r12, r23\n\t"
      "add  r19, r0\n\t"
      "adc  r20, r1\n\t"
      "adc  r21, r3\n\t"
      "mul  r13, r22\n\t"
      "add  r19, r0\n\t"
      "adc  r20, r1\n\t"
      "adc  r21, r3\n\t"
      "lsl  r18\n\t"
      "rol  r19\n\t"
      "rol  r20\n\t"
      "rol  r21\n\t"
      "lsl  r18\n\t"
      "rol  r19\n\t"
      "rol  r20\n\t"
      "rol  r21\n\t"
      "tc_v2fly_interp:\n\t"
      "27:\n\t"
      // Z = &knot[base + index], 4 bytes per knot
      "add  r17, r21\n\t"
      "lsl  r17\n\t"
      "lsl  r17\n\t"
      "adiw r30, %[o_knot]\n\t"
      "add  r30, r17\n\t"
      "adc  r31, r3\n\t"
      "ld   r24, Z+\n\t"  // lower knot: drive, sag
      "ld   r25, Z+\n\t"
      "ld   r18, Z\n\t"
      "ldd  r12, Z+2\n\t"  // upper knot: drive, sag
      "ldd  r13, Z+3\n\t"
      "ldd  r23, Z+4\n\t"
      // drive = lo + round((hi - lo) * fraction / 2^16); the product's byte 0 never carries
      "sub  r12, r24\n\t"
      "sbc  r13, r25\n\t"
      "mul  r12, r19\n\t"
      "mov  r22, r1\n\t"
      "mul  r13, r20\n\t"
      "movw r14, r0\n\t"
      "mul  r12, r20\n\t"
      "add  r22, r0\n\t"
      "adc  r14, r1\n\t"
      "adc  r15, r3\n\t"
      "mul  r13, r19\n\t"
      "add  r22, r0\n\t"
      "adc  r14, r1\n\t"
      "adc  r15, r3\n\t"
      "lsl  r22\n\t"
      "adc  r14, r3\n\t"
      "adc  r15, r3\n\t"
      "add  r24, r14\n\t"
      "adc  r25, r15\n\t"
      "tc_v2fly_sagpt:\n\t"
      // sag in 1/16 unit: lo * (16 - f) + hi * f, f = the fraction's top nibble
      "mov  r17, r20\n\t"
      "swap r17\n\t"
      "andi r17, 0x0F\n\t"
      "mul  r23, r17\n\t"
      "add  r10, r0\n\t"
      "adc  r11, r1\n\t"
      "subi r17, 16\n\t"
      "neg  r17\n\t"
      "mul  r18, r17\n\t"
      "add  r10, r0\n\t"
      "adc  r11, r1\n\t"
      "brts 23f\n"  // bus not valid
      "tc_v2fly_duty:\n\t"
      "15:\n\t"
      // r21..r18 = drive * recip26 + start (+ 1/2 us; its byte 0 is 0), pulse = r21:r20 / 2
      "mul  r24, r4\n\t"
      "movw r18, r0\n\t"
      "mul  r25, r5\n\t"
      "movw r20, r0\n\t"
      "mul  r24, r5\n\t"
      "add  r19, r0\n\t"
      "adc  r20, r1\n\t"
      "adc  r21, r3\n\t"
      "mul  r25, r4\n\t"
      "add  r19, r0\n\t"
      "adc  r20, r1\n\t"
      "adc  r21, r3\n\t"
      "ld   r0, X+\n\t"  // the lane's start threshold
      "add  r19, r0\n\t"
      "ld   r0, X+\n\t"
      "adc  r20, r0\n\t"
      "ld   r0, X+\n\t"
      "adc  r21, r0\n\t"
      "lsr  r21\n\t"
      "ror  r20\n\t"
      "tc_v2fly_limits:\n\t"
      // limits
      "cp   r8, r20\n\t"
      "cpc  r9, r21\n\t"
      "brlo 24f\n\t"
      "cp   r20, r6\n\t"
      "cpc  r21, r7\n\t"
      "brlo 25f\n"
      "17:\n\t"
      "st   X+, r16\n\t"
      "st   X+, r20\n\t"
      "st   X+, r21\n\t"
      "dec  r2\n\t"
      "breq 19f\n\t"
      "rjmp 10b\n"
      "tc_v2fly_rare_b:\n\t"
      // out of line, after the loop (within a branch's reach of its end)
      "23:\n\t"  // bus not valid: this model's resting voltage, (rest_recip + 1) / 2
      "movw r22, r26\n\t"  // the model again, from the lane
      "sbiw r26, 4\n\t"
      "ld   r30, X+\n\t"
      "ld   r31, X\n\t"
      "movw r26, r22\n\t"
      "ldd  r22, Z+%[o_rrec]\n\t"
      "ldd  r23, Z+%[o_rrec]+1\n\t"
      "subi r22, 0xFF\n\t"
      "sbci r23, 0xFF\n\t"
      "lsr  r23\n\t"
      "ror  r22\n\t"
      "movw r4, r22\n\t"
      "rjmp 15b\n"
      "24:\n\t"  // above the maximum: saturated
      "movw r20, r8\n\t"
      "ori  r16, 4\n\t"
      "rjmp 17b\n"
      "25:\n\t"  // below the minimum: clamped
      "movw r20, r6\n\t"
      "ori  r16, 0x40\n\t"
      "rjmp 17b\n"
      "tc_v2fly_out:\n\t"
      "19:\n\t"
      "std  Y+%[o_sag]+3, r10\n\t"
      "std  Y+%[o_sag]+4, r11\n\t"
      "clr  r1"
      : "+r"(sample), "+r"(fl)
      : "y"(y), [o_split] "I"(offsetof(ModelV2Run, split_dg)),
        [o_max] "I"(kOffMax), [o_min] "I"(kOffMin), [o_count] "I"(kOffCount), [o_sag] "I"(kOffSag),
        [o_lanes] "I"(kOffLanes), [o_fmax] "I"(offsetof(ModelV2Run, max_force_dg)),
        [o_inv] "I"(offsetof(ModelV2Run, inv_step_q22)), [o_invc] "I"(offsetof(ModelV2Run, inv_coarse_q22)),
        [o_fine] "I"(offsetof(ModelV2Run, fine_knots)), [o_knot] "I"(offsetof(ModelV2Run, knot)),
        [o_rrec] "I"(offsetof(ModelV2Run, rest_recip_q27)), [o_q16] "I"(offsetof(ModelV2Run, q16_inverse)),
        [o_reseeds] "I"(offsetof(BusVoltageFilter, reseeds)), [reseed] "i"(&reseedRecipQ27),
        [slow] "i"(&slowFilterStep), [mtab] "i"(kShiftMul), [sane_lo] "i"(kV2SaneMinMv),
        [sane_span] "i"(kV2SaneMaxMv - kV2SaneMinMv + 1), [lflags] "i"(&g_lane_flags)
      : "r0", "r2", "r4", "r5", "r6", "r7", "r8", "r9", "r10", "r11", "r12", "r13", "r14", "r15",
        "r16", "r17", "r18", "r19", "r20", "r21", "r24", "r25", "r26", "r27", "r30", "r31", "memory");
}
#endif


}  // namespace

void V2Frame::fly(uint16_t sample_mv, uint8_t extra_flags) {
#if defined(__AVR_HAVE_MUL__)
  frameAvr(*this, sample_mv, extra_flags);
#else
  framePortable(*this, sample_mv, extra_flags);
#endif
}

void V2Frame::flyPortable(uint16_t sample_mv, uint8_t extra_flags) {
  framePortable(*this, sample_mv, extra_flags);
}

uint16_t headroomDg(const ModelV2Run& model, uint16_t vbus_mv, const ForcePwmLimits& limits) {
  if (!model.isPresent() || vbus_mv == 0) return 0;
  uint16_t pwm_us = limits.pwm_max_us;
  if (pwm_us > 4000) pwm_us = 4000;  // keeps (pwm - start) * mV below 2^32
  const uint32_t pwm_q4 = static_cast<uint32_t>(pwm_us) << 4;
  const uint16_t start_q4 = model.startQ4Us();
  if (pwm_q4 <= start_q4) return 0;
  // As forceForPwmDg(ModelV2): (pwm - start) in 1/16 us times mV, / (16 * 512) < 2^32.
  const uint32_t drive = ((pwm_q4 - start_q4) * vbus_mv) >> 13;
  uint8_t k = 0;
  while (k < model.knots && model.knot[k + 1].drive_512usmv < drive) ++k;
  if (k == model.knots) return model.max_force_dg;
  const uint16_t lo = model.knot[k].drive_512usmv;
  const uint16_t hi = model.knot[k + 1].drive_512usmv;
  const uint32_t base = k ? model.knotForceDg(static_cast<uint8_t>(k - 1)) : 0;
  const uint32_t step = model.knotForceDg(k) - base;
  if (hi == lo) return static_cast<uint16_t>(base + step);
  return static_cast<uint16_t>(base + ((drive - lo) * step + (hi - lo) / 2) / (hi - lo));
}

}  // namespace tc
