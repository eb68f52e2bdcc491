// Force-PWM controller, thesis option 2.1, per ESC frame: int32 multiply, one int32 division,
// no float, no 64-bit arithmetic. The arithmetic is forceToPwmWithDg (force_pwm.hpp), shared with
// the form read_run flies (tc::ThesisRun).
#include "thrustcal/force_pwm.hpp"

namespace tc {

namespace {
uint16_t pwmAtGram(const ForceCurveBase& curve, uint16_t grams) { return curve.pwmForGrams(grams); }
}  // namespace

ForcePwmResult forceToPwm(const MotorCalibration& cal, uint16_t force_g, uint16_t vbat_mv,
                          const ForcePwmLimits& limits) {
  return forceToPwmWith(cal, force_g, vbat_mv, limits, pwmAtGram);
}

ForcePwmResult forceToPwmDg(const MotorCalibration& cal, uint16_t force_dg, uint16_t vbat_mv,
                            const ForcePwmLimits& limits) {
  return forceToPwmWithDg(cal, force_dg, vbat_mv, limits, pwmAtGram);
}

}  // namespace tc
