// thrustcal: the host program. Each part registers its own subcommands.
#include <CLI/CLI.hpp>

#include <cstdio>

#ifdef THRUSTCAL_HAVE_PLANT
#include "plant/cli.hpp"
#endif
#ifdef THRUSTCAL_HAVE_SIM
#include "sim/cli.hpp"
#endif
#ifdef THRUSTCAL_HAVE_LAB
#include "lab/cli.hpp"
#endif
#ifdef THRUSTCAL_HAVE_BOARD
#include "board/cli.hpp"
#endif
#ifdef THRUSTCAL_HAVE_BENCH
#include "bench/cli.hpp"
#endif

int main(int argc, char** argv) {
  CLI::App app{
      "thrustcal: force-calibrated multirotor actuators.\n"
      "Calibrate motors on a (virtual) load-cell bench, fly force commands, and find what the\n"
      "force model misses."};
  app.require_subcommand(1);
  app.set_version_flag("--version", "thrustcal 0.1.0");
#ifdef THRUSTCAL_HAVE_PLANT
  plant::registerCommands(app);
#endif
#ifdef THRUSTCAL_HAVE_SIM
  sim::registerCommands(app);
#endif
#ifdef THRUSTCAL_HAVE_LAB
  lab::registerCommands(app);
#endif
#ifdef THRUSTCAL_HAVE_BOARD
  board::registerCommands(app);
#endif
#ifdef THRUSTCAL_HAVE_BENCH
  bench::registerCommands(app);
#endif
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  return 0;
}
