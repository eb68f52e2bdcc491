// EEPROM record for model v2 (layout version 2), power-fail-safe, and the slot loader that
// tells a v1 (thesis) record from a v2 one.
//
// Each motor slot (tc::slotAddress: 1024 bytes at 0/1024/2048/3072) holds TWO copies of the
// v2 record: copy A at slot*1024, copy B at slot*1024 + 512. Layout of one copy (115 bytes,
// little endian):
//
//   offset  size  field
//        0     1  layout version (2); 0xFF = erased
//        1     1  magic 0x5C (a v1 record's bytes here are a curve step: tells them apart)
//        2     2  sequence number (wrap-around safe: newer if (uint16_t)(a - b) in 1..32767)
//        4     1  knots used (2..32)
//        5     1  flags (bit 0: refined by a second sweep)
//        6     2  ESC start threshold, 1/16 us
//        8     2  force step between the fine knots, decigrams
//       10     2  resting monitor reading of the sweep, mV
//       12     2  resting reading of the second sweep, mV (0 = none)
//       14     1  fine knots (1..knots)
//       15     2  force step between the coarse knots above them, decigrams (0 = none)
//       17    64  drive at each knot, 512 us*mV units (unused knots 0)
//       81    32  monitor sag at each knot, 10 mV units (unused knots 0)
//      113     2  CRC-16/CCITT-FALSE of bytes 0..112
//
// Power-fail safety: a write goes to the copy that is NOT the newest valid one, with the
// newest sequence + 1, in this order: body (offsets 0-1, 4-112), then the sequence (2-3),
// then the CRC (113-114). Until the last CRC byte lands, the copy being written either fails
// its CRC or (CRC-16 collision, 1 in 65536) still carries its old, older sequence: the newest
// valid copy, untouched, keeps winning. A power loss at any byte therefore leaves the old
// or the new calibration, never none and never a mix. Exception, by construction: the first
// v2 write into a slot that holds a v1 record destroys the v1 record (its CRC covers the
// whole slot), so a cut there leaves the slot uncalibrated.
// Writes skip bytes that already hold the value (Storage::updateByte does on the board; the
// writer also counts the bytes that change), and writing the model the newest copy already
// holds writes nothing.
//
// Storage: a type with static  uint8_t readByte(uint16_t addr);
//                              void updateByte(uint16_t addr, uint8_t value);
// exactly as eeprom_codec.hpp (hal::Eeprom on the board, RAM arrays in tests).
#pragma once
#include <stdint.h>

#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/motor_calibration.hpp"

namespace tc {

constexpr uint8_t kLayoutVersion2 = 2;
constexpr uint8_t kRecordV2Magic = 0x5C;
constexpr uint16_t kRecordV2Bytes = 115;
constexpr uint16_t kRecordV2CopyOffset = 512;  // copy B, from the slot start
constexpr uint16_t kRecordV2SeqOffset = 2;
constexpr uint16_t kRecordV2CrcOffset = kRecordV2Bytes - 2;
constexpr uint8_t kNoCopy = 0xFF;
static_assert(kRecordV2Bytes <= 256, "a v2 record must fit in 256 bytes");
static_assert(kRecordV2Bytes <= kRecordV2CopyOffset, "copy A must end before copy B");
static_assert(kRecordV2CopyOffset + kRecordV2Bytes <= kRecordBytes, "copy B must fit the slot");
static_assert(17 + 3 * kV2MaxKnots + 2 == kRecordV2Bytes, "layout table and size disagree");

inline uint16_t copyAddressV2(uint8_t slot, uint8_t copy) {
  return static_cast<uint16_t>(slotAddress(slot) + (copy ? kRecordV2CopyOffset : 0));
}
// True when sequence a was written after b (serial-number arithmetic, wrap-around safe).
inline bool sequenceNewer(uint16_t a, uint16_t b) {
  const uint16_t d = static_cast<uint16_t>(a - b);
  return d != 0 && d < 0x8000u;
}

// Image of one copy (CRC included). The model must be finalized. Cannot fail.
void serializeModelV2(const ModelV2& model, uint16_t sequence, uint8_t* image);
// Decodes one copy's image: kErased (version 0xFF), kBadVersion (other version or magic),
// kBadCrc, kBadContent (ModelV2::finalize refused it), kOk. `out` is cleared unless kOk.
DecodeStatus parseModelV2(const uint8_t* image, ModelV2& out, uint16_t& sequence);

struct RecordV2Read {
  DecodeStatus status = DecodeStatus::kErased;  // kOk, or the most telling copy's reason
  uint8_t copy = kNoCopy;                       // 0 = A, 1 = B: the copy that was loaded
  uint16_t sequence = 0;
  DecodeStatus copy_status[2] = {DecodeStatus::kErased, DecodeStatus::kErased};
  uint16_t copy_sequence[2] = {0, 0};
};

enum class WriteV2Status : uint8_t {
  kWritten = 0,
  kUnchanged,     // the newest valid copy already holds this model: nothing written
  kInvalidModel,  // the model does not finalize (absent or out of range): nothing written
  kVerifyFailed,  // read-back of the copy just written failed: worn EEPROM? old copy kept
};
const char* writeV2StatusText(WriteV2Status status);

struct RecordV2Write {
  WriteV2Status status = WriteV2Status::kInvalidModel;
  uint8_t copy = kNoCopy;      // copy written
  uint16_t sequence = 0;       // its sequence number
  uint16_t bytes_changed = 0;  // bytes whose value changed (physical writes on the board)
};

enum class SlotLayout : uint8_t {
  kNone = 0,      // erased or unknown: not calibrated
  kThesisV1 = 1,  // the thesis record (eeprom_codec.hpp); status says whether it decoded
  kModelV2 = 2,   // a v2 record; status says whether a copy decoded
};
const char* slotLayoutText(SlotLayout layout);

struct SlotLoad {
  SlotLayout layout = SlotLayout::kNone;
  DecodeStatus status = DecodeStatus::kErased;  // kOk: the model of `layout` is loaded
  RecordV2Read v2;                              // details of the v2 copies
};

namespace record_v2_detail {

template <class Storage>
DecodeStatus readCopy(uint16_t addr, ModelV2& out, uint16_t& sequence) {
  uint8_t image[kRecordV2Bytes];
  for (uint16_t i = 0; i < kRecordV2Bytes; ++i)
    image[i] = Storage::readByte(static_cast<uint16_t>(addr + i));
  return parseModelV2(image, out, sequence);
}

template <class Storage>
void put(uint16_t addr, uint8_t value, uint16_t& changed) {
  if (Storage::readByte(addr) != value) ++changed;
  Storage::updateByte(addr, value);
}

// How much a failure reason tells: a copy that was written and broke tells more than an
// erased one.
inline uint8_t weight(DecodeStatus s) {
  switch (s) {
    case DecodeStatus::kBadCrc: return 4;
    case DecodeStatus::kBadContent: return 3;
    case DecodeStatus::kBadVersion: return 2;
    default: return 1;
  }
}

}  // namespace record_v2_detail

// Loads the newest valid copy of `slot` into `out` (cleared when none).
template <class Storage>
RecordV2Read readModelV2(uint8_t slot, ModelV2& out) {
  RecordV2Read r;
  ModelV2 other;
  r.copy_status[0] = record_v2_detail::readCopy<Storage>(copyAddressV2(slot, 0), out,
                                                         r.copy_sequence[0]);
  r.copy_status[1] = record_v2_detail::readCopy<Storage>(copyAddressV2(slot, 1), other,
                                                         r.copy_sequence[1]);
  const bool a_ok = r.copy_status[0] == DecodeStatus::kOk;
  const bool b_ok = r.copy_status[1] == DecodeStatus::kOk;
  if (b_ok && (!a_ok || sequenceNewer(r.copy_sequence[1], r.copy_sequence[0]))) {
    out = other;
    r.copy = 1;
  } else if (a_ok) {
    r.copy = 0;
  }
  if (r.copy != kNoCopy) {
    r.status = DecodeStatus::kOk;
    r.sequence = r.copy_sequence[r.copy];
    return r;
  }
  out.clear();
  r.status = record_v2_detail::weight(r.copy_status[1]) > record_v2_detail::weight(r.copy_status[0])
                 ? r.copy_status[1]
                 : r.copy_status[0];
  return r;
}

// Writes `model` into `slot` power-fail-safely (see the top of this file).
template <class Storage>
RecordV2Write writeModelV2(uint8_t slot, const ModelV2& model) {
  RecordV2Write w;
  uint8_t image[kRecordV2Bytes];
  ModelV2 check = model;
  if (!check.finalize()) return w;  // kInvalidModel
  serializeModelV2(check, 0, image);
  ModelV2 scratch;
  const RecordV2Read now = readModelV2<Storage>(slot, scratch);
  if (now.copy != kNoCopy) {
    // Same model already newest? Compare everything but the sequence and the CRC.
    const uint16_t base = copyAddressV2(slot, now.copy);
    bool same = true;
    for (uint16_t i = 0; same && i < kRecordV2CrcOffset; ++i) {
      if (i == kRecordV2SeqOffset || i == kRecordV2SeqOffset + 1) continue;
      same = Storage::readByte(static_cast<uint16_t>(base + i)) == image[i];
    }
    if (same) {
      w.status = WriteV2Status::kUnchanged;
      w.copy = now.copy;
      w.sequence = now.sequence;
      return w;
    }
  }
  w.copy = now.copy == kNoCopy ? 0 : static_cast<uint8_t>(now.copy ^ 1);
  w.sequence = now.copy == kNoCopy ? 1 : static_cast<uint16_t>(now.sequence + 1);
  serializeModelV2(check, w.sequence, image);
  const uint16_t addr = copyAddressV2(slot, w.copy);
  for (uint16_t i = 0; i < kRecordV2CrcOffset; ++i) {
    if (i == kRecordV2SeqOffset || i == kRecordV2SeqOffset + 1) continue;
    record_v2_detail::put<Storage>(static_cast<uint16_t>(addr + i), image[i], w.bytes_changed);
  }
  for (uint16_t i = kRecordV2SeqOffset; i < kRecordV2SeqOffset + 2; ++i)
    record_v2_detail::put<Storage>(static_cast<uint16_t>(addr + i), image[i], w.bytes_changed);
  for (uint16_t i = kRecordV2CrcOffset; i < kRecordV2Bytes; ++i)
    record_v2_detail::put<Storage>(static_cast<uint16_t>(addr + i), image[i], w.bytes_changed);
  uint16_t seq = 0;
  const DecodeStatus verify = record_v2_detail::readCopy<Storage>(addr, scratch, seq);
  w.status = (verify == DecodeStatus::kOk && seq == w.sequence) ? WriteV2Status::kWritten
                                                                : WriteV2Status::kVerifyFailed;
  return w;
}

// Marks both copies erased (their version bytes 0xFF; copy B first). A v1 record in the slot
// is erased too (its version byte is copy A's). Note: eraseRecord() of eeprom_codec.hpp
// clears only offset 0 and would leave copy B loadable: use this for slots that may hold v2.
template <class Storage>
void eraseModelV2(uint8_t slot) {
  Storage::updateByte(copyAddressV2(slot, 1), 0xFF);
  Storage::updateByte(copyAddressV2(slot, 0), 0xFF);
}

// Which layout a slot holds, without decoding a v1 record: kModelV2 when a v2 copy is valid
// or carries the v2 version byte, kThesisV1 when offset 0 holds version 1, else kNone.
template <class Storage>
SlotLayout probeSlotLayout(uint8_t slot) {
  ModelV2 scratch;
  const RecordV2Read r = readModelV2<Storage>(slot, scratch);
  if (r.copy != kNoCopy) return SlotLayout::kModelV2;
  if (Storage::readByte(slotAddress(slot)) == kLayoutVersion1) return SlotLayout::kThesisV1;
  if (Storage::readByte(copyAddressV2(slot, 0)) == kLayoutVersion2 ||
      Storage::readByte(copyAddressV2(slot, 1)) == kLayoutVersion2)
    return SlotLayout::kModelV2;
  return SlotLayout::kNone;
}

// Loads whatever the slot holds: a valid v2 copy wins (into v2, v1 cleared); else a v1
// record (into v1, v2 cleared) with its decode status; else kNone (both cleared) with the
// reason. read_run flies `v2` when layout == kModelV2 && status == kOk, `v1` when
// layout == kThesisV1 && status == kOk, and refuses to arm otherwise.
template <class Storage>
SlotLoad loadSlot(uint8_t slot, ModelV2& v2, MotorCalibration& v1) {
  SlotLoad load;
  load.v2 = readModelV2<Storage>(slot, v2);
  if (load.v2.status == DecodeStatus::kOk) {
    v1.clear();
    load.layout = SlotLayout::kModelV2;
    load.status = DecodeStatus::kOk;
    return load;
  }
  if (Storage::readByte(slotAddress(slot)) == kLayoutVersion1) {
    load.layout = SlotLayout::kThesisV1;
    load.status = readRecord<Storage>(slot, v1);
    return load;
  }
  v1.clear();
  const bool v2_marked = Storage::readByte(copyAddressV2(slot, 0)) == kLayoutVersion2 ||
                         Storage::readByte(copyAddressV2(slot, 1)) == kLayoutVersion2;
  load.layout = v2_marked ? SlotLayout::kModelV2 : SlotLayout::kNone;
  load.status = load.v2.status;
  return load;
}

}  // namespace tc
