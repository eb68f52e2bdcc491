// CRC-16/CCITT-FALSE without a table: 8 shifts/xors per byte, no 512-byte table in flash.
#include "thrustcal/crc16.hpp"

namespace tc {

uint16_t crc16Update(uint16_t crc, uint8_t byte) {
  // Byte-wise form of the polynomial 0x1021 (x^16 + x^12 + x^5 + 1).
  uint8_t x = static_cast<uint8_t>((crc >> 8) ^ byte);
  x = static_cast<uint8_t>(x ^ (x >> 4));
  return static_cast<uint16_t>((crc << 8) ^ (static_cast<uint16_t>(x) << 12) ^
                               (static_cast<uint16_t>(x) << 5) ^ x);
}

uint16_t crc16CcittFalse(const uint8_t* data, uint16_t length, uint16_t crc) {
  for (uint16_t i = 0; i < length; ++i) crc = crc16Update(crc, data[i]);
  return crc;
}

}  // namespace tc
