// Force model v2 at run time (read_run every frame, and the status line): the bus voltage
// filter, force -> PWM (one motor, one frame of several motors, with the bench sag of the
// step predicted) and the inverse for the status line. Fixed point, no float, no division
// per frame: see model_v2.hpp for the formats and model_v2_runtime.hpp for the per-frame path
// read_run flies. The fixed-point helpers are in model_v2_fixed_point.hpp, the AVR frame's
// assembly in model_v2_frame_avr*.inc; the fitter (gather_store, once per sweep) is
// model_v2_fit.cpp. Every multiplication below states its bound; `int` is 16 bits on the AVR,
// so every product that can exceed 16 bits is cast to 32 bits first.
#include "thrustcal/model_v2_runtime.hpp"

#include <stddef.h>

#include "model_v2_fixed_point.hpp"

namespace tc {

// ---- BusVoltageFilter ----------------------------------------------------------------------

void BusVoltageFilter::reset(uint16_t mv_now) {
  if (shift > 6) shift = 6;
  rem = 0;
  if (!isSaneV2Mv(mv_now)) {
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
  if (!isSaneV2Mv(sample_mv)) {
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

#include "model_v2_frame_avr.inc"


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
