// EEPROM record for model v2 (layout version 2), power-fail-safe, and the slot loader that
// tells a v1 (thesis) record from a v2 one.
//
// Each motor slot (tc::slotAddress: 1024 bytes at 0/1024/2048/3072) holds TWO copies of the
// v2 record: copy A at slot*1024, copy B at slot*1024 + 512. Layout of one copy (115 bytes,
// little endian):
//
//   offset  size  field
//        0     1  layout version (2); 0xFF = erased
//        1     1  magic 0x5C (a v1 record's bytes here are a curve step: tells them apart);
//                 a spare copy kept in another slot (below) has 0xC0 + owner slot instead
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
// With the motor's dynamics (flags bit 1, gather_store's `dyn`; thrustcal/dynamics.hpp) the
// copy is 128 bytes, the whole of its 128-byte position, and the CRC moves behind them:
//
//      113     1  operating points measured (1..8)
//      114     2  lightest point, decigrams
//      116     2  heaviest point, decigrams
//      118     2  spin-up time constant at the lightest point, 0.1 ms
//      120     2  ... at the heaviest
//      122     2  spin-down time constant at the lightest point, 0.1 ms
//      124     2  ... at the heaviest
//      126     2  CRC-16/CCITT-FALSE of bytes 0..125
//
// A record without dynamics is byte for byte the 115-byte layout above. The flags byte says
// where the CRC is; a damaged flags byte fails the CRC either way.
//
// Power-fail safety, v2 -> v2: a write goes to the copy that is NOT the newest valid one,
// with the newest sequence + 1, in this order: body (offsets 0-1, 4-112), then the sequence
// (2-3), then the CRC (113-114). Until the last CRC byte lands, the copy being written either
// fails its CRC or (CRC-16 collision, 1 in 65536) still carries its old, older sequence: the
// newest valid copy, untouched, keeps winning. A power loss at any byte therefore leaves the
// old or the new calibration, never none and never a mix.
//
// Spare copies (v1 <-> v2 switches, thrustcal/eeprom_store.hpp): a v1 record fills its whole
// slot and its CRC covers every byte, so nothing can be written into a v1 slot without
// destroying it. A switch therefore first writes a SPARE copy of the v2 model into another
// slot that does not hold a v1 record (a "host": erased or v2), at host offset
// 128 * (j + 1), j = (host - owner - 1) mod 4 (0..2: one position per owner, between copy A
// and copy B), with magic 0xC0 + owner. The loader reads an owner's own copies A and B and its
// spare copies in every host, and flies the newest valid one (a tie goes to the own copy).
// A valid v2 copy, own or spare, wins over a v1 record: during a v1 -> v2 switch the spare
// takes over from the v1 record as soon as it is complete, and during a v2 -> v1 switch the
// old model's spare keeps flying until the v1 record is complete and the spare is erased.
//
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
constexpr uint8_t kRecordV2SpareMagic = 0xC0;  // | owner slot: a spare copy in another slot
constexpr uint16_t kRecordV2Bytes = 115;     // without dynamics
constexpr uint16_t kRecordV2DynBytes = 128;  // with the motor's dynamics (flags kV2HasDynamics)
constexpr uint16_t kRecordV2MaxBytes = kRecordV2DynBytes;
constexpr uint16_t kRecordV2CopyOffset = 512;  // copy B, from the slot start
constexpr uint16_t kRecordV2SpareOffset = 128; // spare position j at 128 * (j + 1), j = 0..2
constexpr uint16_t kRecordV2SeqOffset = 2;
constexpr uint16_t kRecordV2CrcOffset = kRecordV2Bytes - 2;
constexpr uint8_t kNoCopy = 0xFF;
constexpr uint8_t kNoSlot = 0xFF;
// Copies the loader looks at per owner: own A (0), own B (1), spares in the other three
// slots (2..4: copy 2 + j lives in host (owner + 1 + j) mod 4).
constexpr uint8_t kV2Copies = 5;
static_assert(kRecordV2MaxBytes <= 256, "a v2 record must fit in 256 bytes");
static_assert(kRecordV2MaxBytes <= kRecordV2SpareOffset, "copy A must end before the spares");
static_assert(kRecordV2SpareOffset * 3 + kRecordV2MaxBytes <= kRecordV2CopyOffset,
              "the spares must end before copy B");
static_assert(kRecordV2CopyOffset + kRecordV2MaxBytes <= 640, "copy B must end before fly's parameters (640)");
static_assert(17 + 3 * kV2MaxKnots + 2 == kRecordV2Bytes, "layout table and size disagree");
static_assert(kMotorSlots == 4, "spare positions assume four slots");

// Bytes of a copy whose flags byte (offset 5) is `flags`: CRC at the length - 2.
inline uint16_t recordV2Length(uint8_t flags) {
  return (flags & kV2HasDynamics) ? kRecordV2DynBytes : kRecordV2Bytes;
}

inline uint16_t copyAddressV2(uint8_t slot, uint8_t copy) {
  return static_cast<uint16_t>(slotAddress(slot) + (copy ? kRecordV2CopyOffset : 0));
}
inline bool isSpareCopy(uint8_t copy) { return copy >= 2 && copy < kV2Copies; }
// The slot that hosts spare copy `copy` (2..4) of `owner`.
inline uint8_t spareHost(uint8_t owner, uint8_t copy) {
  return static_cast<uint8_t>((owner + copy - 1u) & 3u);
}
// Address of owner's spare position in `host` (host != owner).
inline uint16_t spareAddressV2(uint8_t owner, uint8_t host) {
  const uint8_t j = static_cast<uint8_t>((host - owner - 1u) & 3u);
  return static_cast<uint16_t>(slotAddress(host) + kRecordV2SpareOffset * (j + 1u));
}
inline uint8_t spareMagic(uint8_t owner) { return static_cast<uint8_t>(kRecordV2SpareMagic | owner); }
// True when sequence a was written after b (serial-number arithmetic, wrap-around safe).
inline bool sequenceNewer(uint16_t a, uint16_t b) {
  const uint16_t d = static_cast<uint16_t>(a - b);
  return d != 0 && d < 0x8000u;
}
// A slot that may host spare copies and the board settings: it does not hold a v1 record
// (whose CRC covers the whole slot). Judged by the version byte alone, so a v1 record being
// written (its version byte goes first) already counts as one.
template <class Storage>
bool isHostSlot(uint8_t slot) {
  return Storage::readByte(slotAddress(slot)) != kLayoutVersion1;
}

// Image of one copy (CRC included): recordV2Length(image[5]) bytes, kRecordV2Bytes without
// dynamics, kRecordV2DynBytes with (give kRecordV2MaxBytes of room). The model must be
// finalized. Cannot fail. `magic`: kRecordV2Magic for an own copy, spareMagic(owner) for a spare.
void serializeModelV2(const ModelV2& model, uint16_t sequence, uint8_t* image,
                      uint8_t magic = kRecordV2Magic);
// Decodes one copy's image (recordV2Length(image[5]) bytes are read): kErased (version 0xFF),
// kBadVersion (other version or magic), kBadCrc, kBadContent (the layout or a plausibility rule
// refused it: the rule in `why`, may be null), kOk. `out` is cleared unless kOk.
DecodeStatus parseModelV2(const uint8_t* image, ModelV2& out, uint16_t& sequence,
                          const RecordLimits& limits = RecordLimits(), Plausibility* why = nullptr,
                          uint8_t magic = kRecordV2Magic);

struct RecordV2Read {
  DecodeStatus status = DecodeStatus::kErased;  // kOk, or the most telling own copy's reason
  uint8_t copy = kNoCopy;                       // 0 = A, 1 = B, 2..4 spare: the copy loaded
  uint16_t sequence = 0;
  DecodeStatus copy_status[2] = {DecodeStatus::kErased, DecodeStatus::kErased};
  uint16_t copy_sequence[2] = {0, 0};
  Plausibility why;  // status kBadContent: the rule that copy broke
};

enum class WriteV2Status : uint8_t {
  kWritten = 0,
  kUnchanged,     // the newest valid copy already holds this model: nothing written
  kInvalidModel,  // the model does not finalize (absent or out of range): nothing written
  kVerifyFailed,  // read-back of the copy just written failed: worn EEPROM? old copy kept
  kImplausible,   // the model breaks a plausibility rule (`why`): nothing written
};
const char* writeV2StatusText(WriteV2Status status);

struct RecordV2Write {
  WriteV2Status status = WriteV2Status::kInvalidModel;
  uint8_t copy = kNoCopy;      // copy written
  uint16_t sequence = 0;       // its sequence number
  uint16_t bytes_changed = 0;  // bytes whose value changed (physical writes on the board)
  Plausibility why;            // kImplausible: the rule
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
  Plausibility why;                             // status kBadContent: the rule broken
};

namespace record_v2_detail {

template <class Storage>
DecodeStatus readCopy(uint16_t addr, uint8_t magic, ModelV2& out, uint16_t& sequence,
                      const RecordLimits& limits, Plausibility* why) {
  uint8_t image[kRecordV2MaxBytes];
  const uint16_t length = recordV2Length(Storage::readByte(static_cast<uint16_t>(addr + 5)));
  for (uint16_t i = 0; i < length; ++i) image[i] = Storage::readByte(static_cast<uint16_t>(addr + i));
  return parseModelV2(image, out, sequence, limits, why, magic);
}

// Where copy `copy` of `owner` lives; false for a spare position in a slot that cannot host.
template <class Storage>
bool copyLocation(uint8_t owner, uint8_t copy, uint16_t& addr, uint8_t& magic) {
  if (copy < 2) {
    addr = copyAddressV2(owner, copy);
    magic = kRecordV2Magic;
    return true;
  }
  const uint8_t host = spareHost(owner, copy);
  if (!isHostSlot<Storage>(host)) return false;
  addr = spareAddressV2(owner, host);
  magic = spareMagic(owner);
  return true;
}

template <class Storage>
void put(uint16_t addr, uint8_t value, uint16_t& changed) {
  if (Storage::readByte(addr) != value) ++changed;
  Storage::updateByte(addr, value);
}

// Writes one copy's image in the power-fail-safe order: body (the dynamics included), sequence,
// CRC.
template <class Storage>
void writeImage(uint16_t addr, const uint8_t* image, uint16_t& changed) {
  const uint16_t length = recordV2Length(image[5]);
  const uint16_t crc_at = static_cast<uint16_t>(length - 2);
  for (uint16_t i = 0; i < crc_at; ++i) {
    if (i == kRecordV2SeqOffset || i == kRecordV2SeqOffset + 1) continue;
    put<Storage>(static_cast<uint16_t>(addr + i), image[i], changed);
  }
  for (uint16_t i = kRecordV2SeqOffset; i < kRecordV2SeqOffset + 2; ++i)
    put<Storage>(static_cast<uint16_t>(addr + i), image[i], changed);
  for (uint16_t i = crc_at; i < length; ++i) put<Storage>(static_cast<uint16_t>(addr + i), image[i], changed);
}

// How much a failure reason tells: a copy whose CRC is right but whose content cannot be right
// tells most (it was written so), then a copy that was written and broke, then an erased one.
inline uint8_t weight(DecodeStatus s) {
  switch (s) {
    case DecodeStatus::kBadContent: return 5;
    case DecodeStatus::kBadCrc: return 4;
    case DecodeStatus::kBadVersion: return 2;
    default: return 1;
  }
}

// Checks a model before it is written: finalize (layout) and plausibility.
inline WriteV2Status checkBeforeWrite(ModelV2& model, const RecordLimits& limits, Plausibility& why) {
  why = checkModelV2(model, limits);
  if (!why.ok()) return model.finalize() ? WriteV2Status::kImplausible : WriteV2Status::kInvalidModel;
  return model.finalize() ? WriteV2Status::kWritten : WriteV2Status::kInvalidModel;
}

}  // namespace record_v2_detail

// Loads the newest valid copy of `slot` (own A or B, or a spare in another slot) into `out`
// (cleared when none). A tie in sequence goes to the own copy. `limits`: the board's monitor.
template <class Storage>
RecordV2Read readModelV2(uint8_t slot, ModelV2& out, const RecordLimits& limits = RecordLimits()) {
  RecordV2Read r;
  uint8_t told = record_v2_detail::weight(r.status);
  uint16_t best_seq = 0;
  for (uint8_t c = 0; c < kV2Copies; ++c) {
    uint16_t addr = 0;
    uint8_t magic = 0;
    if (!record_v2_detail::copyLocation<Storage>(slot, c, addr, magic)) continue;
    uint16_t seq = 0;
    Plausibility why;
    const DecodeStatus st = record_v2_detail::readCopy<Storage>(addr, magic, out, seq, limits, &why);
    if (c < 2) {
      r.copy_status[c] = st;
      r.copy_sequence[c] = seq;
      if (st != DecodeStatus::kOk && record_v2_detail::weight(st) > told) {
        told = record_v2_detail::weight(st);
        r.status = st;
        r.why = why;
      }
    }
    if (st == DecodeStatus::kOk && (r.copy == kNoCopy || sequenceNewer(seq, best_seq))) {
      r.copy = c;
      best_seq = seq;
    }
  }
  if (r.copy == kNoCopy) {
    out.clear();
    return r;
  }
  uint16_t addr = 0;
  uint8_t magic = 0;
  record_v2_detail::copyLocation<Storage>(slot, r.copy, addr, magic);
  record_v2_detail::readCopy<Storage>(addr, magic, out, r.sequence, limits, nullptr);
  r.status = DecodeStatus::kOk;
  r.why = Plausibility();
  return r;
}

// Writes `model` into an own copy of `slot`, power-fail-safely against the slot's v2 copies
// (see the top of this file): the own copy that does not hold the newest valid model gets the
// newest sequence + 1. Refuses a model that does not finalize or is implausible. Writing over
// a v1 record destroys it at the first byte: thrustcal/eeprom_store.hpp's storeModelV2 keeps
// it until the model is complete (use that on the board).
template <class Storage>
RecordV2Write writeModelV2(uint8_t slot, const ModelV2& model,
                           const RecordLimits& limits = RecordLimits()) {
  RecordV2Write w;
  uint8_t image[kRecordV2MaxBytes];
  ModelV2 check = model;
  w.status = record_v2_detail::checkBeforeWrite(check, limits, w.why);
  if (w.status != WriteV2Status::kWritten) return w;
  serializeModelV2(check, 0, image);
  ModelV2 scratch;
  const RecordV2Read now = readModelV2<Storage>(slot, scratch, limits);
  if (now.copy == 0 || now.copy == 1) {
    // Same model already newest? Compare everything but the sequence and the CRC.
    const uint16_t base = copyAddressV2(slot, now.copy);
    const uint16_t crc_at = static_cast<uint16_t>(recordV2Length(image[5]) - 2);
    bool same = Storage::readByte(static_cast<uint16_t>(base + 5)) == image[5];
    for (uint16_t i = 0; same && i < crc_at; ++i) {
      if (i == kRecordV2SeqOffset || i == kRecordV2SeqOffset + 1) continue;
      same = Storage::readByte(static_cast<uint16_t>(base + i)) == image[i];
    }
    if (same) {
      w.status = WriteV2Status::kUnchanged;
      w.copy = now.copy;
      w.sequence = now.sequence;
      return w;
    }
    w.copy = static_cast<uint8_t>(now.copy ^ 1);
  } else if (now.copy == kNoCopy || now.copy_status[0] != DecodeStatus::kOk) {
    w.copy = 0;  // nothing valid, or a spare is newest: an invalid own copy first
  } else if (now.copy_status[1] != DecodeStatus::kOk) {
    w.copy = 1;
  } else {
    w.copy = sequenceNewer(now.copy_sequence[0], now.copy_sequence[1]) ? 1 : 0;  // the older
  }
  w.sequence = now.copy == kNoCopy ? 1 : static_cast<uint16_t>(now.sequence + 1);
  serializeModelV2(check, w.sequence, image);
  const uint16_t addr = copyAddressV2(slot, w.copy);
  record_v2_detail::writeImage<Storage>(addr, image, w.bytes_changed);
  uint16_t seq = 0;
  const DecodeStatus verify =
      record_v2_detail::readCopy<Storage>(addr, kRecordV2Magic, scratch, seq, limits, nullptr);
  w.status = (verify == DecodeStatus::kOk && seq == w.sequence) ? WriteV2Status::kWritten
                                                                : WriteV2Status::kVerifyFailed;
  return w;
}

// Marks both own copies erased (their version bytes 0xFF), the one that does not hold the
// newest model first, so a cut in between leaves the newest model, not an older one. A v1
// record in the slot is erased too (its version byte is copy A's). Spare copies are
// eeprom_store.hpp's business (eraseSlot).
template <class Storage>
void eraseModelV2(uint8_t slot, const RecordLimits& limits = RecordLimits()) {
  ModelV2 scratch;
  const RecordV2Read now = readModelV2<Storage>(slot, scratch, limits);
  const uint8_t last = now.copy == 1 ? 1 : 0;
  Storage::updateByte(copyAddressV2(slot, static_cast<uint8_t>(last ^ 1)), 0xFF);
  Storage::updateByte(copyAddressV2(slot, last), 0xFF);
}

// Which layout a slot holds, without decoding a v1 record: kModelV2 when a v2 copy (own or
// spare) is valid or an own copy carries the v2 version byte, kThesisV1 when offset 0 holds
// version 1, else kNone.
template <class Storage>
SlotLayout probeSlotLayout(uint8_t slot, const RecordLimits& limits = RecordLimits()) {
  ModelV2 scratch;
  const RecordV2Read r = readModelV2<Storage>(slot, scratch, limits);
  if (r.copy != kNoCopy) return SlotLayout::kModelV2;
  if (Storage::readByte(slotAddress(slot)) == kLayoutVersion1) return SlotLayout::kThesisV1;
  if (Storage::readByte(copyAddressV2(slot, 0)) == kLayoutVersion2 ||
      Storage::readByte(copyAddressV2(slot, 1)) == kLayoutVersion2)
    return SlotLayout::kModelV2;
  return SlotLayout::kNone;
}

// Loads whatever the slot holds: a valid v2 copy (own or spare) wins (into v2, v1 cleared);
// else a v1 record (into v1, v2 cleared) with its decode status; else kNone (both cleared)
// with the reason. read_run flies `v2` when layout == kModelV2 && status == kOk, `v1` when
// layout == kThesisV1 && status == kOk, and refuses to arm otherwise (printing `why` for
// kBadContent). `limits`: the board's battery monitor.
template <class Storage>
SlotLoad loadSlot(uint8_t slot, ModelV2& v2, MotorCalibration& v1,
                  const RecordLimits& limits = RecordLimits()) {
  SlotLoad load;
  load.v2 = readModelV2<Storage>(slot, v2, limits);
  if (load.v2.status == DecodeStatus::kOk) {
    v1.clear();
    load.layout = SlotLayout::kModelV2;
    load.status = DecodeStatus::kOk;
    return load;
  }
  if (Storage::readByte(slotAddress(slot)) == kLayoutVersion1) {
    load.layout = SlotLayout::kThesisV1;
    load.status = readRecord<Storage>(slot, v1, limits, &load.why);
    return load;
  }
  v1.clear();
  const bool v2_marked = Storage::readByte(copyAddressV2(slot, 0)) == kLayoutVersion2 ||
                         Storage::readByte(copyAddressV2(slot, 1)) == kLayoutVersion2;
  load.layout = v2_marked ? SlotLayout::kModelV2 : SlotLayout::kNone;
  load.status = load.v2.status;
  load.why = load.v2.why;
  return load;
}

}  // namespace tc
