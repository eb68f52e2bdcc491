// 4 KB EEPROM through avr-libc. eeprom_update_* reads each byte first and only programs the
// bytes that change (3.4 ms and one of ~100k erase/write cycles each). Addresses past the end
// are ignored (reads return 0xFF, the erased value) instead of wrapping around.
// Each byte written kicks the watchdog: a byte write waits for the previous one (3.4 ms on the
// chip), and a v2 store writes hundreds of bytes, far longer than the watchdog's 64 ms.
#include <avr/eeprom.h>
#include <avr/wdt.h>

#include "hal/hal.hpp"

namespace {
inline uint8_t* cell(uint16_t addr) { return reinterpret_cast<uint8_t*>(addr); }
inline bool fits(uint16_t addr, uint16_t length) {
  return static_cast<uint32_t>(addr) + length <= hal::Eeprom::kSize;
}
}  // namespace

namespace hal {

uint8_t Eeprom::readByte(uint16_t addr) {
  return fits(addr, 1) ? eeprom_read_byte(cell(addr)) : 0xFF;
}

void Eeprom::updateByte(uint16_t addr, uint8_t value) {
  wdt_reset();
  if (fits(addr, 1)) eeprom_update_byte(cell(addr), value);
}

void Eeprom::readBlock(uint16_t addr, void* dst, uint16_t length) {
  if (fits(addr, length)) {
    eeprom_read_block(dst, cell(addr), length);
  } else {
    uint8_t* out = static_cast<uint8_t*>(dst);
    for (uint16_t i = 0; i < length; ++i) out[i] = 0xFF;
  }
}

void Eeprom::updateBlock(uint16_t addr, const void* src, uint16_t length) {
  if (!fits(addr, length)) return;
  const uint8_t* in = static_cast<const uint8_t*>(src);
  for (uint16_t i = 0; i < length; ++i) updateByte(static_cast<uint16_t>(addr + i), in[i]);
}

}  // namespace hal
