// Pins by the names people use for them on an Arduino Mega 2560: "D3", "A8" (= D62), or the
// chip's port pin, "PE5" (also the pins the Mega's headers do not carry). The map is
// hal/mega_pins.hpp. Used by `--esc-pins` (sim console, sim run) and Board::setEscPins.
#pragma once
#include <array>
#include <string>

#include "hal/board.hpp"

namespace sim {

// Throws std::invalid_argument saying which names exist.
hal::MegaPin parseMegaPin(const std::string& name);
// "D3 (PE5)", "PE7" for a pin without a header number.
std::string megaPinName(const hal::MegaPin& pin);
// "D3,D5,D6,D2": the pins of ESC outputs 0..3 (the rig's motors 0..3). Throws
// std::invalid_argument for another count, an unknown name, a pin named twice.
std::array<hal::MegaPin, hal::kEscChannels> parseEscPins(const std::string& list);
// The board table's ESC pins (hal::kEscPins): the default.
std::array<hal::MegaPin, hal::kEscChannels> boardEscPins();

}  // namespace sim
