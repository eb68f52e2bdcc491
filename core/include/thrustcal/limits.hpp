// The system's shared numbers, one home each: what both firmware images, core and the host
// tools agree on. Messages print these constants rather than repeating their values, so a
// change here changes what the console says. What a calibration record may hold has its own
// header (record_limits.hpp, included here); docs/glossary.md explains the names.
#pragma once
#include <stdint.h>

#include "thrustcal/record_limits.hpp"

namespace tc {

// ESC pulses.
constexpr uint16_t kStopPwmUs = kThrottleMinUs;  // "motor off", also the arming pulse
constexpr uint16_t kArmMs = 2000;  // ESCs see kStopPwmUs this long before any command or sweep

// Battery readings the controller and the bench trust: below, a sensor fault or a dead pack
// (2S is out of scope); above, a sensor fault or a wrong divider setting.
constexpr uint16_t kVbatSaneMinMv = 6000;
constexpr uint16_t kVbatSaneMaxMv = 17500;
constexpr uint16_t kBatteryWindow = 101;  // thesis: the median of 101 battery readings

// Model v2 refine: the two sweeps' resting voltages must be at least this far apart.
constexpr uint16_t kV2MinVoltageGapMv = 500;

// read_run: with a motor running, no complete line for this long stops every motor.
constexpr uint16_t kFailsafeMs = 500;

}  // namespace tc
