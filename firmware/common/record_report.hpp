// What both firmware images say about EEPROM records and the board settings, and the
// `divider` console command they share (thrustcal/board_settings.hpp).
#pragma once
#include <stdint.h>

#include "thrustcal/board_settings.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/plausibility.hpp"

namespace fw {

// Why a record does not load: decodeStatusText, or for kBadContent with a known rule
// "implausible: <rule> (<where>: <value>; allowed <lo>..<hi>)".
void printRecordStatus(tc::DecodeStatus status, const tc::Plausibility& why);

// "divider 100000/47000 ohm, full scale 15.638 V"
void printDivider(const tc::BoardSettings& settings);

// The `divider` command: no argument prints the setting; `divider R1 R2` (ohm) validates,
// stores it power-fail-safely and updates `settings`. Prints one result line (or one error
// line). Returns true when the setting changed.
bool commandDivider(char** tokens, uint8_t count, tc::BoardSettings& settings);
// `divider R1 R2` with the numbers already parsed (a shell row, 0..tc::kDividerMaxOhm each):
// the same checks, store and reply line.
bool setDivider(uint32_t top_ohm, uint32_t bottom_ohm, tc::BoardSettings& settings);

}  // namespace fw
