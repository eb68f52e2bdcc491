// `thrustcal bench ...`: the benchmarks of issue 5, each figure printed next to its target
// and written to JSON.
//   thrustcal bench accuracy     [--json FILE] [--quick]
//   thrustcal bench compute      [--json FILE]
//   thrustcal bench footprint    [--json FILE] [--avr-build DIR]
//   thrustcal bench calibration  [--json FILE] [--avr-build DIR]
//   thrustcal bench liftoff      [--json FILE] [--avr-build DIR]
//   thrustcal bench safety       [--json FILE] [--avr-build DIR]
//   thrustcal bench fly          [--json FILE] [--avr-build DIR]
//   thrustcal bench all          [--json FILE] [--avr-build DIR]
#pragma once
#include <CLI/CLI.hpp>

namespace bench {
void registerCommands(CLI::App& app);
}  // namespace bench
