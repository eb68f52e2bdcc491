// `thrustcal sim ...`: the virtual bench scenarios (gather, liftoff, console, swap, ...).
#pragma once
#include <CLI/CLI.hpp>

#include <string>

namespace sim {
void registerCommands(CLI::App& app);
// Where an AVR image is by default: $THRUSTCAL_AVR_BUILD_DIR, else <source>/build/avr
// (firmware/NAME/NAME.elf).
std::string defaultElf(const std::string& name);
void addSwapCommand(CLI::App& sim);  // thrustcal sim swap (swap_cli.cpp)
void addDynCommand(CLI::App& sim);   // thrustcal sim dyn (dynamics_cli.cpp)
void addFleetCommand(CLI::App& sim); // thrustcal sim fleet (fleet_cli.cpp)
void addConsoleCommand(CLI::App& sim);  // thrustcal sim console (console_cli.cpp)
void addBoardCommand(CLI::App& sim);    // thrustcal sim board (console_cli.cpp)
}  // namespace sim
