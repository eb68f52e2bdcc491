// The two-copy scheme of the records that live in host slots (a slot without a v1 record:
// tc::isHostSlot): the board settings (board_settings.hpp) and fly's saved parameters
// (param_store.hpp). Each keeps copies A and B with a sequence number and a CRC; a write goes
// to the copy that does not hold the newest, in the host that holds it, in an order that makes
// the new copy valid only with its last byte. One home for both, so they cannot drift apart.
#pragma once
#include <stdint.h>

#include "thrustcal/record_v2.hpp"

namespace tc {

struct HostCopy {
  uint8_t host = kNoSlot;
  uint8_t copy = kNoCopy;  // 0 = A, 1 = B
  uint16_t sequence = 0;
};

// The newest copy over both copies of every host slot that `read_copy(host, copy, value,
// sequence)` decodes (DecodeStatus::kOk), into `out` (untouched when none) and `at`; `hosts`
// counts the host slots seen (0: every slot holds a v1 record). kErased when no copy decodes.
template <class Storage, class Value, class ReadCopy>
DecodeStatus newestHostCopy(Value& out, HostCopy& at, uint8_t& hosts, ReadCopy read_copy) {
  DecodeStatus status = DecodeStatus::kErased;
  hosts = 0;
  for (uint8_t host = 0; host < kMotorSlots; ++host) {
    if (!isHostSlot<Storage>(host)) continue;
    ++hosts;
    for (uint8_t copy = 0; copy < 2; ++copy) {
      Value v;
      uint16_t seq = 0;
      if (read_copy(host, copy, v, seq) != DecodeStatus::kOk) continue;
      if (status != DecodeStatus::kOk || sequenceNewer(seq, at.sequence)) {
        status = DecodeStatus::kOk;
        at.host = host;
        at.copy = copy;
        at.sequence = seq;
        out = v;
      }
    }
  }
  return status;
}

// Where the next write goes, given the newest valid copy `now` (`have`: there is one): the
// other copy in its host unless that host is `avoid`; else copy A of the highest host other than
// `avoid`. host kNoSlot: no room (every other slot holds a v1 record). The sequence is one past
// the newest (1 without one).
template <class Storage>
HostCopy nextHostCopy(bool have, const HostCopy& now, uint8_t avoid) {
  HostCopy next;
  if (have && now.host != avoid && isHostSlot<Storage>(now.host)) {
    next.host = now.host;
    next.copy = static_cast<uint8_t>(now.copy ^ 1u);
  } else {
    for (uint8_t h = kMotorSlots; h-- > 0;) {
      if (h != avoid && isHostSlot<Storage>(h)) {
        next.host = h;
        next.copy = 0;
        break;
      }
    }
  }
  next.sequence = have ? static_cast<uint16_t>(now.sequence + 1) : 1;
  return next;
}

// Writes the `length`-byte `image` (its CRC in the last two bytes, its sequence at
// `seq_offset`) at `addr`: every other byte first, then the sequence, then the CRC. A cut before
// the last byte leaves a copy whose CRC does not match (the other copy, untouched, stays the
// newest); after it, the new copy is the newest.
template <class Storage>
void writeCopyInOrder(uint16_t addr, const uint8_t* image, uint16_t length, uint16_t seq_offset) {
  const uint16_t crc_at = static_cast<uint16_t>(length - 2);
  for (uint16_t i = 0; i < crc_at; ++i) {
    if (i == seq_offset || i == seq_offset + 1) continue;
    Storage::updateByte(static_cast<uint16_t>(addr + i), image[i]);
  }
  for (uint16_t i = seq_offset; i < seq_offset + 2; ++i) Storage::updateByte(static_cast<uint16_t>(addr + i), image[i]);
  for (uint16_t i = crc_at; i < length; ++i) Storage::updateByte(static_cast<uint16_t>(addr + i), image[i]);
}

}  // namespace tc
