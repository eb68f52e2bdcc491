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
#include "sim/board.hpp"
#include "sim/intel_hex.hpp"
#include "sim/pty_bridge.hpp"
#include "sim/rigs.hpp"
#include "sim/scenarios.hpp"
#include "sim/sim_board.hpp"

namespace sim {
namespace {

namespace fs = std::filesystem;

// Where the AVR images are by default: $THRUSTCAL_AVR_BUILD_DIR, else <source>/build/avr.
std::string defaultElf(const std::string& name) {
  std::vector<fs::path> dirs;
  if (const char* env = std::getenv("THRUSTCAL_AVR_BUILD_DIR")) dirs.emplace_back(env);
  dirs.emplace_back((fs::path(THRUSTCAL_SOURCE_DIR) / "build" / "avr").lexically_normal());
  for (const auto& d : dirs)
    for (const auto& p : {d / "firmware" / name / (name + ".elf"), d / "firmware" / (name + ".elf")})
      if (fs::exists(p)) return p.string();
  return (dirs.back() / "firmware" / name / (name + ".elf")).string();
}

std::vector<uint8_t> loadEepromOrErased(const std::string& path, bool must_exist) {
  if (path.empty() || (!must_exist && !fs::exists(path)))
    return std::vector<uint8_t>(kEepromBytes, 0xFF);
  return readIntelHexFile(path, kEepromBytes);
}

void writeJson(const std::string& path, const nlohmann::json& j) {
  if (path.empty()) return;
  if (fs::path(path).has_parent_path()) fs::create_directories(fs::path(path).parent_path());
  std::ofstream out(path, std::ios::trunc);
  if (!out) throw std::runtime_error(fmt::format("{}: cannot write the JSON result", path));
  out << j.dump(2) << "\n";
}

// Runs `body`, turning any exception into a message on stderr and exit code 1.
template <class F>
void guarded(F&& body) {
  try {
    body();
  } catch (const std::exception& e) {
    fmt::print(stderr, "thrustcal sim: error: {}\n", e.what());
    std::exit(1);
  }
}

std::atomic<bool> g_stop{false};
extern "C" void onSignal(int) { g_stop = true; }

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
  auto o = std::make_shared<GatherOptions>();
  auto eeprom = std::make_shared<std::string>();
  auto json = std::make_shared<std::string>();
  auto second = std::make_shared<std::string>("supply");
  auto model = std::make_shared<std::string>("v1");
  auto via = std::make_shared<std::string>("pty");
  auto range = std::make_shared<std::vector<int>>();
  o->elf_path = defaultElf("gather_store");
  cmd->add_option("--via", *via,
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
  auto slots = std::make_shared<std::vector<int>>();
  cmd->add_option("--slot,--slots", *slots, "EEPROM slot / ESC output per seed (0..3); "
                                               "default 0, 1, 2, ... in seed order")
      ->delimiter(',');
  cmd->add_option("--variation", o->variation, "part-to-part spread (relative sigma)")
      ->capture_default_str();
  cmd->add_option("--eeprom", *eeprom,
                  "Intel HEX EEPROM image: read if it exists (other slots are kept), written "
                  "after the run (thrustcal board eeprom put puts it on a real board)");
  cmd->add_option("--log-dir", o->log_dir,
                  "write gather_slotK_curve{1,2}.csv (the streamed sweeps + current_a, rpm, temp_c) and "
                  "gather_slotK_curves.csv (stored vs true PWM per gram)");
  cmd->add_option("--json", *json, "results as JSON (calibration.curve_error_max_g, sim.*)");
  cmd->add_option("--range", *range,
                  fmt::format("sweep PWM range MIN MAX in us (default {} {}: the 13 sag bins of "
                              "40 us then span {}..{} us, where the motors fly)",
                              o->pwm_min_us, o->pwm_max_us, o->pwm_min_us, o->pwm_min_us + 520))
      ->expected(2);
  cmd->add_option("--step", o->step_us, "sweep step in us")->capture_default_str();
  cmd->add_option("--settle", o->settle_ms,
                  "settle time per step in ms (thesis: 200, which leaves the bench's low-pass "
                  "~1 % behind each step)")
      ->capture_default_str();
  cmd->add_option("--second", *second, "curve 2 source: supply (bench supply) or drained (pack)")
      ->check(CLI::IsMember({"supply", "drained"}))
      ->capture_default_str();
  cmd->add_option("--model", *model,
                  "what to store: v1 (the thesis's curves: store 1, store 2) or v2 (store v2 "
                  "after each sweep)")
      ->check(CLI::IsMember({"v1", "v2"}))
      ->capture_default_str();
  cmd->add_option("--supply-v", o->supply_v, "bench supply voltage for curve 2")
      ->capture_default_str();
  cmd->add_option("--drained-soc", o->drained_soc, "pack charge (0..1) for --second drained")
      ->capture_default_str();
  cmd->callback([=] {
    guarded([&] {
      GatherOptions opt = *o;
      if (range->size() == 2) {
        opt.pwm_min_us = (*range)[0];
        opt.pwm_max_us = (*range)[1];
      }
      opt.slots = *slots;
      if (opt.slots.empty())
        for (std::size_t i = 0; i < opt.seeds.size(); ++i) opt.slots.push_back(static_cast<int>(i));
      opt.second = *second == "drained" ? SecondCurveSource::kDrainedPack
                                        : SecondCurveSource::kBenchSupply;
      opt.model = *model == "v2" ? GatherModel::kModelV2 : GatherModel::kThesisV1;
      opt.link = *via == "in-process" ? GatherLink::kInProcess : GatherLink::kPty;
      opt.eeprom = loadEepromOrErased(*eeprom, false);
      const GatherResult r = runGather(opt);
      if (!eeprom->empty()) {
        writeIntelHexFile(*eeprom, r.eeprom);
        stderrProgress(fmt::format("EEPROM saved: {}", *eeprom));
      }
      nlohmann::json j = r.toJson();
      j["scenario"] = "gather";
      j["preset"] = opt.preset;
      j["eeprom"] = *eeprom;
      writeJson(*json, j);
      const bool v2 = opt.model == GatherModel::kModelV2;
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
      fmt::print("sim: {:.1f} s simulated in {:.2f} s wall: {:.1f}x real time ({:.1f}x during "
                 "sweeps); {:.1f} s wall in all, via {}\n",
                 r.simulated_s, r.wall_s, r.realtime_factor, r.sweep_realtime_factor,
                 r.session_wall_s, gatherLinkName(r.link));
    });
  });
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
  auto o = std::make_shared<LiftoffOptions>();
  auto eeprom = std::make_shared<std::string>();
  auto json = std::make_shared<std::string>();
  auto out_dir = std::make_shared<std::string>();
  auto mode = std::make_shared<std::string>("both");
  auto uncal = std::make_shared<bool>(false);
  auto label = std::make_shared<std::string>();
  auto seeds = std::make_shared<std::vector<uint64_t>>(std::vector<uint64_t>{1, 2, 3, 4});
  auto via = std::make_shared<std::string>("pty");
  o->elf_path = defaultElf("read_run");
  cmd->add_option("--via", *via, "pty (bootloader + pty + the board client) or in-process")
      ->check(CLI::IsMember({"pty", "in-process"}))
      ->capture_default_str();
  cmd->add_option("--elf", o->elf_path, "read_run ELF image")->capture_default_str();
  cmd->add_option("--eeprom", *eeprom, "Intel HEX EEPROM image with the four calibrated slots")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--seeds", *seeds, "the four motors' seeds, slot 0..3 (as given to gather)")
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
  cmd->add_option("--mode", *mode, "calibrated, uncalibrated or both")
      ->check(CLI::IsMember({"calibrated", "uncalibrated", "both"}))
      ->capture_default_str();
  cmd->add_flag("--uncalibrated", *uncal, "same as --mode uncalibrated");
  cmd->add_option("--label", *label,
                  "name of the calibrated run: JSON liftoff.NAME, CSV liftoff_NAME.csv (e.g. v2 "
                  "for an EEPROM from gather --model v2)")
      ->check([](const std::string& v) {
        return v.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789_") == std::string::npos
                   ? std::string()
                   : std::string("use lower-case letters, digits and _ only");
      });
  cmd->add_option("--reference-slot", o->reference_slot,
                  "uncalibrated: the slot whose record all four motors use")
      ->capture_default_str();
  cmd->add_option("--out-dir", *out_dir,
                  "write liftoff_calibrated.csv / liftoff_uncalibrated.csv (10 ms time series)");
  cmd->add_option("--json", *json,
                  "results as JSON: liftoff.<mode>.{thrust_spread_pct,force_error_rms_pct,...}, "
                  "sim.realtime_factor");
  cmd->callback([=] {
    guarded([&] {
      std::vector<std::string> modes;
      const std::string m = *uncal ? "uncalibrated" : *mode;
      if (m == "both") modes = {"calibrated", "uncalibrated"};
      else modes = {m};
      if (!out_dir->empty()) fs::create_directories(*out_dir);
      nlohmann::json j;
      j["scenario"] = "liftoff";
      double sim_s = 0, wall_s = 0, session_s = 0;
      for (const auto& mm : modes) {
        LiftoffOptions opt = *o;
        for (int i = 0; i < 4; ++i) opt.seeds[i] = (*seeds)[i];
        opt.eeprom = loadEepromOrErased(*eeprom, true);
        opt.link = *via == "in-process" ? GatherLink::kInProcess : GatherLink::kPty;
        opt.uncalibrated = mm == "uncalibrated";
        if (!opt.uncalibrated) opt.label = *label;
        const std::string name = opt.label.empty() ? mm : opt.label;
        if (!out_dir->empty())
          opt.csv_path = (fs::path(*out_dir) / fmt::format("liftoff_{}.csv", name)).string();
        const LiftoffResult r = runLiftoff(opt);
        j["liftoff"][name] = r.toJson();
        sim_s += r.simulated_s;
        wall_s += r.wall_s;
        session_s += r.session_wall_s;
        fmt::print("liftoff {}: thrust {:.1f} {:.1f} {:.1f} {:.1f} g for {:.0f} g: spread {:.2f} %, "
                   "rms error {:.2f} %, tilt {:.2f} deg (max {:.2f})\n",
                   name, r.hold_thrust_g[0], r.hold_thrust_g[1], r.hold_thrust_g[2],
                   r.hold_thrust_g[3], r.force_g, r.thrust_spread_pct, r.force_error_rms_pct,
                   r.hold_tilt_deg, r.max_tilt_deg);
      }
      j["sim"] = {{"realtime_factor", wall_s > 0 ? sim_s / wall_s : 0},
                  {"simulated_s", sim_s},
                  {"wall_s", wall_s}};
      writeJson(*json, j);
      fmt::print("sim: {:.1f} s simulated in {:.2f} s wall: {:.1f}x real time; {:.1f} s wall in "
                 "all, via {}\n",
                 sim_s, wall_s, wall_s > 0 ? sim_s / wall_s : 0, session_s, *via);
    });
  });
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
  auto elf = std::make_shared<std::string>(defaultElf("gather_store"));
  auto eeprom = std::make_shared<std::string>();
  auto rig = std::make_shared<std::string>("auto");
  auto preset = std::make_shared<std::string>("kv1100_9x4.7");
  auto seeds = std::make_shared<std::vector<uint64_t>>(std::vector<uint64_t>{1, 2, 3, 4});
  auto speed = std::make_shared<double>(1.0);
  auto duration = std::make_shared<double>(0.0);
  auto read_only = std::make_shared<bool>(false);
  auto slot = std::make_shared<int>(0);
  cmd->add_option("--elf", *elf, "firmware ELF image")->capture_default_str();
  cmd->add_option("--eeprom", *eeprom, "Intel HEX EEPROM image (loaded if it exists, saved at exit)");
  cmd->add_option("--rig", *rig, "bench, quad, seesaw, gimbal or auto (bench for gather_store, quad "
                                 "otherwise)")
      ->check(CLI::IsMember({"auto", "bench", "quad", "seesaw", "gimbal"}))
      ->capture_default_str();
  auto air = std::make_shared<AirCliOptions>();
  addAirOptions(cmd, *air);
  cmd->add_option("--preset", *preset, "motor + propeller preset")->capture_default_str();
  cmd->add_option("--slot", *slot, "bench: the ESC output (0..3) the motor is wired to; select "
                                   "it with 'motor N' in gather_store")
      ->check(CLI::Range(0, 3))
      ->capture_default_str();
  cmd->add_option("--seeds", *seeds, "motor seeds (bench: the first; quad: slot 0..3)")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--speed", *speed, "simulated seconds per wall second (0: as fast as possible)")
      ->capture_default_str();
  cmd->add_option("--duration", *duration, "stop after this many simulated seconds (0: Ctrl-C)")
      ->capture_default_str();
  cmd->add_flag("--read-only", *read_only, "do not write the EEPROM back");
  cmd->callback([=] {
    guarded([&] {
      std::string which = *rig;
      if (which == "auto")
        which = fs::path(*elf).filename().string().find("gather") != std::string::npos ? "bench"
                                                                                       : "quad";
      const auto image = loadEepromOrErased(*eeprom, false);
      std::unique_ptr<BenchRig> bench;
      std::unique_ptr<QuadRig> quad;
      std::unique_ptr<AirframeRig> airframe;
      Board* board = nullptr;
      if (isAirRig(which)) {
        airframe = makeAirframeRig(*elf, which, *preset, *seeds, *air);
        board = &airframe->board();
      } else if (which == "bench") {
        plant::BenchParams p = plant::BenchParams::thesis(*preset);
        p.actuator = motorForSeed(*preset, seeds->at(0), 0.03);
        bench = std::make_unique<BenchRig>(*elf, p, *slot);
        board = &bench->board;
      } else {
        std::array<plant::ActuatorParams, 4> motors;
        for (int i = 0; i < 4; ++i)
          motors[i] = motorForSeed(*preset, seeds->size() > static_cast<std::size_t>(i) ? (*seeds)[i] : i + 1, 0.03);
        plant::QuadFrameParams qp;
        quad = std::make_unique<QuadRig>(*elf, qp, motors);
        board = &quad->board;
      }
      board->setEeprom(image);
      std::unique_ptr<StillAirframe> still;
      if (!airframe) still = std::make_unique<StillAirframe>(*board, which, *air);
      if (airframe) fmt::print("rig: {}\n", airframe->describe());
      PtyBridge pty(*board);
      fmt::print("simulated board ({}, {} rig) on {}\n", fs::path(*elf).filename().string(), which,
                 pty.path());
      fmt::print("open it with:  screen {0} {1}   or   picocom -b {1} {0}\n", pty.path(),
                 hal::kUartBaud);
      fmt::print("Ctrl-C here ends the simulation{}.\n",
                 *read_only || eeprom->empty() ? "" : " and saves the EEPROM to " + *eeprom);
      std::fflush(stdout);
      std::signal(SIGINT, onSignal);
      std::signal(SIGTERM, onSignal);
      pty.run(*speed, *duration, g_stop);
      if (!*read_only && !eeprom->empty()) {
        writeIntelHexFile(*eeprom, board->eeprom());
        fmt::print("EEPROM saved: {}\n", *eeprom);
      }
      fmt::print("{:.1f} s simulated (paced at {:g}x; the simulation alone ran at {:.0f}x real "
                 "time)\n",
                 board->simulatedSeconds(), *speed, board->realtimeFactor());
      for (const auto& f : airframe ? airframe->faultsApplied() : still->faultsApplied())
        fmt::print("fault applied: {}\n", f);
      if (!air->log.empty()) fmt::print("truth log: {}\n", air->log);
    });
  });
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
  auto o = std::make_shared<SimBoardOptions>();
  auto elf = std::make_shared<std::string>();
  auto hex = std::make_shared<std::string>();
  auto eeprom = std::make_shared<std::string>();
  auto link = std::make_shared<std::string>();
  auto pacing = std::make_shared<Pacing>();
  auto duration = std::make_shared<double>(0.0);
  auto read_only = std::make_shared<bool>(false);
  auto quiet = std::make_shared<bool>(false);
  cmd->add_option("--bootloader", o->bootloader_hex, "bootloader Intel HEX")->capture_default_str();
  auto* elf_opt = cmd->add_option("--elf", *elf, "application already in flash (ELF image)");
  cmd->add_option("--hex", *hex, "application already in flash (Intel HEX)")->excludes(elf_opt);
  cmd->add_option("--eeprom", *eeprom, "Intel HEX EEPROM image (loaded if it exists, saved at exit)");
  cmd->add_option("--link", *link, "also make this symlink to the pty (a stable port name)");
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
  cmd->add_option("--idle-speed", pacing->idle_speed,
                  "simulated s per wall s while idle (1: the bootloader's timeout is real)")
      ->capture_default_str();
  cmd->add_option("--busy-speed", pacing->busy_speed,
                  "simulated s per wall s while bytes flow (0: as fast as possible; 1: a real "
                  "board's timing)")
      ->capture_default_str();
  cmd->add_option("--duration", *duration, "stop after this many simulated seconds (0: Ctrl-C)")
      ->capture_default_str();
  cmd->add_flag("--read-only", *read_only, "do not write the EEPROM back");
  cmd->add_flag("--quiet", *quiet, "no event lines (resets, clients)");
  cmd->callback([=] {
    guarded([&] {
      SimBoardOptions opt = *o;
      opt.application = !elf->empty() ? *elf : *hex;
      opt.eeprom = loadEepromOrErased(*eeprom, false);
      opt.pty.link_path = *link;
      if (!*quiet) opt.pty.log = [](const std::string& l) {
        std::fprintf(stderr, "sim board: %s\n", l.c_str());
        std::fflush(stderr);
      };
      SimBoard sb(opt);
      const std::string port = sb.link().port();
      fmt::print("simulated Mega2560 on {}{}\n", sb.link().path(),
                 link->empty() ? "" : fmt::format(" (link {})", *link));
      fmt::print("  bootloader {} at 0x{:05X}; application: {}\n", opt.bootloader_hex,
                 sb.board().resetAddress(), flashAppName(sb.app()));
      fmt::print("  plant: {}\n", sb.rigText());
      fmt::print("use it as the board's port:\n");
      fmt::print("  thrustcal board flash --port {} build/avr/firmware/gather_store/gather_store.hex\n", port);
      fmt::print("  avrdude -p m2560 -c wiring -P {} -b {} -D -U flash:w:IMAGE.hex:i\n", port,
                 hal::kBootloaderBaud);
      fmt::print("  screen {} {}\n", port, hal::kUartBaud);
      fmt::print("Ctrl-C here ends the simulation{}.\n",
                 *read_only || eeprom->empty() ? "" : " and saves the EEPROM to " + *eeprom);
      std::fflush(stdout);
      std::signal(SIGINT, onSignal);
      std::signal(SIGTERM, onSignal);
      sb.link().run(*pacing, *duration, g_stop);
      if (!*read_only && !eeprom->empty()) {
        writeIntelHexFile(*eeprom, sb.board().eeprom());
        fmt::print("EEPROM saved: {}\n", *eeprom);
      }
      fmt::print("{:.1f} s simulated, {} reset(s) by clients; the simulation alone ran at {:.1f}x "
                 "real time\n",
                 sb.board().simulatedSeconds(), sb.link().clientResets(),
                 sb.board().realtimeFactor());
    });
  });
}

void addFleet(CLI::App& sim) {
  auto* cmd = sim.add_subcommand(
      "fleet",
      "The whole virtual-bench story in one run (what tools/demo.sh shows): calibrate four varied\n"
      "motors into slots 0..3 with gather_store (both curves each), then fly the tethered\n"
      "lift-off with read_run calibrated and uncalibrated. Writes into --out-dir:\n"
      "  sim_summary.json   calibration.curve_error_max_g, calibration.motors[],\n"
      "                     liftoff.{calibrated,uncalibrated}.{thrust_spread_pct,\n"
      "                     force_error_rms_pct,hold_thrust_g,...}, sim.realtime_factor\n"
      "  eeprom.hex         the calibrated EEPROM (thrustcal board eeprom put --port P eeprom.hex)\n"
      "  gather_slotK_curve1.csv, gather_slotK_curve2.csv   the streamed sweeps\n"
      "  gather_slotK_curves.csv                            stored vs true PWM per gram\n"
      "  liftoff_calibrated.csv, liftoff_uncalibrated.csv   10 ms time series");
  auto g = std::make_shared<GatherOptions>();
  auto l = std::make_shared<LiftoffOptions>();
  auto out_dir = std::make_shared<std::string>("build/demo");
  auto seeds = std::make_shared<std::vector<uint64_t>>(std::vector<uint64_t>{11, 12, 13, 14});
  g->elf_path = defaultElf("gather_store");
  l->elf_path = defaultElf("read_run");
  cmd->add_option("--gather-elf", g->elf_path, "gather_store ELF image")->capture_default_str();
  cmd->add_option("--read-run-elf", l->elf_path, "read_run ELF image")->capture_default_str();
  cmd->add_option("--seeds", *seeds, "the four motors (slot 0..3)")
      ->delimiter(',')
      ->expected(4)
      ->capture_default_str();
  cmd->add_option("--preset", g->preset, "motor + propeller preset")->capture_default_str();
  cmd->add_option("--variation", g->variation, "part-to-part spread")->capture_default_str();
  cmd->add_option("--settle", g->settle_ms, "gather settle time per step in ms")
      ->capture_default_str();
  cmd->add_option("--force", l->force_g, "lift-off force per motor in g")->capture_default_str();
  cmd->add_option("--hold-ms", l->hold_ms, "lift-off hold time")->capture_default_str();
  cmd->add_option("--out-dir", *out_dir, "where every output goes")->capture_default_str();
  cmd->callback([=] {
    guarded([&] {
      fs::create_directories(*out_dir);
      GatherOptions go = *g;
      go.seeds = *seeds;
      go.slots = {0, 1, 2, 3};
      go.log_dir = *out_dir;
      go.eeprom = std::vector<uint8_t>(kEepromBytes, 0xFF);
      const GatherResult gr = runGather(go);
      const std::string eeprom_path = (fs::path(*out_dir) / "eeprom.hex").string();
      writeIntelHexFile(eeprom_path, gr.eeprom);
      nlohmann::json j = gr.toJson();
      double sim_s = gr.simulated_s, wall_s = gr.wall_s;
      for (const bool uncal : {false, true}) {
        LiftoffOptions lo = *l;
        lo.preset = go.preset;
        lo.variation = go.variation;
        for (int i = 0; i < 4; ++i) lo.seeds[i] = (*seeds)[i];
        lo.eeprom = gr.eeprom;
        lo.uncalibrated = uncal;
        lo.csv_path = (fs::path(*out_dir) / (uncal ? "liftoff_uncalibrated.csv"
                                                    : "liftoff_calibrated.csv")).string();
        const LiftoffResult lr = runLiftoff(lo);
        j["liftoff"][lr.mode] = lr.toJson();
        sim_s += lr.simulated_s;
        wall_s += lr.wall_s;
      }
      j["scenario"] = "fleet";
      j["preset"] = go.preset;
      j["seeds"] = *seeds;
      j["eeprom"] = eeprom_path;
      j["sim"]["realtime_factor"] = wall_s > 0 ? sim_s / wall_s : 0;
      j["sim"]["simulated_s"] = sim_s;
      j["sim"]["wall_s"] = wall_s;
      const std::string json_path = (fs::path(*out_dir) / "sim_summary.json").string();
      writeJson(json_path, j);
      const auto& c = j["liftoff"]["calibrated"];
      const auto& u = j["liftoff"]["uncalibrated"];
      fmt::print("stored curves vs plant: max error {:.2f} g\n", gr.curve_error_max_g);
      fmt::print("lift-off {:.0f} g per motor   thrust spread   force error rms   max tilt\n",
                 l->force_g);
      fmt::print("  calibrated          {:8.2f} %      {:8.2f} %    {:6.2f} deg\n",
                 c["thrust_spread_pct"].get<double>(), c["force_error_rms_pct"].get<double>(),
                 c["max_tilt_deg"].get<double>());
      fmt::print("  uncalibrated        {:8.2f} %      {:8.2f} %    {:6.2f} deg\n",
                 u["thrust_spread_pct"].get<double>(), u["force_error_rms_pct"].get<double>(),
                 u["max_tilt_deg"].get<double>());
      fmt::print("sim: {:.1f} s simulated in {:.2f} s wall: {:.1f}x real time ({:.1f}x during "
                 "sweeps)\nresults: {}\n",
                 sim_s, wall_s, wall_s > 0 ? sim_s / wall_s : 0, gr.sweep_realtime_factor,
                 json_path);
    });
  });
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
  addFleet(*sim);
  addRunCommand(*sim);
  addImuCommand(*sim);
}

}  // namespace sim
