// `thrustcal sim ...`: the virtual bench scenarios (gather, liftoff, console).
#pragma once
#include <CLI/CLI.hpp>

namespace sim {
void registerCommands(CLI::App& app);
}
