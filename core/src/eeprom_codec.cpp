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

DecodeStatus validate(MotorCalibration& cal, const RecordLimits& limits, Plausibility* why) {
  const Plausibility p = checkCalibration(cal, limits);
  if (why) *why = p;
  return p.ok() ? DecodeStatus::kOk : DecodeStatus::kBadContent;
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
