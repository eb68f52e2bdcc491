// `thrustcal sim swap`: the swap experiment on the command line (sim/swap.hpp, sim/swap_report.hpp).
#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>

#include "sim/cli.hpp"
#include "sim/swap.hpp"
#include "sim/swap_report.hpp"
#include "cli_support.hpp"

namespace sim {

namespace {

namespace fs = std::filesystem;

// What `sim swap` reads from its command line.
struct SwapArgs {
  swap::SwapOptions o;
  std::string json, model = "v2";
  std::vector<std::string> rigs = {"seesaw", "gimbal"}, modes = {"force", "force+dyn", "generic", "pwm", "ardupilot"},
                           gains = {"pd", "pid"};
  bool quick = false, no_plots = false, peer_only = false;
  std::string peer;
};

// How each flight measures: its steps, and the part's weight alone (a diagnostic).
void declareStepOptions(CLI::App* cmd, swap::SwapOptions* o) {
  cmd->add_option("--steps", o->steps,
                  "up-steps per flight, each back to level for --window-s before the next; a run's figures "
                  "are the means over its steps (one step's rise time scatters by about 1 % with the same motors)")
      ->check(CLI::Range(1, 20))
      ->capture_default_str();
  cmd->add_option("--dyn-steps", o->dyn_steps,
                  "force+dyn's up-steps per flight (default: --steps); its 1 % rise-time target is finer than "
                  "one step's scatter, the mean of 8 measures a run to about 0.4 %")
      ->check(CLI::Range(1, 20));
  cmd->add_flag("--no-reaction-torque", o->no_reaction_torque,
                "diagnostic: the rotors push the rig with their thrust alone, without their drag and spin-up "
                "torques about its z axis: what a part's torque-to-thrust ratio does through the yaw balance");
  cmd->add_flag("--part-mass-only", o->part_mass_only,
                "diagnostic: each part's runs fly the stock motor 1 carrying the part's motor and propeller "
                "masses (and the seesaw's counterweight) on the stock records: what the part changes in the rig alone");
}

void declareSwapOptions(CLI::App* cmd, SwapArgs& a) {
  swap::SwapOptions* o = &a.o;
  cmd->add_option(
      "--json", a.json,
      "results as JSON: runs[] (rig, mode, part, axis, step_deg, seed, rise_s, overshoot_pct, "
      "settling_s, sse_deg, itae, integrator, hover_pwm_spread_us) and targets[] (target, figure, "
      "wanted, met)");
  cmd->add_option("--out-dir", o->out_dir,
                  "cached calibrations (calibration/), every run's time series (series/*.csv), plots")
      ->capture_default_str();
  cmd->add_flag("--quick", a.quick,
                "one IMU unit, modes force and pwm, PD gains only (tools/demo.sh flies every mode with "
                "--imu-seeds 1 --gains pd)");
  cmd->add_option("--rigs", a.rigs, "seesaw and/or gimbal")
      ->delimiter(',')
      ->check(CLI::IsMember({"seesaw", "gimbal"}))
      ->capture_default_str();
  cmd->add_option("--modes", a.modes,
                  "fly's output modes to compare (force+dyn: force with each motor's dynamics in its record "
                  "and `dyn on`)")
      ->delimiter(',')
      ->check(CLI::IsMember({"force", "force+dyn", "generic", "pwm", "ardupilot"}))
      ->capture_default_str();
  cmd->add_option("--dyn-from", o->dyn_from,
                  "force+dyn: the records' dynamics from gather_store's dyn on the virtual bench (gather, "
                  "cached in --out-dir) or the plant's own time constants (plant)")
      ->check(CLI::IsMember({"gather", "plant"}))
      ->capture_default_str();
  cmd->add_option("--dyn-ref", o->dyn_reference_ms,
                  "force+dyn: fly's `dyn on MS MS`, a fixed reference lag no faster than any motor's; 0: "
                  "`dyn on`, the slowest motor's (which a swap changes)")
      ->check(CLI::Range(0, 2000))
      ->capture_default_str();
  cmd->add_option("--parts", o->parts, "the parts that replace motor 1")
      ->delimiter(',')
      ->check(CLI::IsMember({"kv1100_9x4.7", "kv900_11x4.7", "prop-8pct"}))
      ->capture_default_str();
  cmd->add_option("--gains", a.gains, "pd (the thesis's 800 0 146 mN m) and/or pid (KI --pid-ki)")
      ->delimiter(',')
      ->check(CLI::IsMember({"pd", "pid"}))
      ->capture_default_str();
  cmd->add_option("--imu-seeds", o->imu_seeds, "the MPU-6050 units, one flight each")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--pid-ki", o->pid_ki, "integral gain of the PID runs, mN m per rad s")
      ->check(CLI::Range(1, 10000))
      ->capture_default_str();
  cmd->add_option("--model", a.model, "what gather_store stores: v2 (model v2) or v1 (the thesis's curves)")
      ->check(CLI::IsMember({"v1", "v2"}))
      ->capture_default_str();
  cmd->add_option("--step-deg", o->step_deg, "the step")->check(CLI::Range(1, 20))->capture_default_str();
  cmd->add_option("--settle-s", o->settle_s, "level flight after the spool-up, before the step")
      ->check(CLI::Range(0.2, 10.0))
      ->capture_default_str();
  cmd->add_option("--pid-settle-s", o->pid_settle_s,
                  "the same with PID gains (the integrator takes up the mismatch)")
      ->check(CLI::Range(0.2, 20.0))
      ->capture_default_str();
  cmd->add_option("--window-s", o->window_s, "simulated time after the step")
      ->check(CLI::Range(0.5, 20.0))
      ->capture_default_str();
  declareStepOptions(cmd, o);
  cmd->add_option("--jobs", o->jobs, "flights at once, each on its own simulated board")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  cmd->add_option("--gather-elf", o->gather_elf, "gather_store ELF image")->capture_default_str();
  cmd->add_option("--fly-elf", o->fly_elf, "fly ELF image")->capture_default_str();
  cmd->add_flag("--no-plots", a.no_plots, "no gnuplot");
  cmd->add_option("--peer", a.peer,
                  "a peer's profile (docs/sim.md, \"A peer in the swap\"): another firmware flown on the gimbal "
                  "with stock and every part, its runs in runs[] as mode peer:NAME");
  cmd->add_flag("--peer-only", a.peer_only, "fly only the peer (no fly mode; nothing is calibrated)");
  cmd->add_flag("--no-level", [o](std::int64_t) { o->level = false; },
                "skip fly's `level` before each flight (the IMU's zero-g offsets then tilt what it holds)");
}

swap::SwapOptions optionsFrom(const SwapArgs& a) {
  swap::SwapOptions o = a.o;
  o.rigs.clear(), o.modes.clear(), o.gains.clear();
  for (const std::string& r : a.rigs) o.rigs.push_back(r == "seesaw" ? AirRig::kSeesaw : AirRig::kGimbal);
  for (const std::string& m : a.modes) o.modes.push_back(swap::parseMode(m));
  for (const std::string& g : a.gains) o.gains.push_back(swap::parseGains(g));
  o.model = a.model == "v1" ? GatherModel::kThesisV1 : GatherModel::kModelV2;
  if (a.quick) {
    o.imu_seeds.resize(1);
    o.modes = {swap::Mode::kForce, swap::Mode::kPwm};
    o.gains = {swap::Gains::kPd};
  }
  if (!a.peer.empty()) o.peer = std::make_shared<const PeerProfile>(readPeerProfile(a.peer));
  if (a.peer_only) {
    if (!o.peer) throw std::invalid_argument("--peer-only needs --peer FILE");
    o.modes.clear();
  }
  if (o.imu_seeds.empty() || o.rigs.empty() || (o.modes.empty() && !o.peer) || o.gains.empty())
    throw std::invalid_argument("nothing to fly: give at least one rig, mode, gain set and IMU seed");
  return o;
}

void runSwapCommand(const SwapArgs& a) {
  const swap::SwapOptions o = optionsFrom(a);
  const swap::SwapResult r = swap::runSwap(o);
  fmt::print("{}", swap::formatTable(r));
  fmt::print("\n{}\n{}", swap::formatTargets(r), swap::formatDynamics(r));
  const auto& m = r.calibration.modes;
  if (!o.modes.empty())
    fmt::print(
      "modes without records: pwm hover {} us at {:.3f} g/us (the stock LiPo sweeps); ardupilot {} (the "
      "lab's "
      "fit on {} rows of the stock sweeps, RMS {:.1f} g)\n",
      m.hover_us, m.slope_g_per_us, fmt::join(m.ardupilot_lines, ", "), m.ardupilot_rows, m.ardupilot_rms_g);
  std::vector<std::string> warnings;
  const std::vector<std::string> images =
      a.no_plots ? std::vector<std::string>{} : swap::writePlots(r, o.out_dir, warnings);
  for (const std::string& w : warnings) fmt::print(stderr, "thrustcal sim swap: warning: {}\n", w);
  if (!a.json.empty()) {
    if (fs::path(a.json).has_parent_path()) fs::create_directories(fs::path(a.json).parent_path());
    std::ofstream out(a.json, std::ios::trunc);
    if (!out) throw std::runtime_error(fmt::format("{}: cannot write the JSON result", a.json));
    out << r.toJson().dump(2) << "\n";
  }
  fmt::print(
      "sim: {} flights, {:.1f} s simulated in {:.1f} s of flight ({}); {:.1f} s wall in all\n",
      r.runs.size(), r.simulated_s, r.flight_wall_s,
      speedText(r.flight_wall_s > 0 ? r.simulated_s / r.flight_wall_s : 0), r.wall_s);
  fmt::print("files: {}/series/*.csv{}{}\n", o.out_dir,
             images.empty() ? "" : ", " + fmt::format("{}", fmt::join(images, ", ")),
             a.json.empty() ? "" : ", " + a.json);
}

}  // namespace

void addSwapCommand(CLI::App& sim) {
  auto* cmd = sim.add_subcommand(
      "swap",
      "The swap experiment (issue 19; docs/fly.md, \"The swap experiment\"): calibrate four stock motors\n"
      "with gather_store on the virtual bench, fly 10-degree steps with fly on the seesaw and the gimbal\n"
      "(plus; roll and pitch) for each IMU unit, replace motor 1 (another KV1100 unit, a KV900 with an\n"
      "11x4.7 propeller, a propeller giving 8 % less thrust), calibrate only slot 1 again, fly again\n"
      "with the same gains in every mode (force, force+dyn, generic, pwm, ardupilot). Prints stock and swapped side\n"
      "by side, the targets (force mode, PD) and the motors' time constants, which no static\n"
      "calibration equalises. Calibrations are cached in --out-dir.");
  auto a = std::make_shared<SwapArgs>();
  a->o.gather_elf = defaultElf("gather_store");
  a->o.fly_elf = defaultElf("fly");
  declareSwapOptions(cmd, *a);
  cmd->callback([a] { guarded("swap", [&] { runSwapCommand(*a); }); });
}

}  // namespace sim
