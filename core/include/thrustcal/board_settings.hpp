// Board settings kept in EEPROM: the battery monitor's divider (R1 from the pack to A1, R2
// from A1 to ground). gather_store measures with it, read_run flies with it; both set it with
// the `divider` console command. Default: the thesis's 100 kOhm / 47 kOhm (full scale 15.638 V,
// 1S..3S); 100 kOhm / 22 kOhm (27.7 V) covers 6S.
//
// Where it lives: the four 1024-byte motor slots fill the 4 KiB EEPROM, and a v1 record fills
// its whole slot, so the settings live in a slot that does NOT hold a v1 record (a "host",
// tc::isHostSlot: erased or v2), two copies at host offsets 960 and 992 (after v2 copy B,
// 627..1023 is free in a v2 slot). Layout of one copy (14 bytes, little endian):
//
//   offset  size  field
//        0     1  kind 0x53 ('S'); 0xFF = erased
//        1     1  magic 0xD7
//        2     2  sequence number (newest valid copy wins, wrap-around safe)
//        4     4  divider top resistor R1, ohm
//        8     4  divider bottom resistor R2, ohm
//       12     2  CRC-16/CCITT-FALSE of bytes 0..11
//
// With the bench's load-cell response identified (gather_store's `dyn cell`, issue 26;
// thrustcal/dynamics.hpp) the kind is 0x54 ('T') and the copy 17 bytes:
//
//       12     1  equal low-pass stages (1..4)
//       13     2  each stage's time constant, 0.1 ms (1 ms .. 2 s)
//       15     2  CRC-16/CCITT-FALSE of bytes 0..14
//
// Without it the copy is the 14-byte kind 0x53 above, byte for byte.
//
// The loader looks at both copies in every host slot and takes the newest valid one; none:
// the defaults. A write goes to the copy that does not hold the newest (body, sequence, CRC:
// the same power-fail-safe order as a v2 record), in the host that holds the newest, so a cut
// at any byte leaves the old or the new setting. Before a v1 record is written over the host
// (tc::storeRecordV1), the settings move to another host first; with no other host and a
// setting other than the default that store is refused, since the setting would be lost.
// With all four slots holding v1 records there is no room: the divider is the default and
// `divider` refuses to change it (say so, store a motor as v2 or erase one first).
#pragma once
#include <stdint.h>

#include "thrustcal/battery_monitor.hpp"
#include "thrustcal/crc16.hpp"
#include "thrustcal/dynamics.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/host_copies.hpp"
#include "thrustcal/record_limits.hpp"
#include "thrustcal/record_v2.hpp"

namespace tc {

constexpr uint8_t kSettingsKind = 0x53;
constexpr uint8_t kSettingsKindBench = 0x54;  // with the bench's response
constexpr uint8_t kSettingsMagic = 0xD7;
constexpr uint16_t kSettingsBytes = 14;
constexpr uint16_t kSettingsBenchBytes = 17;
constexpr uint16_t kSettingsMaxBytes = kSettingsBenchBytes;
constexpr uint16_t kSettingsOffset[2] = {960, 992};  // copies A and B within a host slot
constexpr uint16_t kSettingsSeqOffset = 2;
constexpr uint16_t kSettingsCrcOffset = kSettingsBytes - 2;
// Bytes of a copy whose kind byte is `kind`.
inline uint16_t settingsLength(uint8_t kind) {
  return kind == kSettingsKindBench ? kSettingsBenchBytes : kSettingsBytes;
}
constexpr uint32_t kDividerMaxOhm = 10000000ul;   // 10 MOhm: above, the ADC's input current matters
constexpr uint32_t kDividerMinBottomOhm = 100;
constexpr uint16_t kMaxFullScaleMv = 60000;
static_assert(kRecordV2CopyOffset + kRecordV2MaxBytes <= 960, "settings must lie after copy B");
static_assert(960 + kSettingsMaxBytes <= 992, "settings copy A must end before copy B");
static_assert(992 + kSettingsMaxBytes <= kRecordBytes, "settings copy B must fit the slot");

struct BoardSettings {
  uint32_t divider_top_ohm = kDefaultDividerTopOhm;
  uint32_t divider_bottom_ohm = kDefaultDividerBottomOhm;
  BenchResponse bench;  // the load cell's response (`dyn cell`); not identified by default

  // Full scale of the monitor in mV (5 V on the pin); 0 when the divider is not valid.
  uint16_t fullScaleMv() const;
  // R2 at least 100 Ohm, both at most 10 MOhm, full scale 5..60 V.
  bool isValid() const;
  bool isDefault() const {
    return divider_top_ohm == kDefaultDividerTopOhm && divider_bottom_ohm == kDefaultDividerBottomOhm;
  }
  // The battery monitor with this divider: counts -> mV, sane from kPackMinMv up to the
  // smaller of kPackMaxMv and just below the full scale (a reading at the rail is clipped).
  BatteryConfig batteryConfig() const;
  // What the record decoders need (voltages up to the monitor's full scale).
  RecordLimits recordLimits() const;
};

// settingsLength(image[0]) bytes (give kSettingsMaxBytes of room).
void serializeSettings(const BoardSettings& s, uint16_t sequence, uint8_t* image);
// kErased (kind 0xFF), kBadVersion (other kind or magic), kBadCrc, kBadContent (divider or
// bench response not valid), kOk. `out` is left at the defaults unless kOk.
DecodeStatus parseSettings(const uint8_t* image, BoardSettings& out, uint16_t& sequence);

struct SettingsRead {
  DecodeStatus status = DecodeStatus::kErased;  // kOk: a stored copy was loaded
  uint8_t host = kNoSlot;                       // slot holding it
  uint8_t copy = kNoCopy;                       // 0 = A, 1 = B
  uint16_t sequence = 0;
};

enum class SettingsWriteStatus : uint8_t {
  kWritten = 0,
  kUnchanged,     // the newest copy already holds these values: nothing written
  kInvalid,       // the divider is not valid: nothing written
  kNoRoom,        // every (allowed) slot holds a v1 record: nothing written
  kVerifyFailed,  // read-back failed: the previous setting is kept
};

struct SettingsWrite {
  SettingsWriteStatus status = SettingsWriteStatus::kInvalid;
  uint8_t host = kNoSlot;
  uint8_t copy = kNoCopy;
  uint16_t sequence = 0;
};

namespace settings_detail {

template <class Storage>
DecodeStatus readCopy(uint16_t addr, BoardSettings& out, uint16_t& sequence) {
  uint8_t image[kSettingsMaxBytes];
  const uint16_t length = settingsLength(Storage::readByte(addr));
  for (uint16_t i = 0; i < length; ++i) image[i] = Storage::readByte(static_cast<uint16_t>(addr + i));
  return parseSettings(image, out, sequence);
}

inline uint16_t copyAddress(uint8_t host, uint8_t copy) {
  return static_cast<uint16_t>(slotAddress(host) + kSettingsOffset[copy]);
}

}  // namespace settings_detail

// The newest valid settings copy in any host slot; the defaults when there is none.
template <class Storage>
SettingsRead readSettings(BoardSettings& out) {
  SettingsRead r;
  out = BoardSettings();
  HostCopy at;
  uint8_t hosts = 0;
  r.status = newestHostCopy<Storage>(out, at, hosts, [](uint8_t host, uint8_t copy, BoardSettings& s, uint16_t& seq) {
    return settings_detail::readCopy<Storage>(settings_detail::copyAddress(host, copy), s, seq);
  });
  r.host = at.host;
  r.copy = at.copy;
  r.sequence = at.sequence;
  return r;
}

// Stores `s` power-fail-safely (see the top of this file), never in slot `avoid`.
template <class Storage>
SettingsWrite writeSettings(const BoardSettings& s, uint8_t avoid = kNoSlot) {
  SettingsWrite w;
  if (!s.isValid()) return w;  // kInvalid
  BoardSettings now_values;
  const SettingsRead now = readSettings<Storage>(now_values);
  const bool have = now.status == DecodeStatus::kOk;
  if (have && now.host != avoid && now_values.divider_top_ohm == s.divider_top_ohm &&
      now_values.divider_bottom_ohm == s.divider_bottom_ohm && now_values.bench == s.bench) {
    w.status = SettingsWriteStatus::kUnchanged;
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
    w.status = SettingsWriteStatus::kNoRoom;
    return w;
  }
  w.host = next.host;
  w.copy = next.copy;
  w.sequence = next.sequence;
  uint8_t image[kSettingsMaxBytes];
  serializeSettings(s, w.sequence, image);
  const uint16_t addr = settings_detail::copyAddress(w.host, w.copy);
  writeCopyInOrder<Storage>(addr, image, settingsLength(image[0]), kSettingsSeqOffset);
  BoardSettings back;
  uint16_t seq = 0;
  const bool ok = settings_detail::readCopy<Storage>(addr, back, seq) == DecodeStatus::kOk && seq == w.sequence;
  w.status = ok ? SettingsWriteStatus::kWritten : SettingsWriteStatus::kVerifyFailed;
  return w;
}

}  // namespace tc
