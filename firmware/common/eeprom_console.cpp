// `eeprom crc` and `eeprom dump` (see eeprom_console.hpp).
#include "eeprom_console.hpp"

#include "console.hpp"
#include "hal/hal.hpp"
#include "thrustcal/crc16.hpp"
#include "thrustcal/eeprom_codec.hpp"

namespace fw {

namespace {

constexpr uint16_t kSlotBytes = tc::kRecordBytes;  // one motor's slot
constexpr uint8_t kSlots = hal::Eeprom::kSize / kSlotBytes;
constexpr uint8_t kRecordBytes = 16;
static_assert(hal::Eeprom::kSize % kSlotBytes == 0, "whole slots");
static_assert(hal::Eeprom::kSize % kRecordBytes == 0, "whole dump records");
static_assert(hal::Eeprom::kSize <= 0x10000, "dump addresses fit 16 bits (no type 04 records)");

void printHexDigit(uint8_t nibble) {
  hal::Uart::write(static_cast<uint8_t>(nibble < 10 ? '0' + nibble : 'A' + nibble - 10));
}

void printHex8(uint8_t value) {
  printHexDigit(static_cast<uint8_t>(value >> 4));
  printHexDigit(static_cast<uint8_t>(value & 0x0F));
}

void printHex16(uint16_t value) {
  printHex8(static_cast<uint8_t>(value >> 8));
  printHex8(static_cast<uint8_t>(value & 0xFF));
}

}  // namespace

void eepromCrc() {
  uint16_t all = 0xFFFF;
  hal::Uart::printP(TC_FLASH_TEXT("eeprom crc"));
  for (uint8_t slot = 0; slot < kSlots; ++slot) {
    uint16_t crc = 0xFFFF;
    const uint16_t base = static_cast<uint16_t>(slot * kSlotBytes);
    for (uint16_t i = 0; i < kSlotBytes; ++i) {
      const uint8_t byte = hal::Eeprom::readByte(static_cast<uint16_t>(base + i));
      crc = tc::crc16Update(crc, byte);
      all = tc::crc16Update(all, byte);
    }
    hal::Uart::printP(TC_FLASH_TEXT(" slot"));
    printUint(slot);
    hal::Uart::write(' ');
    printHex16(crc);
  }
  hal::Uart::printP(TC_FLASH_TEXT(" all "));
  printHex16(all);
  newline();
}

// One record ":10AAAA00<32 hex digits>CC": the checksum makes the bytes after ':' sum to 0.
void eepromDump(void (*between_records)()) {
  for (uint16_t addr = 0; addr < hal::Eeprom::kSize; addr += kRecordBytes) {
    uint8_t sum = static_cast<uint8_t>(kRecordBytes + (addr >> 8) + (addr & 0xFF));
    hal::Uart::write(':');
    printHex8(kRecordBytes);
    printHex16(addr);
    printHex8(0x00);
    for (uint8_t i = 0; i < kRecordBytes; ++i) {
      const uint8_t byte = hal::Eeprom::readByte(static_cast<uint16_t>(addr + i));
      sum = static_cast<uint8_t>(sum + byte);
      printHex8(byte);
    }
    printHex8(static_cast<uint8_t>(0x100 - sum));
    newline();
    if (between_records != nullptr) between_records();
  }
  hal::Uart::printP(TC_FLASH_TEXT(":00000001FF"));
  newline();
}

}  // namespace fw
