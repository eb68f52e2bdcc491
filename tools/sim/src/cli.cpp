// `thrustcal sim gather|liftoff` and the `sim` command group (console and board: console_cli.cpp).
#include "sim/cli.hpp"
#include "hal/board.hpp"

#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>

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

}  // namespace

void registerCommands(CLI::App& app) {
  auto* sim = app.add_subcommand(
      "sim",
      "The virtual bench: the real firmware images in a simulated ATmega2560 (simavr) wired to\n"
      "the plant model. Deterministic (simulated time only; same seed, same result).");
  sim->require_subcommand(1);
  addGather(*sim);
  addLiftoff(*sim);
  addConsoleCommand(*sim);
  addBoardCommand(*sim);
  addFleetCommand(*sim);
  addRunCommand(*sim);
  addImuCommand(*sim);
  addSwapCommand(*sim);
  addDynCommand(*sim);
}

}  // namespace sim
