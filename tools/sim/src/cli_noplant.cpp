// Stand-in registration while the plant library is missing: `thrustcal sim` explains why.
#include "sim/cli.hpp"

namespace sim {
void registerCommands(CLI::App& app) {
  auto* cmd = app.add_subcommand("sim", "virtual bench (unavailable: built without tools/plant)");
  cmd->callback([] { throw CLI::RuntimeError("thrustcal was built without tools/plant; rebuild", 2); });
}
}  // namespace sim
