// Power-fail-safe stores across the whole EEPROM: switching a slot between the thesis record
// (v1) and model v2, erasing it, and the recovery that finishes a switch a power cut
// interrupted. gather_store stores through these; read_run never writes a record.
//
// The guarantee (tested by cutting the write after every byte, tests/core_v2 and
// tests/hil_power): after a power loss at any byte of a store, the loader (tc::loadSlot)
// finds the old calibration or the new one, whole; never a mix, never another one.
//
//   v2 -> v2   the own copy that is not newest is written (record_v2.hpp).
//   v1 -> v2   storeModelV2: a v1 record fills its slot and its CRC covers every byte, so the
//              new model goes first into a SPARE copy in a host slot (another slot without a
//              v1 record, record_v2.hpp), which takes over from the v1 record when complete;
//              then into the slot's own copy A (destroying the v1 record; the spare flies
//              meanwhile); then the spare is erased (one byte).
//   v2 -> v1   storeRecordV1: the slot's own copy not holding the newest model is erased, the
//              newest model is copied into a spare, the v1 record is written over the slot
//              (the spare flies meanwhile), checked, and the spare erased: the v1 record takes
//              over with that one byte.
//   v1 -> v1   in place (the thesis layout fills the slot: no room for a second copy). A cut
//              leaves the record corrupt: the motor is "not calibrated", never flown wrong.
//   erase      eraseSlot: the copy not holding the newest model first, the newest last.
// With no host slot (all three other slots hold v1 records) a v1 <-> v2 switch cannot keep
// the old record while writing the new one (there is no free byte in the EEPROM): it is done
// in place and reported as unprotected (StoreReport::unprotected), so the firmware can say
// that a cut leaves the motor not calibrated.
//
// Every store first runs recoverSlots(): a spare that is some owner's newest valid copy (a
// switch cut after the spare was complete) is written into the owner's own copy, and every
// valid spare is erased. So no spare outlives the store that made it, a spare position is
// free before it is used, and a v1 record written over a host destroys no live spare.
#pragma once
#include <stdint.h>

#include "thrustcal/board_settings.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/param_store.hpp"
#include "thrustcal/plausibility.hpp"
#include "thrustcal/record_v2.hpp"

namespace tc {

enum class StoreStatus : uint8_t {
  kStored = 0,
  kUnchanged,        // the slot holds this model already: nothing written
  kInvalid,          // the model does not fit the layout: nothing written
  kImplausible,      // it breaks a plausibility rule (StoreReport::why): nothing written
  kVerifyFailed,     // read-back failed (EEPROM worn?): the previous calibration still loads
  kSettingsNoRoom,   // a v1 record here would erase the only home of a non-default divider
};

struct StoreReport {
  StoreStatus status = StoreStatus::kInvalid;
  uint8_t spare_host = kNoSlot;  // slot that held the spare copy during the switch
  bool unprotected = false;      // a v1 <-> v2 switch without a host slot (see above)
  uint8_t copy = kNoCopy;        // v2: own copy written
  uint16_t sequence = 0;         // v2: its sequence number
  Plausibility why;              // kImplausible: the rule
  ParamsMove params = ParamsMove::kNone;  // v1: a parameter record the slot held (param_store.hpp)
};

namespace store_detail {

// A host slot for owner's spare: the first other slot without a v1 record, else kNoSlot.
template <class Storage>
uint8_t findHost(uint8_t owner) {
  for (uint8_t j = 1; j < kMotorSlots; ++j) {
    const uint8_t h = static_cast<uint8_t>((owner + j) & 3u);
    if (isHostSlot<Storage>(h)) return h;
  }
  return kNoSlot;
}

// Writes `model` (finalized) as owner's spare in `host` with `sequence`; true when it reads back.
template <class Storage>
bool writeSpare(uint8_t owner, uint8_t host, const ModelV2& model, uint16_t sequence,
                const RecordLimits& limits) {
  uint8_t image[kRecordV2MaxBytes];
  serializeModelV2(model, sequence, image, spareMagic(owner));
  const uint16_t addr = spareAddressV2(owner, host);
  uint16_t changed = 0;
  record_v2_detail::writeImage<Storage>(addr, image, changed);
  ModelV2 back;
  uint16_t seq = 0;
  return record_v2_detail::readCopy<Storage>(addr, spareMagic(owner), back, seq, limits, nullptr) ==
             DecodeStatus::kOk &&
         seq == sequence;
}

// Erases every valid spare of `owner` (their version bytes).
template <class Storage>
void eraseSpares(uint8_t owner, const RecordLimits& limits) {
  for (uint8_t c = 2; c < kV2Copies; ++c) {
    uint16_t addr = 0;
    uint8_t magic = 0;
    if (!record_v2_detail::copyLocation<Storage>(owner, c, addr, magic)) continue;
    ModelV2 scratch;
    uint16_t seq = 0;
    if (record_v2_detail::readCopy<Storage>(addr, magic, scratch, seq, limits, nullptr) == DecodeStatus::kOk)
      Storage::updateByte(addr, 0xFF);
  }
}

inline StoreStatus fromWrite(WriteV2Status s) {
  switch (s) {
    case WriteV2Status::kWritten: return StoreStatus::kStored;
    case WriteV2Status::kUnchanged: return StoreStatus::kUnchanged;
    case WriteV2Status::kVerifyFailed: return StoreStatus::kVerifyFailed;
    case WriteV2Status::kImplausible: return StoreStatus::kImplausible;
    default: return StoreStatus::kInvalid;
  }
}

}  // namespace store_detail

// Finishes switches a power cut interrupted (see the top of this file). Safe to cut anywhere
// itself (it only writes an own copy that is not the newest, then erases spares that are not
// the only newest copy), and a no-op (no write) when no valid spare exists.
template <class Storage>
void recoverSlots(const RecordLimits& limits = RecordLimits()) {
  for (uint8_t owner = 0; owner < kMotorSlots; ++owner) {
    ModelV2 m;
    const RecordV2Read now = readModelV2<Storage>(owner, m, limits);
    if (now.copy == kNoCopy) continue;  // no valid copy at all: no valid spare either
    if (isSpareCopy(now.copy)) {
      const WriteV2Status w = writeModelV2<Storage>(owner, m, limits).status;
      if (w != WriteV2Status::kWritten && w != WriteV2Status::kUnchanged) continue;  // keep it
    }
    store_detail::eraseSpares<Storage>(owner, limits);
  }
}

// Stores model v2 into `slot` (any previous content: nothing, v1 or v2), power-fail-safely.
template <class Storage>
StoreReport storeModelV2(uint8_t slot, const ModelV2& model, const RecordLimits& limits = RecordLimits()) {
  StoreReport rep;
  ModelV2 check = model;
  const WriteV2Status ok = record_v2_detail::checkBeforeWrite(check, limits, rep.why);
  if (ok != WriteV2Status::kWritten) {
    rep.status = store_detail::fromWrite(ok);
    return rep;
  }
  recoverSlots<Storage>(limits);
  const uint8_t host = recordCrcOk<Storage>(slot) ? store_detail::findHost<Storage>(slot) : kNoSlot;
  if (host != kNoSlot) {
    // v1 -> v2: spare first (the v1 record stays whole until the spare is complete).
    ModelV2 scratch;
    const RecordV2Read now = readModelV2<Storage>(slot, scratch, limits);
    // One below the own copy's sequence to come (writeModelV2 takes the newest + 1).
    const uint16_t seq = now.copy == kNoCopy ? 0 : now.sequence;
    if (!store_detail::writeSpare<Storage>(slot, host, check, seq, limits)) {
      rep.status = StoreStatus::kVerifyFailed;
      return rep;
    }
    rep.spare_host = host;
  } else {
    rep.unprotected = recordCrcOk<Storage>(slot);  // a v1 record and nowhere to keep it
  }
  const RecordV2Write w = writeModelV2<Storage>(slot, check, limits);
  rep.status = store_detail::fromWrite(w.status);
  rep.copy = w.copy;
  rep.sequence = w.sequence;
  if (w.status == WriteV2Status::kWritten && host != kNoSlot)
    Storage::updateByte(spareAddressV2(slot, host), 0xFF);  // the own copy is complete
  return rep;
}

// Stores the thesis record `cal` into `slot` (nothing, v1 or v2 before), power-fail-safe from
// v2 (see the top of this file). `cal` is checked for plausibility first (and its curves
// finalized). Moves the board settings and a parameter record out of the slot first.
template <class Storage>
StoreReport storeRecordV1(uint8_t slot, MotorCalibration& cal, const RecordLimits& limits = RecordLimits()) {
  StoreReport rep;
  rep.why = checkCalibration(cal, limits);
  if (!rep.why.ok()) {
    rep.status = StoreStatus::kImplausible;
    return rep;
  }
  recoverSlots<Storage>(limits);
  BoardSettings settings;
  const SettingsRead where = readSettings<Storage>(settings);
  if (where.status == DecodeStatus::kOk && where.host == slot) {
    const SettingsWriteStatus moved = writeSettings<Storage>(settings, slot).status;
    if (moved != SettingsWriteStatus::kWritten && moved != SettingsWriteStatus::kUnchanged &&
        !settings.isDefault()) {
      rep.status = StoreStatus::kSettingsNoRoom;
      return rep;
    }
  }
  rep.params = moveParamsOutOf<Storage>(slot);
  ModelV2 old;
  const RecordV2Read now = readModelV2<Storage>(slot, old, limits);
  uint8_t host = kNoSlot;
  if (now.copy == 0 || now.copy == 1) {
    // Only the newest own copy may survive while the v1 record is written over both.
    Storage::updateByte(copyAddressV2(slot, static_cast<uint8_t>(now.copy ^ 1u)), 0xFF);
    host = store_detail::findHost<Storage>(slot);
    if (host == kNoSlot) {
      rep.unprotected = true;
    } else if (!store_detail::writeSpare<Storage>(slot, host, old, now.sequence, limits)) {
      rep.status = StoreStatus::kVerifyFailed;
      return rep;
    }
    rep.spare_host = host;
  }
  writeRecord<Storage>(slot, cal);
  if (!recordCrcOk<Storage>(slot)) {
    rep.status = StoreStatus::kVerifyFailed;  // the spare (if any) keeps the old model flying
    return rep;
  }
  if (host != kNoSlot) Storage::updateByte(spareAddressV2(slot, host), 0xFF);
  rep.status = StoreStatus::kStored;
  return rep;
}

// Marks `slot` not calibrated (v1 record, both own copies, its spares), power-fail-safely:
// after a cut the slot loads its newest model or nothing, never an older model.
template <class Storage>
void eraseSlot(uint8_t slot, const RecordLimits& limits = RecordLimits()) {
  recoverSlots<Storage>(limits);
  eraseModelV2<Storage>(slot, limits);
}

// Stores the board settings (the divider) power-fail-safely (board_settings.hpp).
template <class Storage>
SettingsWrite storeSettings(const BoardSettings& s) {
  return writeSettings<Storage>(s);
}

}  // namespace tc
