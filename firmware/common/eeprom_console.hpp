// The EEPROM console commands both images answer (TEAM.md, "EEPROM console commands"):
//
//   eeprom crc    one line:  eeprom crc slot0 XXXX slot1 XXXX slot2 XXXX slot3 XXXX all XXXX
//                 CRC-16/CCITT-FALSE (tc::crc16Update) over each 1024-byte motor slot and over
//                 all 4096 bytes, 4 upper-case hex digits each.
//   eeprom dump   the whole EEPROM as Intel HEX: 256 data records of 16 bytes (type 00,
//                 addresses 0x0000..0x0FF0), then the end record :00000001FF.
//
// Why: a host reads and verifies the EEPROM through the running firmware (`thrustcal board
// eeprom get|put`), never through the Mega2560's stock STK500v2 bootloader, whose EEPROM read
// doubles the address (arduino/ArduinoCore-avr issue 129): avrdude's `-U eeprom:r` gets 4080
// of 4096 bytes wrong and its verify after `eeprom:w` fails.
//
// Reading only: neither command writes the EEPROM or touches an ESC output. The caller prints
// the prompt afterwards (and refuses the command while a motor runs, where that matters).
#pragma once
#include <stdint.h>

namespace fw {

// `eeprom crc` and `eeprom dump` (each image's command table parses `crc|dump`).
// `between_records`, when not null, runs after each dump record: the dump is ~11 KB of output
// (about 1 s at 115200 baud), so an image with a watchdog or a TX ring buffer can keep its
// loop duties going there.
void eepromCrc();
void eepromDump(void (*between_records)() = nullptr);

}  // namespace fw
