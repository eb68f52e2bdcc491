// `thrustcal sim gather|liftoff|console`.
#include "sim/cli.hpp"
#include "hal/board.hpp"

#include <fmt/format.h>

#include <atomic>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>

#include "sim/air_cli.hpp"
#include "sim/console_stdin.hpp"
#include "sim/eeprom_motors.hpp"
#include "sim/board.hpp"
#include "cli_support.hpp"
#include "hex/intel_hex.hpp"
#include "sim/pty_bridge.hpp"
#include "sim/rigs.hpp"
#include "sim/scenarios.hpp"
#include "sim/sim_board.hpp"
#include "thrustcal/source_tree.hpp"

namespace sim {

namespace fs = std::filesystem;

// Where the AVR images are by default: $THRUSTCAL_AVR_BUILD_DIR, else <source>/build/avr.
std::string defaultElf(const std::string& name) {
  const std::vector<fs::path> dirs = thrustcal::avrBuildDirs();
  for (const auto& d : dirs)
    for (const auto& p : {d / "firmware" / name / (name + ".elf"), d / "firmware" / (name + ".elf")})
      if (fs::exists(p)) return p.string();
  return (dirs.back() / "firmware" / name / (name + ".elf")).string();
}

namespace {

std::atomic<bool> g_stop{false};
extern "C" void onSignal(int) { g_stop = true; }

// What `sim gather` reads from its command line.
struct GatherArgs {
  GatherOptions o;
  std::string eeprom, json, second = "supply", model = "v1", via = "pty";
  std::vector<int> range, slots;
};

void declareGatherOptions(CLI::App* cmd, GatherArgs& a) {
  GatherOptions* o = &a.o;
  cmd->add_option("--via", a.via,
                  "pty: bootloader + pty + the board client, as a user's cable; in-process: typed "
                  "into the simulated UART (simulated time only, reproducible)")
      ->check(CLI::IsMember({"pty", "in-process"}))
      ->capture_default_str();
  cmd->add_option("--bootloader", o->bootloader_hex, "bootloader Intel HEX (--via pty)")
      ->capture_default_str();
  cmd->add_option("--elf", o->elf_path, "gather_store ELF image")->capture_default_str();
  cmd->add_option("--preset", o->preset, "motor + propeller preset (see thrustcal plant)")
      ->capture_default_str();
  cmd->add_option("--seed,--seeds", o->seeds,
                  "varied motor per seed; several seeds calibrate several slots")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--slot,--slots", a.slots, "EEPROM slot / ESC output per seed (0..3); "
                                              "default 0, 1, 2, ... in seed order")
      ->delimiter(',');
  cmd->add_option("--variation", o->variation, "part-to-part spread (relative sigma)")
      ->capture_default_str();
  cmd->add_option("--eeprom", a.eeprom,
                  "Intel HEX EEPROM image: read if it exists (other slots are kept), written "
                  "after the run (thrustcal board eeprom put puts it on a real board)");
  cmd->add_option("--log-dir", o->log_dir,
                  "write gather_slotK_curve{1,2}.csv (the streamed sweeps + current_a, rpm, temp_c) and "
                  "gather_slotK_curves.csv (stored vs true PWM per gram)");
  cmd->add_option("--json", a.json, "results as JSON (calibration.curve_error_max_g, sim.*)");
  cmd->add_option("--range", a.range,
                  fmt::format("sweep PWM range MIN MAX in us (default {} {}: the 13 sag bins of "
                              "40 us then span {}..{} us, where the motors fly)",
                              o->pwm_min_us, o->pwm_max_us, o->pwm_min_us, o->pwm_min_us + 520))
      ->expected(2);
  cmd->add_option("--step", o->step_us, "sweep step in us")->capture_default_str();
  cmd->add_option("--settle", o->settle_ms,
                  "settle time per step in ms (thesis: 200, which leaves the bench's low-pass "
                  "~1 % behind each step)")
      ->capture_default_str();
  cmd->add_option("--second", a.second, "curve 2 source: supply (bench supply) or drained (pack)")
      ->check(CLI::IsMember({"supply", "drained"}))
      ->capture_default_str();
  cmd->add_option("--model", a.model,
                  "what to store: v1 (the thesis's curves: store 1, store 2) or v2 (store v2 "
                  "after each sweep)")
      ->check(CLI::IsMember({"v1", "v2"}))
      ->capture_default_str();
  cmd->add_option("--supply-v", o->supply_v, "bench supply voltage for curve 2")
      ->capture_default_str();
  cmd->add_option("--drained-soc", o->drained_soc, "pack charge (0..1) for --second drained")
      ->capture_default_str();
}

GatherOptions gatherOptionsFrom(const GatherArgs& a) {
  GatherOptions opt = a.o;
  if (a.range.size() == 2) {
    opt.pwm_min_us = a.range[0];
    opt.pwm_max_us = a.range[1];
  }
  opt.slots = a.slots;
  if (opt.slots.empty())
    for (std::size_t i = 0; i < opt.seeds.size(); ++i) opt.slots.push_back(static_cast<int>(i));
  opt.second = a.second == "drained" ? SecondCurveSource::kDrainedPack : SecondCurveSource::kBenchSupply;
  opt.model = a.model == "v2" ? GatherModel::kModelV2 : GatherModel::kThesisV1;
  opt.link = a.via == "in-process" ? GatherLink::kInProcess : GatherLink::kPty;
  opt.eeprom = loadEepromOrErased(a.eeprom, false);
  return opt;
}

void printGather(const GatherResult& r, bool v2) {
  fmt::print("calibration{}: max error of the stored {} vs the plant {:.2f} g\n",
             v2 ? " (model v2)" : "", v2 ? "model at both sweeps' voltages" : "curves",
             r.curve_error_max_g);
  for (const auto& m : r.motors)
    fmt::print("  slot {} (seed {}): {} 1 {:.3f} V 1..{} g err max {:.2f} g rms {:.2f} g; "
               "{} 2 {:.3f} V 1..{} g err max {:.2f} g rms {:.2f} g{}\n",
               m.slot, m.seed, v2 ? "sweep" : "curve", m.curve1.start_v, m.curve1.max_g,
               m.curve1.error_max_g, m.curve1.error_rms_g, v2 ? "sweep" : "curve",
               m.curve2.start_v, m.curve2.max_g, m.curve2.error_max_g, m.curve2.error_rms_g,
               v2 ? fmt::format("; start {:.1f} us, {} knots", m.v2_start_us, m.v2_knots)
                  : std::string());
  fmt::print("sim: {:.1f} s simulated in {:.2f} s wall: {} ({} during sweeps); {:.1f} s wall "
             "in all, via {}\n",
             r.simulated_s, r.wall_s, speedText(r.realtime_factor), speedText(r.sweep_realtime_factor),
             r.session_wall_s, gatherLinkName(r.link));
}

void runGatherCommand(const GatherArgs& a) {
  const GatherOptions opt = gatherOptionsFrom(a);
  const GatherResult r = runGather(opt);
  if (!a.eeprom.empty()) {
    hex::writeIntelHexFile(a.eeprom, r.eeprom);
    recordGatheredMotors(a.eeprom, opt.preset, opt.variation, opt.slots, opt.seeds);
    stderrProgress(fmt::format("EEPROM saved: {} (its motors: {})", a.eeprom, eepromMotorsPath(a.eeprom)));
  }
  nlohmann::json j = r.toJson();
  j["scenario"] = "gather";
  j["preset"] = opt.preset;
  j["eeprom"] = a.eeprom;
  writeJson(a.json, j);
  printGather(r, opt.model == GatherModel::kModelV2);
}

void addGather(CLI::App& sim) {
  auto* cmd = sim.add_subcommand(
      "gather",
      "Calibrate simulated motors with the real gather_store image on the thesis bench:\n"
      "motor K, plate 60, cal W (motor + propeller weight), sweep on a full 3S LiPo -> store 1,\n"
      "sweep on a bench supply (or a drained pack) -> store 2, show. Saves the EEPROM as Intel\n"
      "HEX and reports the stored curves against the plant's true steady-state thrust.\n"
      "--model v2: store v2 after each sweep instead (fit, then refine); the stored model v2 is\n"
      "checked at each sweep's resting voltage (JSON: calibration.v2.*).\n"
      "The board boots from the Mega2560's bootloader behind a pty and is driven by the same\n"
      "client code as `thrustcal board calibrate` (--via in-process: typed straight into the\n"
      "simulated UART, reproducible byte for byte).");
  auto a = std::make_shared<GatherArgs>();
  a->o.elf_path = defaultElf("gather_store");
  declareGatherOptions(cmd, *a);
  cmd->callback([a] { guarded([&] { runGatherCommand(*a); }); });
}

// What `sim liftoff` reads from its command line.
struct LiftoffArgs {
  LiftoffOptions o;
  std::string eeprom, json, out_dir, mode = "both", label, via = "pty";
  bool uncalibrated = false;
  std::vector<uint64_t> seeds{1, 2, 3, 4};
};

void declareLiftoffOptions(CLI::App* cmd, LiftoffArgs& a) {
  LiftoffOptions* o = &a.o;
  cmd->add_option("--via", a.via, "pty (bootloader + pty + the board client) or in-process")
      ->check(CLI::IsMember({"pty", "in-process"}))
      ->capture_default_str();
  cmd->add_option("--elf", o->elf_path, "read_run ELF image")->capture_default_str();
  cmd->add_option("--eeprom", a.eeprom, "Intel HEX EEPROM image with the four calibrated slots")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--seeds", a.seeds, "the four motors' seeds, slot 0..3 (as given to gather)")
      ->delimiter(',')
      ->expected(4)
      ->capture_default_str();
  cmd->add_option("--preset", o->preset, "motor + propeller preset")->capture_default_str();
  cmd->add_option("--variation", o->variation, "part-to-part spread (same as at gather)")
      ->capture_default_str();
  cmd->add_option("--force", o->force_g, "force per motor in g")->capture_default_str();
  cmd->add_option("--ramp-ms", o->ramp_ms, "ramp time")->capture_default_str();
  cmd->add_option("--hold-ms", o->hold_ms, "hold time")->capture_default_str();
  cmd->add_option("--soc", o->lipo_soc, "LiPo state of charge at take-off (0..1)")
      ->capture_default_str();
  cmd->add_option("--mode", a.mode, "calibrated, uncalibrated or both")
      ->check(CLI::IsMember({"calibrated", "uncalibrated", "both"}))
      ->capture_default_str();
  cmd->add_flag("--uncalibrated", a.uncalibrated, "same as --mode uncalibrated");
  cmd->add_option("--label", a.label,
                  "name of the calibrated run: JSON liftoff.NAME, CSV liftoff_NAME.csv (e.g. v2 "
                  "for an EEPROM from gather --model v2)")
      ->check([](const std::string& v) {
        return v.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789_") == std::string::npos
                   ? std::string()
                   : std::string("use lower-case letters, digits and _ only");
      });
  cmd->add_flag("--dyn", o->dyn, "equal dynamics: the v2 records with the plant's dynamics, read_run's dyn on");
  cmd->add_option("--reference-slot", o->reference_slot,
                  "uncalibrated: the slot whose record all four motors use")
      ->capture_default_str();
  cmd->add_option("--out-dir", a.out_dir,
                  "write liftoff_calibrated.csv / liftoff_uncalibrated.csv (10 ms time series)");
  cmd->add_option("--json", a.json,
                  "results as JSON: liftoff.<mode>.{thrust_spread_pct,force_error_rms_pct,...}, "
                  "sim.realtime_factor");
}

// One lift-off of `mode` (calibrated or uncalibrated); `name` is its JSON key and CSV name.
LiftoffResult flyLiftoffMode(const LiftoffArgs& a, const std::string& mode, std::string& name) {
  LiftoffOptions opt = a.o;
  for (int i = 0; i < 4; ++i) opt.seeds[i] = a.seeds[i];
  opt.eeprom = loadEepromOrErased(a.eeprom, true);
  opt.link = a.via == "in-process" ? GatherLink::kInProcess : GatherLink::kPty;
  opt.uncalibrated = mode == "uncalibrated";
  if (!opt.uncalibrated) opt.label = a.label;
  name = opt.label.empty() ? mode : opt.label;
  if (!a.out_dir.empty())
    opt.csv_path = (fs::path(a.out_dir) / fmt::format("liftoff_{}.csv", name)).string();
  return runLiftoff(opt);
}

void runLiftoffCommand(const LiftoffArgs& a) {
  const std::string m = a.uncalibrated ? "uncalibrated" : a.mode;
  const std::vector<std::string> modes =
      m == "both" ? std::vector<std::string>{"calibrated", "uncalibrated"} : std::vector<std::string>{m};
  if (!a.out_dir.empty()) fs::create_directories(a.out_dir);
  nlohmann::json j;
  j["scenario"] = "liftoff";
  double sim_s = 0, wall_s = 0, session_s = 0;
  for (const auto& mm : modes) {
    std::string name;
    const LiftoffResult r = flyLiftoffMode(a, mm, name);
    j["liftoff"][name] = r.toJson();
    sim_s += r.simulated_s;
    wall_s += r.wall_s;
    session_s += r.session_wall_s;
    fmt::print("liftoff {}: thrust {:.1f} {:.1f} {:.1f} {:.1f} g for {:.0f} g: spread {:.2f} % "
               "(ramp {:.2f} %), rms error {:.2f} %, tilt {:.2f} deg (max {:.2f})\n", name, r.hold_thrust_g[0],
               r.hold_thrust_g[1], r.hold_thrust_g[2], r.hold_thrust_g[3], r.force_g, r.thrust_spread_pct,
               r.ramp_spread_pct, r.force_error_rms_pct, r.hold_tilt_deg, r.max_tilt_deg);
  }
  j["sim"] = {{"realtime_factor", wall_s > 0 ? sim_s / wall_s : 0},
              {"simulated_s", sim_s},
              {"wall_s", wall_s}};
  writeJson(a.json, j);
  fmt::print("sim: {:.1f} s simulated in {:.2f} s wall: {}; {:.1f} s wall in all, via {}\n",
             sim_s, wall_s, speedText(wall_s > 0 ? sim_s / wall_s : 0), session_s, a.via);
}

void addLiftoff(CLI::App& sim) {
  auto* cmd = sim.add_subcommand(
      "liftoff",
      "Fly the thesis's tethered lift-off with the real read_run image: four varied motors on a\n"
      "quad frame tied to the floor, one LiPo, 'liftoff G RAMP HOLD', no attitude controller.\n"
      "calibrated: each slot's own record; uncalibrated: the reference slot's record in all\n"
      "four slots, so every ESC gets the same PWM (one generic curve). Reports per-motor thrust\n"
      "in the hold, their spread, the force error, moments and tilt. The board boots from the\n"
      "Mega2560's bootloader behind a pty and `thrustcal board liftoff`'s client flies it\n"
      "(--via in-process: typed into the simulated UART, reproducible byte for byte).");
  auto a = std::make_shared<LiftoffArgs>();
  a->o.elf_path = defaultElf("read_run");
  declareLiftoffOptions(cmd, *a);
  cmd->callback([a] { guarded([&] { runLiftoffCommand(*a); }); });
}

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

void addConsole(CLI::App& sim) {
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

void addBoard(CLI::App& sim) {
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

}  // namespace

void registerCommands(CLI::App& app) {
  auto* sim = app.add_subcommand(
      "sim",
      "The virtual bench: the real firmware images in a simulated ATmega2560 (simavr) wired to\n"
      "the plant model. Deterministic (simulated time only; same seed, same result).");
  sim->require_subcommand(1);
  addGather(*sim);
  addLiftoff(*sim);
  addConsole(*sim);
  addBoard(*sim);
  addFleetCommand(*sim);
  addRunCommand(*sim);
  addImuCommand(*sim);
  addSwapCommand(*sim);
  addDynCommand(*sim);
}

}  // namespace sim
