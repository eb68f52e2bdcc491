// `thrustcal board`: a real (or simulated) Mega2560 on a serial port: flash, eeprom put|get,
// calibrate, liftoff, params pull|push|table.
#pragma once
#include <CLI/CLI.hpp>

namespace board {
void registerCommands(CLI::App& app);
}  // namespace board
