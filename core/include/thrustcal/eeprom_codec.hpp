// EEPROM codec for the per-motor calibration record, layout version 1.
//
// The thesis layout (table 6.1/6.2, 1024 bytes per motor at 0/1024/2048/3072) is the
// reference; version 1 keeps its order and size and adds a version byte and a CRC:
//
//   offset  size  field
//        0     1  layout version (1); 0xFF = erased
//        1     2  first curve start voltage, mV (little endian)
//        3     2  first curve PWM at 1 g, us
//        5   499  first curve steps, us per gram (0xFF = unreachable from here on)
//      504     2  sag table base PWM, us
//      506    13  sag offsets, int8, units of 10 mV (bin width 40 us)
//      519     2  second curve start voltage, mV (0 = no second curve)
//      521     2  second curve PWM at 1 g, us
//      523   499  second curve steps
//     1022     2  CRC-16/CCITT-FALSE of bytes 0..1021 (little endian)
//
// Serialization is byte by byte through a Storage type with static
//   uint8_t readByte(uint16_t addr);  void updateByte(uint16_t addr, uint8_t value);
// (hal::Eeprom on the board, a RAM array in tests and host tools). Never memcpy structs.
// Decoding never yields garbage: erased, wrong version, bad CRC or implausible content all
// decode as "not calibrated" (out.clear()) with the reason in the status; for implausible
// content the rule that failed (thrustcal/plausibility.hpp) in the optional `why`.
#pragma once
#include <stdint.h>

#include "thrustcal/crc16.hpp"
#include "thrustcal/motor_calibration.hpp"
#include "thrustcal/plausibility.hpp"

namespace tc {

constexpr uint8_t kLayoutVersion1 = 1;
constexpr uint16_t kRecordBytes = 1024;
constexpr uint8_t kMotorSlots = 4;
constexpr uint16_t kRecordCrcOffset = kRecordBytes - 2;
constexpr int16_t kSagUnitMv = 10;
// What a decoded record may hold (anything else is kBadContent): thrustcal/record_limits.hpp.

// Where each curve's steps lie in a v1 record (the layout above): read_run reads them from the
// EEPROM on demand (thesis_runtime.hpp).
constexpr uint16_t kRecordFirstStepsOffset = 5;
constexpr uint16_t kRecordSecondStepsOffset = kRecordFirstStepsOffset + (kCurveGrams - 1) + 2 +
                                              kSagBins + 2 + 2;
static_assert(kRecordSecondStepsOffset == 523, "layout table and offsets disagree");
static_assert(kRecordSecondStepsOffset + (kCurveGrams - 1) + 2 == kRecordBytes,
              "the second curve's steps end at the CRC");

inline uint16_t slotAddress(uint8_t slot) { return static_cast<uint16_t>(slot) * kRecordBytes; }

enum class DecodeStatus : uint8_t {
  kOk = 0,
  kErased,      // version byte 0xFF: never written
  kBadVersion,  // a layout this firmware does not know
  kBadCrc,      // corrupt: power lost while writing, worn cell, foreign data
  kBadContent,  // CRC fine but values impossible (voltage, PWM, steps)
};

// Short human text for a status ("ok", "erased", ...). Never null.
const char* decodeStatusText(DecodeStatus status);

namespace codec_detail {

// Checks the decoded fields (tc::checkCalibration: voltages, PWMs, flat curves, step
// sequences, sag) and finalizes the curves: kOk or kBadContent, the broken rule in `why`
// (may be null). An absent second curve (start_mv 0) is cleared whatever its other bytes hold.
DecodeStatus validate(MotorCalibration& cal, const RecordLimits& limits, Plausibility* why);
// Sag offset in mV -> stored byte: nearest multiple of kSagUnitMv, saturated to int8.
int8_t sagToByte(int16_t offset_mv);

template <class Storage>
struct Writer {
  uint16_t addr;
  uint16_t crc;
  void u8(uint8_t v) {
    Storage::updateByte(addr++, v);
    crc = crc16Update(crc, v);
  }
  void u16(uint16_t v) {
    u8(static_cast<uint8_t>(v & 0xFF));
    u8(static_cast<uint8_t>(v >> 8));
  }
};

template <class Storage>
struct Reader {
  uint16_t addr;
  uint16_t crc;
  uint8_t u8() {
    uint8_t v = Storage::readByte(addr++);
    crc = crc16Update(crc, v);
    return v;
  }
  uint16_t u16() {
    uint16_t lo = u8();
    return static_cast<uint16_t>(lo | (static_cast<uint16_t>(u8()) << 8));
  }
};

}  // namespace codec_detail

template <class Storage>
void writeRecord(uint8_t slot, const MotorCalibration& cal) {
  codec_detail::Writer<Storage> w{slotAddress(slot), 0xFFFF};
  w.u8(kLayoutVersion1);
  w.u16(cal.first.start_mv);
  w.u16(cal.first.pwm_at_1g_us);
  for (uint16_t i = 0; i < cal.first.stepCount(); ++i) w.u8(cal.first.steps()[i]);
  w.u16(cal.sag.base_pwm_us);
  for (uint8_t i = 0; i < kSagBins; ++i)
    w.u8(static_cast<uint8_t>(codec_detail::sagToByte(cal.sag.offset_mv[i])));
  // An absent second curve is written as start 0, PWM 0, steps kUnreachable: no stale bytes.
  const bool second = cal.hasSecondCurve();
  w.u16(second ? cal.second.start_mv : 0);
  w.u16(second ? cal.second.pwm_at_1g_us : 0);
  for (uint16_t i = 0; i < cal.second.stepCount(); ++i)
    w.u8(second ? cal.second.steps()[i] : kUnreachable);
  const uint16_t crc = w.crc;
  w.u16(crc);
}

// Decodes the v1 record of `slot` into `out` (cleared unless kOk). `limits`: the board's
// battery monitor (voltages above its full scale are implausible); `why` (may be null): the
// plausibility rule a kBadContent record broke.
template <class Storage>
DecodeStatus readRecord(uint8_t slot, MotorCalibration& out,
                        const RecordLimits& limits = RecordLimits(), Plausibility* why = nullptr) {
  codec_detail::Reader<Storage> r{slotAddress(slot), 0xFFFF};
  out.clear();
  if (why) *why = Plausibility();
  const uint8_t version = r.u8();
  if (version == 0xFF) return DecodeStatus::kErased;
  if (version != kLayoutVersion1) return DecodeStatus::kBadVersion;
  out.first.start_mv = r.u16();
  out.first.pwm_at_1g_us = r.u16();
  for (uint16_t i = 0; i < out.first.stepCount(); ++i) out.first.steps()[i] = r.u8();
  out.sag.base_pwm_us = r.u16();
  for (uint8_t i = 0; i < kSagBins; ++i)
    out.sag.offset_mv[i] = static_cast<int16_t>(static_cast<int8_t>(r.u8()) * kSagUnitMv);
  out.second.start_mv = r.u16();
  out.second.pwm_at_1g_us = r.u16();
  for (uint16_t i = 0; i < out.second.stepCount(); ++i) out.second.steps()[i] = r.u8();
  const uint16_t computed = r.crc;
  const uint16_t stored = r.u16();
  if (stored != computed) {
    out.clear();
    return DecodeStatus::kBadCrc;
  }
  const DecodeStatus status = codec_detail::validate(out, limits, why);
  if (status != DecodeStatus::kOk) out.clear();
  return status;
}

// True when the slot's version byte says v1 and its CRC matches: the bytes of a complete v1
// record (its content is readRecord's question). Streams the slot, no buffer.
template <class Storage>
bool recordCrcOk(uint8_t slot) {
  codec_detail::Reader<Storage> r{slotAddress(slot), 0xFFFF};
  if (r.u8() != kLayoutVersion1) return false;
  for (uint16_t i = 1; i < kRecordCrcOffset; ++i) r.u8();
  const uint16_t computed = r.crc;
  return r.u16() == computed;
}

// Marks a slot as not calibrated (version byte 0xFF; only that byte is written).
template <class Storage>
void eraseRecord(uint8_t slot) {
  Storage::updateByte(slotAddress(slot), 0xFF);
}

}  // namespace tc
