// v2 record image <-> ModelV2 (layout table in record_v2.hpp). Byte by byte, little endian,
// never a memcpy of the struct: the AVR and the host agree by construction.
#include "thrustcal/record_v2.hpp"

namespace tc {

namespace {

void putU16(uint8_t* p, uint16_t v) {
  p[0] = static_cast<uint8_t>(v & 0xFF);
  p[1] = static_cast<uint8_t>(v >> 8);
}

uint16_t getU16(const uint8_t* p) {
  return static_cast<uint16_t>(p[0] | (static_cast<uint16_t>(p[1]) << 8));
}

constexpr uint16_t kFineKnotsOffset = 14;
constexpr uint16_t kCoarseStepOffset = 15;
constexpr uint16_t kDriveOffset = 17;
constexpr uint16_t kSagOffset = kDriveOffset + 2 * kV2MaxKnots;
static_assert(kSagOffset + kV2MaxKnots == kRecordV2CrcOffset, "layout table and code disagree");
constexpr uint16_t kDynOffset = kRecordV2CrcOffset;  // the dynamics take the CRC's place
static_assert(kDynOffset + 13 + 2 == kRecordV2DynBytes, "dynamics layout and size disagree");

}  // namespace

void serializeModelV2(const ModelV2& model, uint16_t sequence, uint8_t* image, uint8_t magic) {
  image[0] = kLayoutVersion2;
  image[1] = magic;
  putU16(image + kRecordV2SeqOffset, sequence);
  image[4] = model.knots;
  image[5] = model.flags;
  putU16(image + 6, model.start_q4_us);
  putU16(image + 8, model.step_dg);
  putU16(image + 10, model.rest_mv);
  putU16(image + 12, model.second_mv);
  image[kFineKnotsOffset] = model.fine_knots;
  putU16(image + kCoarseStepOffset, model.coarse_step_dg);
  for (uint8_t k = 0; k < kV2MaxKnots; ++k) {
    const bool used = k < model.knots;
    putU16(image + kDriveOffset + 2 * k, used ? model.drive_512usmv[k] : 0);
    image[kSagOffset + k] = used ? model.sag_10mv[k] : 0;
  }
  const MotorDynamics& d = model.dynamics;
  image[5] = static_cast<uint8_t>((model.flags & ~kV2HasDynamics) | (d.isPresent() ? kV2HasDynamics : 0));
  if (d.isPresent()) {
    image[kDynOffset] = d.points;
    putU16(image + kDynOffset + 1, d.lo_dg);
    putU16(image + kDynOffset + 3, d.hi_dg);
    putU16(image + kDynOffset + 5, d.up_lo_01ms);
    putU16(image + kDynOffset + 7, d.up_hi_01ms);
    putU16(image + kDynOffset + 9, d.down_lo_01ms);
    putU16(image + kDynOffset + 11, d.down_hi_01ms);
  }
  const uint16_t crc_at = static_cast<uint16_t>(recordV2Length(image[5]) - 2);
  putU16(image + crc_at, crc16CcittFalse(image, crc_at));
}

DecodeStatus parseModelV2(const uint8_t* image, ModelV2& out, uint16_t& sequence,
                          const RecordLimits& limits, Plausibility* why, uint8_t magic) {
  out.clear();
  sequence = 0;
  if (why) *why = Plausibility();
  if (image[0] == 0xFF) return DecodeStatus::kErased;
  if (image[0] != kLayoutVersion2 || image[1] != magic) return DecodeStatus::kBadVersion;
  const uint16_t crc_at = static_cast<uint16_t>(recordV2Length(image[5]) - 2);
  if (crc16CcittFalse(image, crc_at) != getU16(image + crc_at)) return DecodeStatus::kBadCrc;
  ModelV2 m;
  m.knots = image[4];
  m.flags = static_cast<uint8_t>(image[5] & ~kV2HasDynamics);
  if (image[5] & kV2HasDynamics) {
    MotorDynamics& d = m.dynamics;
    d.points = image[kDynOffset];
    d.lo_dg = getU16(image + kDynOffset + 1);
    d.hi_dg = getU16(image + kDynOffset + 3);
    d.up_lo_01ms = getU16(image + kDynOffset + 5);
    d.up_hi_01ms = getU16(image + kDynOffset + 7);
    d.down_lo_01ms = getU16(image + kDynOffset + 9);
    d.down_hi_01ms = getU16(image + kDynOffset + 11);
    if (!d.isPresent()) {  // the flag without points: not what the writer makes
      if (why) why->rule = Implausible::kMalformed;
      return DecodeStatus::kBadContent;
    }
  }
  m.start_q4_us = getU16(image + 6);
  m.step_dg = getU16(image + 8);
  m.rest_mv = getU16(image + 10);
  m.second_mv = getU16(image + 12);
  m.fine_knots = image[kFineKnotsOffset];
  m.coarse_step_dg = getU16(image + kCoarseStepOffset);
  for (uint8_t k = 0; k < kV2MaxKnots; ++k) {
    m.drive_512usmv[k] = getU16(image + kDriveOffset + 2 * k);
    m.sag_10mv[k] = image[kSagOffset + k];
  }
  const Plausibility p = checkModelV2(m, limits);
  if (!p.ok() || !m.finalize()) {
    if (why) {
      *why = p;
      if (p.ok()) why->rule = Implausible::kMalformed;
    }
    return DecodeStatus::kBadContent;
  }
  out = m;
  sequence = getU16(image + kRecordV2SeqOffset);
  return DecodeStatus::kOk;
}

const char* writeV2StatusText(WriteV2Status status) {
  switch (status) {
    case WriteV2Status::kWritten: return "written";
    case WriteV2Status::kUnchanged: return "unchanged (already stored)";
    case WriteV2Status::kInvalidModel: return "invalid model: nothing written (fit it again)";
    case WriteV2Status::kVerifyFailed:
      return "read-back failed: EEPROM worn? the previous calibration is kept";
    case WriteV2Status::kImplausible:
      return "implausible model: nothing written (it breaks a plausibility rule)";
  }
  return "unknown";
}

const char* slotLayoutText(SlotLayout layout) {
  switch (layout) {
    case SlotLayout::kNone: return "none";
    case SlotLayout::kThesisV1: return "v1 (thesis)";
    case SlotLayout::kModelV2: return "v2";
  }
  return "unknown";
}

}  // namespace tc
