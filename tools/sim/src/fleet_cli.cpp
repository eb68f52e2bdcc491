// `thrustcal sim fleet`: the whole virtual-bench story in one run (what tools/demo.sh shows).
#include <fmt/format.h>

#include <filesystem>
#include <memory>

#include <nlohmann/json.hpp>

#include "cli_support.hpp"
#include "hal/board.hpp"
#include "hex/intel_hex.hpp"
#include "sim/board.hpp"
#include "sim/cli.hpp"
#include "sim/scenarios.hpp"

namespace sim {

namespace fs = std::filesystem;

namespace {

// What `sim fleet` reads from its command line.
struct FleetArgs {
  GatherOptions g;
  LiftoffOptions l;
  std::string out_dir = "build/demo";
  std::vector<uint64_t> seeds{11, 12, 13, 14};
};

void declareFleetOptions(CLI::App* cmd, FleetArgs& a) {
  cmd->add_option("--gather-elf", a.g.elf_path, "gather_store ELF image")->capture_default_str();
  cmd->add_option("--read-run-elf", a.l.elf_path, "read_run ELF image")->capture_default_str();
  cmd->add_option("--seeds", a.seeds, "the four motors (slot 0..3)")
      ->delimiter(',')
      ->expected(4)
      ->capture_default_str();
  cmd->add_option("--preset", a.g.preset, "motor + propeller preset")->capture_default_str();
  cmd->add_option("--variation", a.g.variation, "part-to-part spread")->capture_default_str();
  cmd->add_option("--settle", a.g.settle_ms, "gather settle time per step in ms")
      ->capture_default_str();
  cmd->add_option("--force", a.l.force_g, "lift-off force per motor in g")->capture_default_str();
  cmd->add_option("--hold-ms", a.l.hold_ms, "lift-off hold time")->capture_default_str();
  cmd->add_option("--out-dir", a.out_dir, "where every output goes")->capture_default_str();
}

// The calibrated and the uncalibrated lift-off on the gathered EEPROM, into j["liftoff"];
// adds their simulated and wall seconds.
void flyFleet(const FleetArgs& a, const GatherOptions& go, const GatherResult& gr, nlohmann::json& j,
              double& sim_s, double& wall_s) {
  for (const bool uncal : {false, true}) {
    LiftoffOptions lo = a.l;
    lo.preset = go.preset;
    lo.variation = go.variation;
    for (int i = 0; i < 4; ++i) lo.seeds[i] = a.seeds[i];
    lo.eeprom = gr.eeprom;
    lo.uncalibrated = uncal;
    lo.csv_path = (fs::path(a.out_dir) / (uncal ? "liftoff_uncalibrated.csv" : "liftoff_calibrated.csv")).string();
    const LiftoffResult lr = runLiftoff(lo);
    j["liftoff"][lr.mode] = lr.toJson();
    sim_s += lr.simulated_s;
    wall_s += lr.wall_s;
  }
}

void printFleet(const FleetArgs& a, const GatherResult& gr, const nlohmann::json& j,
                const std::string& json_path) {
  const auto& c = j["liftoff"]["calibrated"];
  const auto& u = j["liftoff"]["uncalibrated"];
  const double sim_s = j["sim"]["simulated_s"].get<double>(), wall_s = j["sim"]["wall_s"].get<double>();
  fmt::print("stored curves vs plant: max error {:.2f} g\n", gr.curve_error_max_g);
  fmt::print("lift-off {:.0f} g per motor   thrust spread   force error rms   max tilt\n", a.l.force_g);
  fmt::print("  calibrated          {:8.2f} %      {:8.2f} %    {:6.2f} deg\n",
             c["thrust_spread_pct"].get<double>(), c["force_error_rms_pct"].get<double>(),
             c["max_tilt_deg"].get<double>());
  fmt::print("  uncalibrated        {:8.2f} %      {:8.2f} %    {:6.2f} deg\n",
             u["thrust_spread_pct"].get<double>(), u["force_error_rms_pct"].get<double>(),
             u["max_tilt_deg"].get<double>());
  fmt::print("sim: {:.1f} s simulated in {:.2f} s wall: {} ({} during sweeps)\nresults: {}\n",
             sim_s, wall_s, speedText(wall_s > 0 ? sim_s / wall_s : 0), speedText(gr.sweep_realtime_factor),
             json_path);
}

void runFleetCommand(const FleetArgs& a) {
  fs::create_directories(a.out_dir);
  GatherOptions go = a.g;
  go.seeds = a.seeds;
  go.slots = {0, 1, 2, 3};
  go.log_dir = a.out_dir;
  go.eeprom = std::vector<uint8_t>(kEepromBytes, 0xFF);
  const GatherResult gr = runGather(go);
  const std::string eeprom_path = (fs::path(a.out_dir) / "eeprom.hex").string();
  hex::writeIntelHexFile(eeprom_path, gr.eeprom);
  nlohmann::json j = gr.toJson();
  double sim_s = gr.simulated_s, wall_s = gr.wall_s;
  flyFleet(a, go, gr, j, sim_s, wall_s);
  j["scenario"] = "fleet";
  j["preset"] = go.preset;
  j["seeds"] = a.seeds;
  j["eeprom"] = eeprom_path;
  j["sim"]["realtime_factor"] = wall_s > 0 ? sim_s / wall_s : 0;
  j["sim"]["simulated_s"] = sim_s;
  j["sim"]["wall_s"] = wall_s;
  const std::string json_path = (fs::path(a.out_dir) / "sim_summary.json").string();
  writeJson(json_path, j);
  printFleet(a, gr, j, json_path);
}

}  // namespace

void addFleetCommand(CLI::App& sim) {
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
  auto a = std::make_shared<FleetArgs>();
  a->g.elf_path = defaultElf("gather_store");
  a->l.elf_path = defaultElf("read_run");
  declareFleetOptions(cmd, *a);
  cmd->callback([a] { guarded([&] { runFleetCommand(*a); }); });
}


}  // namespace sim
