// `thrustcal lab`: diagnose, ladder, effects, generate.
#pragma once
#include <CLI/CLI.hpp>

namespace lab {
void registerCommands(CLI::App& app);
}  // namespace lab
