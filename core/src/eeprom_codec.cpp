// EEPROM codec: the parts that are not templates over the Storage.
#include "thrustcal/eeprom_codec.hpp"

namespace tc {

const char* decodeStatusText(DecodeStatus status) {
  switch (status) {
    case DecodeStatus::kOk:
      return "ok";
    case DecodeStatus::kErased:
      return "erased (never calibrated)";
    case DecodeStatus::kBadVersion:
      return "unknown layout version";
    case DecodeStatus::kBadCrc:
      return "corrupt (CRC mismatch)";
    case DecodeStatus::kBadContent:
      return "implausible values";
  }
  return "unknown status";
}

namespace codec_detail {

namespace {

bool plausibleVoltage(uint16_t mv) { return mv >= kPlausibleMinMv && mv <= kPlausibleMaxMv; }
bool plausiblePwm(uint16_t us) { return us >= kPlausibleMinPwmUs && us <= kPlausibleMaxPwmUs; }

// A present curve: plausible start voltage, PWM at 1 g and at its heaviest gram, steps
// consistent (no real step after the end marker).
bool validCurve(ForceCurveBase& curve) {
  if (!plausibleVoltage(curve.start_mv) || !plausiblePwm(curve.pwm_at_1g_us)) return false;
  if (!curve.finalize()) return false;
  return plausiblePwm(curve.pwmForGrams(curve.maxGrams()));
}

}  // namespace

DecodeStatus validate(MotorCalibration& cal) {
  if (!validCurve(cal.first)) return DecodeStatus::kBadContent;
  if (!plausiblePwm(cal.sag.base_pwm_us) || cal.sag.offset_mv[0] != 0)
    return DecodeStatus::kBadContent;
  if (cal.second.start_mv == 0) {
    // No second curve: whatever its other bytes hold is not used.
    cal.second.clear();
  } else if (!validCurve(cal.second)) {
    return DecodeStatus::kBadContent;
  }
  return DecodeStatus::kOk;
}

int8_t sagToByte(int16_t offset_mv) {
  // Nearest multiple of 10 mV, saturated to the int8 range (-1280..1270 mV).
  int16_t units = static_cast<int16_t>(offset_mv / kSagUnitMv);
  const int16_t rest = static_cast<int16_t>(offset_mv % kSagUnitMv);
  if (rest >= kSagUnitMv / 2) ++units;
  if (rest <= -kSagUnitMv / 2) --units;
  if (units > 127) return 127;
  if (units < -128) return -128;
  return static_cast<int8_t>(units);
}

}  // namespace codec_detail

}  // namespace tc
