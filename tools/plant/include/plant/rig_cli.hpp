// `thrustcal plant rig seesaw|gimbal`: the attitude rigs against hand calculations.
#pragma once
#include <CLI/CLI.hpp>

namespace plant {
void addRigCommands(CLI::App* plant);
}  // namespace plant
