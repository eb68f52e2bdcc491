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

// `divider R1 R2` (ohm, both already parsed by the command table, 0..tc::kDividerMaxOhm):
// validates, stores the setting power-fail-safely, updates `settings` and prints one result
// (or error) line. True when the setting changed.
bool setDivider(uint32_t top_ohm, uint32_t bottom_ohm, tc::BoardSettings& settings);

}  // namespace fw
