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
// kSaturated). Cost on the ATmega2560: about 1800 cycles (one 32-bit division), measured by
// tests/core/avr_cycles.sh.
#pragma once
#include <stdint.h>

#include "thrustcal/motor_calibration.hpp"

namespace tc {

struct ForcePwmLimits {
  uint16_t pwm_min_us = 1000;
  uint16_t pwm_max_us = 2000;
  uint16_t v_min_mv = 6000;
  uint16_t v_max_mv = 17500;
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

}  // namespace tc
