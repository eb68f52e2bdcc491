// Saved parameters in EEPROM (an image's parameter table, param_table.hpp): one record, two
// copies, a sequence number and a CRC, as the board settings keep theirs (board_settings.hpp).
//
// Where it lives: the four 1024-byte motor slots fill the 4 KiB EEPROM and a v1 record fills
// its slot, so the record lives in a host slot (tc::isHostSlot: erased or model v2), copies A and
// B at host offsets 640 and 768, 128 bytes each (after v2 copy B, 512..626; 896..959 is kept
// for another record, 960..1005 holds the board settings). No slot shrinks. Layout of one copy
// (little endian):
//
//   offset  size  field
//        0     1  kind 0x50 ('P'); 0xFF = erased
//        1     1  magic 0xA9
//        2     2  sequence number (the newest valid copy wins, wrap-around safe)
//        4     1  layout version of the table that wrote it
//        5     1  payload bytes N, 1..120
//        6     N  payload: every row's value in table order (param_table.hpp)
//      6+N     2  CRC-16/CCITT-FALSE of bytes 0..5+N
//
// The loader takes the newest copy whose CRC is right in any host slot; whether its layout is
// the image's and its values are allowed is the image's to judge (it flies its defaults
// otherwise and says why: a power cut never makes such a copy, so an older one is not used
// instead). A write goes to the copy that does not hold the newest, in the host that holds it
// (else the highest host): body, then sequence, then CRC, so a cut at any byte leaves the old
// record or the new one whole. Before a v1 record is written over the host (tc::storeRecordV1),
// the record moves to another host first; with no other host it is dropped (the image then
// flies its defaults and says so: parameters are tuning, not calibration, and four thesis
// records leave no room for them). With all four slots holding v1 records there is no room.
#pragma once
#include <stdint.h>

#include "thrustcal/board_settings.hpp"
#include "thrustcal/crc16.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/host_copies.hpp"
#include "thrustcal/param_table.hpp"
#include "thrustcal/record_v2.hpp"

namespace tc {

constexpr uint8_t kParamsKind = 0x50;
constexpr uint8_t kParamsMagic = 0xA9;
constexpr uint16_t kParamsCopyBytes = 128;
constexpr uint16_t kParamsOffsetA = 640;  // copy A within a host slot; copy B follows it
constexpr uint16_t kParamsOffsetB = kParamsOffsetA + kParamsCopyBytes;
constexpr uint8_t kParamsHeaderBytes = 6;
constexpr uint16_t kParamsSeqOffset = 2;
constexpr uint16_t kParamsReservedEnd = 960;  // 896..959: kept for another record
static_assert(kParamsHeaderBytes + kParamPayloadMax + 2 == kParamsCopyBytes, "a copy is 128 bytes");
static_assert(kRecordV2CopyOffset + kRecordV2Bytes <= kParamsOffsetA, "the record lies after v2 copy B");
static_assert(kParamsOffsetB + kParamsCopyBytes <= 896 && kParamsReservedEnd <= kSettingsOffset[0],
              "copy B ends before the reserved bytes and the board settings");

struct ParamsRecord {
  uint8_t layout = 0;
  uint8_t length = 0;  // payload bytes, 1..kParamPayloadMax
  uint8_t payload[kParamPayloadMax] = {};
  bool samePayload(const ParamsRecord& o) const;
};

// One copy's image (kParamsHeaderBytes + length + 2 bytes). Cannot fail; length must be valid.
void serializeParams(const ParamsRecord& r, uint16_t sequence, uint8_t* image);

struct ParamsRead {
  DecodeStatus status = DecodeStatus::kErased;  // kOk: a copy was loaded
  uint8_t host = kNoSlot;
  uint8_t copy = kNoCopy;  // 0 = A, 1 = B
  uint16_t sequence = 0;
  uint8_t hosts = 0;       // host slots seen (0: every slot holds a v1 record, no room)
};

enum class ParamsWriteStatus : uint8_t {
  kWritten = 0,
  kUnchanged,     // the newest copy holds this record already: nothing written
  kInvalid,       // length 0 or above kParamPayloadMax: nothing written
  kNoRoom,        // every (allowed) slot holds a v1 record: nothing written
  kVerifyFailed,  // read-back failed: the previous record is kept
};

struct ParamsWrite {
  ParamsWriteStatus status = ParamsWriteStatus::kInvalid;
  uint8_t host = kNoSlot;
  uint8_t copy = kNoCopy;
  uint16_t sequence = 0;
};

// What storeRecordV1 did with a parameter record in the slot it wrote (StoreReport::params).
enum class ParamsMove : uint8_t {
  kNone = 0,  // the slot held none
  kMoved,     // moved to another host first
  kDropped,   // no other host: the v1 record overwrote it
};

namespace params_detail {

inline uint16_t copyAddress(uint8_t host, uint8_t copy) {
  return static_cast<uint16_t>(slotAddress(host) + kParamsOffsetA + copy * kParamsCopyBytes);
}

// Decodes the copy at `addr`: kErased (kind 0xFF), kBadVersion (other kind or magic),
// kBadContent (length outside 1..kParamPayloadMax), kBadCrc, kOk.
template <class Storage>
DecodeStatus readCopy(uint16_t addr, ParamsRecord& out, uint16_t& sequence) {
  uint8_t header[kParamsHeaderBytes];
  for (uint8_t i = 0; i < kParamsHeaderBytes; ++i) header[i] = Storage::readByte(static_cast<uint16_t>(addr + i));
  if (header[0] == 0xFF) return DecodeStatus::kErased;
  if (header[0] != kParamsKind || header[1] != kParamsMagic) return DecodeStatus::kBadVersion;
  const uint8_t length = header[5];
  if (length == 0 || length > kParamPayloadMax) return DecodeStatus::kBadContent;
  uint16_t crc = crc16CcittFalse(header, kParamsHeaderBytes);
  for (uint8_t i = 0; i < length; ++i) {
    out.payload[i] = Storage::readByte(static_cast<uint16_t>(addr + kParamsHeaderBytes + i));
    crc = crc16Update(crc, out.payload[i]);
  }
  const uint16_t at = static_cast<uint16_t>(addr + kParamsHeaderBytes + length);
  const uint16_t stored = static_cast<uint16_t>(Storage::readByte(at) | (Storage::readByte(static_cast<uint16_t>(at + 1)) << 8));
  if (stored != crc) return DecodeStatus::kBadCrc;
  out.layout = header[4];
  out.length = length;
  sequence = static_cast<uint16_t>(header[2] | (header[3] << 8));
  return DecodeStatus::kOk;
}

}  // namespace params_detail

// The newest copy with a right CRC in any host slot; `out` untouched unless kOk.
template <class Storage>
ParamsRead readParams(ParamsRecord& out) {
  ParamsRead r;
  HostCopy at;
  r.status = newestHostCopy<Storage>(out, at, r.hosts, [](uint8_t host, uint8_t copy, ParamsRecord& rec, uint16_t& seq) {
    return params_detail::readCopy<Storage>(params_detail::copyAddress(host, copy), rec, seq);
  });
  r.host = at.host;
  r.copy = at.copy;
  r.sequence = at.sequence;
  return r;
}

// Stores `rec` power-fail-safely (see the top of this file), never in slot `avoid`.
template <class Storage>
ParamsWrite writeParams(const ParamsRecord& rec, uint8_t avoid = kNoSlot) {
  ParamsWrite w;
  if (rec.length == 0 || rec.length > kParamPayloadMax) return w;  // kInvalid
  ParamsRecord now_rec;
  const ParamsRead now = readParams<Storage>(now_rec);
  const bool have = now.status == DecodeStatus::kOk;
  if (have && now.host != avoid && now_rec.samePayload(rec)) {
    w.status = ParamsWriteStatus::kUnchanged;
    w.host = now.host;
    w.copy = now.copy;
    w.sequence = now.sequence;
    return w;
  }
  HostCopy newest;
  newest.host = now.host;
  newest.copy = now.copy;
  newest.sequence = now.sequence;
  const HostCopy next = nextHostCopy<Storage>(have, newest, avoid);
  if (next.host == kNoSlot) {
    w.status = ParamsWriteStatus::kNoRoom;
    return w;
  }
  w.host = next.host;
  w.copy = next.copy;
  w.sequence = next.sequence;
  uint8_t image[kParamsCopyBytes];
  serializeParams(rec, w.sequence, image);
  const uint16_t addr = params_detail::copyAddress(w.host, w.copy);
  const uint16_t length = static_cast<uint16_t>(kParamsHeaderBytes + rec.length + 2);
  writeCopyInOrder<Storage>(addr, image, length, kParamsSeqOffset);
  bool ok = true;  // read back byte for byte (the image's CRC is right, so the copy is whole)
  for (uint16_t i = 0; i < length; ++i) ok = ok && Storage::readByte(static_cast<uint16_t>(addr + i)) == image[i];
  w.status = ok ? ParamsWriteStatus::kWritten : ParamsWriteStatus::kVerifyFailed;
  return w;
}

// Before a v1 record is written over `slot`: a parameter record there moves to another host.
template <class Storage>
ParamsMove moveParamsOutOf(uint8_t slot) {
  ParamsRecord rec;
  const ParamsRead where = readParams<Storage>(rec);
  if (where.status != DecodeStatus::kOk || where.host != slot) return ParamsMove::kNone;
  const ParamsWriteStatus w = writeParams<Storage>(rec, slot).status;
  return w == ParamsWriteStatus::kWritten || w == ParamsWriteStatus::kUnchanged ? ParamsMove::kMoved
                                                                             : ParamsMove::kDropped;
}

}  // namespace tc
