// CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection, no xorout).
// Check value: crc16CcittFalse("123456789", 9) == 0x29B1.
#pragma once
#include <stdint.h>

namespace tc {

// Feeds one byte into a running CRC. Cannot fail.
uint16_t crc16Update(uint16_t crc, uint8_t byte);

// CRC of a whole buffer; pass a previous result as `crc` to continue a running CRC.
uint16_t crc16CcittFalse(const uint8_t* data, uint16_t length, uint16_t crc = 0xFFFF);

}  // namespace tc
