// `thrustcal plant ...`: look at the plant model from the command line.
//   thrustcal plant presets                                  list presets
//   thrustcal plant curve --preset kv1100_9x4.7 --supply 11.1 [--step 20] [--lipo-soc S] [--json]
//   thrustcal plant table51 [--preset P] [--json]            fidelity vs thesis table 5.1
//   thrustcal plant datasheet [--preset P] [--json]          fidelity vs the T-motor datasheet
//   thrustcal plant step [--preset P] [--from 1300 --to 1500] [--supply 11.1]
//   thrustcal plant speed [--preset P]                        host ns per plant step
#pragma once
#include <CLI/CLI.hpp>

namespace plant {
void registerCommands(CLI::App& app);
}  // namespace plant
