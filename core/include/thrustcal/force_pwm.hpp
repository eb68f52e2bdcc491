// Force-PWM controller, thesis option 2.1 (sec. 6.3, 6.5):
//   PWM = c1(F) + (V_now - V1) * (c2(F) - c1(F)) / (V2 - V1)
// integer arithmetic, clamped to the ESC range. Defined behaviour at every edge, each
// reported in the result's flags:
//   F == 0                       -> pwm_min (motor stopped), kStopped
//   not calibrated               -> pwm_min, kNotCalibrated
//   F above what a curve reaches -> that curve's PWM at its heaviest gram, kSaturated
//   V_now outside sane range     -> first curve alone (no voltage term), kVoltageInvalid
//   no second curve              -> first curve alone, kSingleCurve
//   |V2 - V1| < min span         -> first curve alone, kEqualVoltages
//   result outside ESC range     -> clamped, kClamped
// "Not calibrated" also covers a first curve without a single gram. The voltage term is
// rounded to the nearest microsecond (halves away from zero) and is extrapolated linearly
// outside V1..V2. A second curve shorter than F saturates at its own heaviest gram (flagged
// kSaturated). One 32-bit division per call; its cost on the ATmega2560 is measured by
// tests/core/avr_cycles.sh.
#pragma once
#include <stdint.h>

#include "thrustcal/limits.hpp"
#include "thrustcal/motor_calibration.hpp"

namespace tc {

struct ForcePwmLimits {
  uint16_t pwm_min_us = kThrottleMinUs;
  uint16_t pwm_max_us = kThrottleMaxUs;
  uint16_t v_min_mv = kVbatSaneMinMv;
  uint16_t v_max_mv = kVbatSaneMaxMv;
  uint16_t min_voltage_span_mv = 100;
};

enum ForcePwmFlag : uint8_t {
  kStopped = 1u << 0,
  kNotCalibrated = 1u << 1,
  kSaturated = 1u << 2,
  kVoltageInvalid = 1u << 3,
  kSingleCurve = 1u << 4,
  kEqualVoltages = 1u << 5,
  kClamped = 1u << 6,
};

struct ForcePwmResult {
  uint16_t pwm_us;
  uint8_t flags;  // ForcePwmFlag bits
};

ForcePwmResult forceToPwm(const MotorCalibration& cal, uint16_t force_g, uint16_t vbat_mv,
                          const ForcePwmLimits& limits = ForcePwmLimits());
// The same for a force in decigrams (0.1 g): between two grams the curves' straight line.
ForcePwmResult forceToPwmDg(const MotorCalibration& cal, uint16_t force_dg, uint16_t vbat_mv,
                            const ForcePwmLimits& limits = ForcePwmLimits());

namespace force_pwm_detail {

// floor(m / d) for m < 256 d and d < 2^16: eight steps of long division (the quotient's eight
// bits), ~200 AVR cycles where the library's 32-bit division takes ~650.
inline uint32_t shortQuotient(uint32_t m, uint32_t d) {
  uint32_t rem = m >> 8;  // < d
  uint8_t low = static_cast<uint8_t>(m);
  uint8_t q = 0;
  for (uint8_t i = 0; i < 8; ++i) {
    rem = (rem << 1) | (low >> 7);
    low = static_cast<uint8_t>(low << 1);
    q = static_cast<uint8_t>(q << 1);
    if (rem >= d) {
      rem -= d;
      q = static_cast<uint8_t>(q | 1u);
    }
  }
  return q;
}

// num / den rounded to nearest (halves away from zero), den != 0, num > INT32_MIN. The
// magnitude is floor((|num| + floor(|den| / 2)) / |den|): a remainder of at least half of |den|
// rounds it up. Option 2.1 divides every motor's voltage share by the curves' voltage span each
// frame, a quotient of a few microseconds: shortQuotient when it is below 256.
inline int32_t divRound(int32_t num, int32_t den) {
  const bool negative = (num < 0) != (den < 0);
  const uint32_t n = num < 0 ? 0u - static_cast<uint32_t>(num) : static_cast<uint32_t>(num);
  const uint32_t d = den < 0 ? 0u - static_cast<uint32_t>(den) : static_cast<uint32_t>(den);
  const uint32_t m = n + (d >> 1);
  const uint32_t q = d <= 0xFFFFu && (m >> 8) < d ? shortQuotient(m, d) : m / d;
  return negative ? -static_cast<int32_t>(q) : static_cast<int32_t>(q);
}

inline uint16_t clampPwm(int32_t pwm_us, const ForcePwmLimits& limits, uint8_t& flags) {
  if (pwm_us < limits.pwm_min_us) {
    flags |= kClamped;
    return limits.pwm_min_us;
  }
  if (pwm_us > limits.pwm_max_us) {
    flags |= kClamped;
    return limits.pwm_max_us;
  }
  return static_cast<uint16_t>(pwm_us);
}

}  // namespace force_pwm_detail

// The curve's PWM at `grams` + `tenths` / 10, in tenths of a microsecond: between two grams
// the straight line between their PWMs (the curves are measured per gram); below the first gram
// the first gram's PWM, at and beyond the heaviest the heaviest's.
template <class Curve, class PwmFor>
int32_t pwmTenthsAt(const Curve& curve, uint16_t grams, uint8_t tenths, PwmFor pwmFor) {
  const uint16_t max = curve.maxGrams();
  if (grams >= max) return 10 * static_cast<int32_t>(pwmFor(curve, max));
  if (grams == 0) return 10 * static_cast<int32_t>(pwmFor(curve, 1));
  const int32_t lo = pwmFor(curve, grams);
  if (tenths == 0) return 10 * lo;
  return 10 * lo + static_cast<int32_t>(tenths) * (static_cast<int32_t>(pwmFor(curve, static_cast<uint16_t>(grams + 1))) - lo);
}

// Option 2.1 over any form of the thesis record for a force in decigrams: `cal` has
// isCalibrated(), hasSecondCurve() and curves `first` / `second` with start_mv and maxGrams();
// pwmFor(curve, grams) is the curve's PWM at a gram (1..maxGrams()). Each curve's PWM at the
// force (pwmTenthsAt, in 0.1 us), then PWM = c1 + (V_now - V1) (c2 - c1) / (V2 - V1) rounded once
// to the microsecond: at a whole gram exactly the thesis's arithmetic on whole microseconds (the
// rational is the same, and so is its rounding), between grams the curves' straight line.
// forceToPwm(MotorCalibration) is this over the decoded record; read_run and fly fly it over
// tc::ThesisRun (thesis_runtime.hpp), the same arithmetic to the bit.
template <class Cal, class PwmFor>
ForcePwmResult forceToPwmWithDg(const Cal& cal, uint16_t force_dg, uint16_t vbat_mv,
                                const ForcePwmLimits& limits, PwmFor pwmFor) {
  ForcePwmResult result{limits.pwm_min_us, 0};
  if (!cal.isCalibrated() || cal.first.maxGrams() == 0) result.flags |= kNotCalibrated;
  if (force_dg == 0) result.flags |= kStopped;
  if (result.flags) return result;

  // force_dg / 10 by a product (exact for every uint16_t: no division routine on the AVR).
  const uint16_t grams = static_cast<uint16_t>((static_cast<uint32_t>(force_dg) * 52429u) >> 19);
  const uint8_t tenths = static_cast<uint8_t>(force_dg - 10u * grams);
  // PWM of a curve at the force, flagging a force beyond what the curve reaches.
  if (force_dg > 10u * cal.first.maxGrams()) result.flags |= kSaturated;
  const int32_t c1_x10 = pwmTenthsAt(cal.first, grams, tenths, pwmFor);
  const int32_t c1_us = (c1_x10 * 52429) >> 19;  // whole microseconds (c1_x10 < 2^16, >= 0)
  const int32_t c1_tenths = c1_x10 - 10 * c1_us;
  if (vbat_mv < limits.v_min_mv || vbat_mv > limits.v_max_mv) {
    result.flags |= kVoltageInvalid;
  } else if (!cal.hasSecondCurve() || cal.second.maxGrams() == 0) {
    result.flags |= kSingleCurve;
  } else {
    const int32_t span_mv = static_cast<int32_t>(cal.second.start_mv) - cal.first.start_mv;
    const int32_t min_span_mv = limits.min_voltage_span_mv;
    if (span_mv < min_span_mv && -span_mv < min_span_mv) {
      result.flags |= kEqualVoltages;
    } else {
      if (force_dg > 10u * cal.second.maxGrams()) result.flags |= kSaturated;
      const int32_t c2_x10 = pwmTenthsAt(cal.second, grams, tenths, pwmFor);
      // |dv| <= 65535 and |dc| <= 32767 tenths keep the product inside int32; a calibration
      // that passed the codec's checks has PWMs of a few thousand us, so the clamp never bites.
      const int32_t dv_mv = static_cast<int32_t>(vbat_mv) - cal.first.start_mv;
      int32_t dc_x10 = c2_x10 - c1_x10;
      if (dc_x10 > 32767) dc_x10 = 32767;
      if (dc_x10 < -32767) dc_x10 = -32767;
      // c1 + (c1_tenths + dv dc_x10 / span) / 10, rounded once: the remainder over 10 span.
      const int32_t pwm_us =
          c1_us + force_pwm_detail::divRound(c1_tenths * span_mv + dv_mv * dc_x10, 10 * span_mv);
      result.pwm_us = force_pwm_detail::clampPwm(pwm_us, limits, result.flags);
      return result;
    }
  }
  result.pwm_us = force_pwm_detail::clampPwm(c1_us + (c1_tenths >= 5 ? 1 : 0), limits, result.flags);
  return result;
}

// The same for a force in whole grams (the thesis's own commands).
template <class Cal, class PwmFor>
ForcePwmResult forceToPwmWith(const Cal& cal, uint16_t force_g, uint16_t vbat_mv,
                              const ForcePwmLimits& limits, PwmFor pwmFor) {
  const uint16_t force_dg = force_g > 6553 ? 65530 : static_cast<uint16_t>(10u * force_g);
  return forceToPwmWithDg(cal, force_dg, vbat_mv, limits, pwmFor);
}

}  // namespace tc
