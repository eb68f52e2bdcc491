// Force-PWM controller, thesis option 2.1, per ESC frame: int32 multiply, one int32 division,
// no float, no 64-bit arithmetic.
#include "thrustcal/force_pwm.hpp"

namespace tc {

namespace {

uint16_t clampPwm(int32_t pwm_us, const ForcePwmLimits& limits, uint8_t& flags) {
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

// PWM of `curve` at `force_g`, flagging a force beyond what the curve reaches.
uint16_t lookUp(const ForceCurveBase& curve, uint16_t force_g, uint8_t& flags) {
  if (force_g > curve.maxGrams()) flags |= kSaturated;
  return curve.pwmForGrams(force_g);
}

// num / den rounded to nearest (halves away from zero), den != 0.
int32_t divRound(int32_t num, int32_t den) {
  int32_t q = num / den;
  int32_t r = num % den;  // sign of num
  if (r < 0) r = -r;
  const int32_t abs_den = den < 0 ? -den : den;
  if (2 * r >= abs_den) q += ((num < 0) != (den < 0)) ? -1 : 1;
  return q;
}

}  // namespace

ForcePwmResult forceToPwm(const MotorCalibration& cal, uint16_t force_g, uint16_t vbat_mv,
                          const ForcePwmLimits& limits) {
  ForcePwmResult result{limits.pwm_min_us, 0};
  if (!cal.isCalibrated() || cal.first.maxGrams() == 0) result.flags |= kNotCalibrated;
  if (force_g == 0) result.flags |= kStopped;
  if (result.flags) return result;

  const uint16_t c1_us = lookUp(cal.first, force_g, result.flags);
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
      const uint16_t c2_us = lookUp(cal.second, force_g, result.flags);
      // |dv| <= 65535 and |dc| <= 32767 keep the product inside int32; a calibration that
      // passed the codec's checks has PWMs of a few thousand us, so the clamp never bites.
      const int32_t dv_mv = static_cast<int32_t>(vbat_mv) - cal.first.start_mv;
      int32_t dc_us = static_cast<int32_t>(c2_us) - c1_us;
      if (dc_us > 32767) dc_us = 32767;
      if (dc_us < -32767) dc_us = -32767;
      const int32_t pwm_us = static_cast<int32_t>(c1_us) + divRound(dv_mv * dc_us, span_mv);
      result.pwm_us = clampPwm(pwm_us, limits, result.flags);
      return result;
    }
  }
  result.pwm_us = clampPwm(c1_us, limits, result.flags);
  return result;
}

}  // namespace tc
