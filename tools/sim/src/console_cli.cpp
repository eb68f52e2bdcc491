// `thrustcal sim console` and `thrustcal sim board`: a firmware image on a simulated board with
// its console on this terminal (console) or on a pseudo-terminal for real tools (board: avrdude,
// thrustcal board), until Ctrl-C or --duration.
#include <fmt/format.h>

#include <atomic>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>

#include "cli_support.hpp"
#include "hal/board.hpp"
#include "hex/intel_hex.hpp"
#include "sim/air_cli.hpp"
#include "sim/board.hpp"
#include "sim/cli.hpp"
#include "sim/console_stdin.hpp"
#include "sim/eeprom_motors.hpp"
#include "sim/pty_bridge.hpp"
#include "sim/rigs.hpp"
#include "sim/scenarios.hpp"
#include "sim/sim_board.hpp"

namespace sim {

namespace fs = std::filesystem;

namespace {

std::atomic<bool> g_stop{false};
extern "C" void onSignal(int) { g_stop = true; }

// What `sim console` reads from its command line.
struct ConsoleArgs {
  std::string elf = defaultElf("gather_store");
  std::string eeprom;
  std::string rig = "auto";
  std::string preset = "kv1100_9x4.7";
  std::vector<uint64_t> seeds{1, 2, 3, 4};
  double speed = 1.0;
  double duration = 0.0;
  bool read_only = false;
  int slot = 0;
  AirCliOptions air;
  bool seeds_given = false, preset_given = false;  // typed on the command line
};

void declareConsoleOptions(CLI::App* cmd, ConsoleArgs& a) {
  cmd->add_option("--elf", a.elf, "firmware ELF image")->capture_default_str();
  cmd->add_option("--eeprom", a.eeprom, "Intel HEX EEPROM image (loaded if it exists, saved at exit)");
  cmd->add_option("--rig", a.rig, "bench, quad, seesaw, gimbal or auto (bench for gather_store, quad "
                                  "otherwise)")
      ->check(CLI::IsMember({"auto", "bench", "quad", "seesaw", "gimbal"}))
      ->capture_default_str();
  addAirOptions(cmd, a.air);
  cmd->add_option("--preset", a.preset, "motor + propeller preset")->capture_default_str();
  cmd->add_option("--slot", a.slot, "bench: the ESC output (0..3) the motor is wired to; select "
                                    "it with 'motor N' in gather_store")
      ->check(CLI::Range(0, 3))
      ->capture_default_str();
  cmd->add_option("--seeds", a.seeds, "motor seeds (bench: the first; quad: slot 0..3)")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--speed", a.speed, "simulated seconds per wall second (0: as fast as possible)")
      ->capture_default_str();
  cmd->add_option("--duration", a.duration, "stop after this many simulated seconds (0: Ctrl-C)")
      ->capture_default_str();
  cmd->add_flag("--read-only", a.read_only, "do not write the EEPROM back");
}

// The plant `sim console` wires to the image: one of the rigs (kept alive here) and its board.
struct ConsoleRig {
  std::unique_ptr<BenchRig> bench;
  std::unique_ptr<QuadRig> quad;
  std::unique_ptr<AirframeRig> airframe;
  std::unique_ptr<StillAirframe> still;  // the IMU and faults on a board without an attitude rig
  Board* board = nullptr;
};

// The flight rigs' four motors: those the EEPROM's records were made for unless --seeds or
// --preset say otherwise (sim/eeprom_motors.hpp); said either way.
void chooseMotors(ConsoleArgs& a) {
  const ConsoleMotors m = chooseConsoleMotors(a.eeprom, a.seeds, a.seeds_given, a.preset, a.preset_given);
  a.seeds.assign(4, 0);
  for (int i = 0; i < 4; ++i) a.seeds[i] = m.motors[i].seed;
  a.preset = m.motors[0].preset;
  for (int i = 1; i < 4; ++i)  // another preset in a slot: that motor is another part
    if (m.motors[i].preset != a.preset) a.air.motor_parts.push_back(fmt::format("{}:{}", i, m.motors[i].preset));
  for (const std::string& note : m.notes) fmt::print("{}\n", note);
}

ConsoleRig makeConsoleRig(const ConsoleArgs& a, const std::string& which) {
  ConsoleRig r;
  if (isAirRig(which)) {
    r.airframe = makeAirframeRig(a.elf, which, a.preset, a.seeds, a.air);
    r.board = &r.airframe->board();
  } else if (which == "bench") {
    plant::BenchParams p = plant::BenchParams::thesis(a.preset);
    p.actuator = motorForSeed(a.preset, a.seeds.at(0), 0.03);
    r.bench = std::make_unique<BenchRig>(a.elf, p, a.slot);
    r.board = &r.bench->board;
  } else {
    std::array<plant::ActuatorParams, 4> motors;
    for (int i = 0; i < 4; ++i)
      motors[i] = motorForSeed(a.preset, a.seeds.size() > static_cast<std::size_t>(i) ? a.seeds[i] : i + 1, 0.03);
    r.quad = std::make_unique<QuadRig>(a.elf, plant::QuadFrameParams{}, motors);
    r.board = &r.quad->board;
  }
  if (!r.airframe) applyEscPins(*r.board, a.air);  // the airframe took them from its options
  return r;
}

void runConsoleCommand(ConsoleArgs a) {
  std::string which = a.rig;
  if (which == "auto")
    which = fs::path(a.elf).filename().string().find("gather") != std::string::npos ? "bench" : "quad";
  const auto image = loadEepromOrErased(a.eeprom, false);
  if (which != "bench") chooseMotors(a);
  ConsoleRig r = makeConsoleRig(a, which);
  Board& board = *r.board;
  board.setEeprom(image);
  if (!r.airframe) r.still = std::make_unique<StillAirframe>(board, which, a.air);
  if (r.airframe) fmt::print("rig: {}\n", r.airframe->describe());
  const std::unique_ptr<RcOnBoard> rc = makeRcInput(board, a.air, true);
  PtyBridge pty(board);
  fmt::print("simulated board ({}, {} rig) on {}\n", fs::path(a.elf).filename().string(), which,
             pty.path());
  fmt::print("open it with:  screen {0} {1}   or   picocom -b {1} {0}\n", pty.path(), hal::kUartBaud);
  if (rc)
    fmt::print("RC receiver ({}) on {}: type 'ch 1500 1500 1000 1500 ...' (us, channels 1..8), 'loss', "
               "'status'; no signal until then{}\n",
               rc->describe(), rc->ptyPath(), a.air.rc_script.empty() ? "" : " or the script's first row");
  fmt::print("Ctrl-C here ends the simulation{}.\n",
             a.read_only || a.eeprom.empty() ? "" : " and saves the EEPROM to " + a.eeprom);
  std::fflush(stdout);
  // Each fault is said when it is applied; simulator commands come from this terminal.
  const auto say_fault = [](const std::string& f) {
    fmt::print("fault applied: {}\n", f);
    std::fflush(stdout);
  };
  if (r.airframe) r.airframe->onFaultApplied(say_fault);
  if (r.still) r.still->onFaultApplied(say_fault);
  if (r.airframe) fmt::print("{}\n", ConsoleStdin::kHelp);
  std::fflush(stdout);
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  {
    ConsoleStdin keys(pty, r.airframe.get());
    pty.run(a.speed, a.duration, g_stop);
  }
  if (!a.read_only && !a.eeprom.empty()) {
    hex::writeIntelHexFile(a.eeprom, board.eeprom());
    fmt::print("EEPROM saved: {}\n", a.eeprom);
  }
  fmt::print("{:.1f} s simulated (paced at {:g}x; the simulation alone ran at {})\n",
             board.simulatedSeconds(), a.speed, speedText(board.realtimeFactor()));
  if (rc) fmt::print("{}\n", rcSummary(*rc));
  if (!a.air.log.empty()) fmt::print("truth log: {}\n", a.air.log);
}

}  // namespace

void addConsoleCommand(CLI::App& sim) {
  auto* cmd = sim.add_subcommand(
      "console",
      fmt::format("The simulated board on a pseudo-terminal: open the printed /dev/pts/N with\n"
                  "'screen /dev/pts/N {0}' or 'picocom -b {0} /dev/pts/N' and type as on the real\n"
                  "board. gather_store gets the thesis bench (motor on the load cell), read_run the "
                  "tethered\nquad. Ctrl-C ends it and saves the EEPROM back to --eeprom.\n"
                  "Any image: --imu mpu6050 puts an MPU-6050 on its I2C bus; --rig seesaw|gimbal an "
                  "attitude\nrig on its ESC outputs that the IMU measures, --log FILE its true attitude "
                  "as it runs;\n--fault KIND@T injects faults (docs/sim.md, \"The virtual airframe\").",
                  hal::kUartBaud));
  auto a = std::make_shared<ConsoleArgs>();
  declareConsoleOptions(cmd, *a);
  cmd->callback([a, cmd] {
    a->seeds_given = cmd->count("--seeds") > 0;
    a->preset_given = cmd->count("--preset") > 0;
    guarded([&] { runConsoleCommand(*a); });
  });
}

namespace {

// What `sim board` reads from its command line.
struct BoardArgs {
  SimBoardOptions o;
  std::string elf, hex, eeprom, link;
  Pacing pacing;
  double duration = 0.0;
  bool read_only = false, quiet = false;
};

void declareBoardOptions(CLI::App* cmd, BoardArgs& a) {
  SimBoardOptions* o = &a.o;
  cmd->add_option("--bootloader", o->bootloader_hex, "bootloader Intel HEX")->capture_default_str();
  auto* elf_opt = cmd->add_option("--elf", a.elf, "application already in flash (ELF image)");
  cmd->add_option("--hex", a.hex, "application already in flash (Intel HEX)")->excludes(elf_opt);
  cmd->add_option("--eeprom", a.eeprom, "Intel HEX EEPROM image (loaded if it exists, saved at exit)");
  cmd->add_option("--link", a.link, "also make this symlink to the pty (a stable port name)");
  cmd->add_option("--rig", o->rig, "plant: auto (follow the image), bench or quad")
      ->check(CLI::IsMember({"auto", "bench", "quad"}))
      ->capture_default_str();
  cmd->add_option("--slot", o->bench_slot, "bench: the ESC output / slot whose motor is mounted")
      ->check(CLI::Range(0, 3))
      ->capture_default_str();
  cmd->add_option("--seeds", o->seeds, "the four motors (slot 0..3), as for sim gather / liftoff")
      ->delimiter(',')
      ->expected(4)
      ->capture_default_str();
  cmd->add_option("--preset", o->preset, "motor + propeller preset")->capture_default_str();
  cmd->add_option("--soc", o->lipo_soc, "3S LiPo state of charge (0..1)")->capture_default_str();
  cmd->add_option("--idle-speed", a.pacing.idle_speed,
                  "simulated s per wall s while idle (1: the bootloader's timeout is real)")
      ->capture_default_str();
  cmd->add_option("--busy-speed", a.pacing.busy_speed,
                  "simulated s per wall s while bytes flow (0: as fast as possible; 1: a real "
                  "board's timing)")
      ->capture_default_str();
  cmd->add_option("--duration", a.duration, "stop after this many simulated seconds (0: Ctrl-C)")
      ->capture_default_str();
  cmd->add_flag("--read-only", a.read_only, "do not write the EEPROM back");
  cmd->add_flag("--quiet", a.quiet, "no event lines (resets, clients)");
}

// Where the board is and how to reach it, printed before it runs.
void printBoardBanner(const BoardArgs& a, const SimBoardOptions& opt, SimBoard& sb) {
  const std::string port = sb.link().port();
  fmt::print("simulated Mega2560 on {}{}\n", sb.link().path(),
             a.link.empty() ? "" : fmt::format(" (link {})", a.link));
  fmt::print("  bootloader {} at 0x{:05X}; application: {}\n", opt.bootloader_hex,
             sb.board().resetAddress(), flashAppName(sb.app()));
  fmt::print("  plant: {}\n", sb.rigText());
  fmt::print("use it as the board's port:\n");
  fmt::print("  thrustcal board flash --port {} build/avr/firmware/gather_store/gather_store.hex\n", port);
  fmt::print("  avrdude -p m2560 -c wiring -P {} -b {} -D -U flash:w:IMAGE.hex:i\n", port,
             hal::kBootloaderBaud);
  fmt::print("  screen {} {}\n", port, hal::kUartBaud);
  fmt::print("Ctrl-C here ends the simulation{}.\n",
             a.read_only || a.eeprom.empty() ? "" : " and saves the EEPROM to " + a.eeprom);
  std::fflush(stdout);
}

void runBoardCommand(const BoardArgs& a) {
  SimBoardOptions opt = a.o;
  opt.application = !a.elf.empty() ? a.elf : a.hex;
  opt.eeprom = loadEepromOrErased(a.eeprom, false);
  opt.pty.link_path = a.link;
  if (!a.quiet) opt.pty.log = [](const std::string& l) {
    std::fprintf(stderr, "sim board: %s\n", l.c_str());
    std::fflush(stderr);
  };
  SimBoard sb(opt);
  printBoardBanner(a, opt, sb);
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  sb.link().run(a.pacing, a.duration, g_stop);
  if (!a.read_only && !a.eeprom.empty()) {
    hex::writeIntelHexFile(a.eeprom, sb.board().eeprom());
    fmt::print("EEPROM saved: {}\n", a.eeprom);
  }
  fmt::print("{:.1f} s simulated, {} reset(s) by clients; the simulation alone ran at {}\n",
             sb.board().simulatedSeconds(), sb.link().clientResets(), speedText(sb.board().realtimeFactor()));
}

}  // namespace

void addBoardCommand(CLI::App& sim) {
  auto* cmd = sim.add_subcommand(
      "board",
      "A simulated Arduino Mega2560 as avrdude and `thrustcal board` meet a real one on USB:\n"
      "the flash holds the Mega2560's STK500v2 bootloader (Debian's arduino-core-avr) at byte\n"
      "0x3E000 and, if given, an application; every reset starts the bootloader (~1 s wait for\n"
      "avrdude, then the application). UART0 is on a pseudo-terminal: a client that opens it\n"
      "and flushes it resets the board (what avrdude's DTR pulse does; a pty has no DTR). Time\n"
      "keeps the wall clock while idle and runs fast while bytes flow or a console command is\n"
      "under way. What avrdude writes stays for the run. The plant follows the image at each\n"
      "reset: gather_store gets the thesis bench (motor of --slot on the load cell), read_run\n"
      "the tethered quad. Ctrl-C ends it and saves the EEPROM to --eeprom.");
  auto a = std::make_shared<BoardArgs>();
  declareBoardOptions(cmd, *a);
  cmd->callback([a] { guarded([&] { runBoardCommand(*a); }); });
}

}  // namespace sim
