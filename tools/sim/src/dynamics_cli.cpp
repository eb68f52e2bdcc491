// `thrustcal sim dyn`: gather_store's dynamics session on the virtual bench for one part
// (sim/dynamics_session.hpp): every step's fitted time constant beside the plant's own, the
// stored dynamics, and the step log as gather_store streamed it (--log).
#include <fmt/format.h>

#include <cmath>
#include <fstream>
#include <memory>

#include <nlohmann/json.hpp>

#include "sim/cli.hpp"
#include "sim/dynamics_session.hpp"
#include "sim/eeprom_motors.hpp"
#include "sim/swap.hpp"
#include "cli_support.hpp"

namespace sim {

namespace {

struct DynArgs {
  DynSessionOptions o;
  std::string part = swap::kStock;
  uint64_t seed = 11;
  std::string preset = "kv1100_9x4.7";
  std::string json, eeprom;
};

nlohmann::json toJson(const DynSessionResult& r, const DynArgs& a) {
  nlohmann::json steps = nlohmann::json::array();
  for (const DynStep& s : r.steps)
    steps.push_back({{"dir", s.dir}, {"from_us", s.from_us}, {"to_us", s.to_us}, {"bus_v", s.bus_v},
                     {"ok", s.ok}, {"force_g", s.force_g}, {"tau_s", s.tau_s}, {"truth_s", s.truth_s}});
  const tc::MotorDynamics& d = r.dynamics;
  return {{"part", a.part},
          {"seed", a.seed},
          {"steps", steps},
          {"bench", {{"stages", r.bench.stages}, {"tau_ms", r.bench.tauS() * 1e3}}},
          {"stored", {{"points", d.points}, {"lo_g", d.lo_dg / 10.0}, {"hi_g", d.hi_dg / 10.0},
                      {"up_lo_ms", d.up_lo_01ms / 10.0}, {"up_hi_ms", d.up_hi_01ms / 10.0},
                      {"down_lo_ms", d.down_lo_01ms / 10.0}, {"down_hi_ms", d.down_hi_01ms / 10.0}}},
          {"session_s", r.session_s}};
}

void runDynCommand(DynArgs& a) {
  if (a.part == swap::kStock) {
    a.o.motor = swap::actuatorOf({swap::kStock, a.preset, a.seed, 1.0, ""}, 0.03);
  } else {
    const swap::Part& p = swap::findPart(a.part);
    a.o.motor = swap::actuatorOf(p, 0.03);
    a.seed = p.seed;
  }
  a.o.noise_seed = a.seed;
  a.o.eeprom = loadEepromOrErased(a.eeprom, false);
  const DynSessionResult r = runDynSession(a.o);
  if (!a.eeprom.empty()) {
    hex::writeIntelHexFile(a.eeprom, r.eeprom);
    if (a.part == swap::kStock) recordGatheredMotors(a.eeprom, a.preset, 0.03, {a.o.slot}, {a.seed});
    fmt::print("EEPROM saved: {}\n", a.eeprom);
  }
  fmt::print("{:>4} {:>12} {:>8} {:>9} {:>9} {:>8}\n", "dir", "pulses us", "force g", "tau ms", "plant ms", "error");
  for (const DynStep& s : r.steps) {
    if (!s.ok) {
      fmt::print("{:>4} {:>5}->{:<5}   not usable\n", s.dir > 0 ? "up" : "down", s.from_us, s.to_us);
      continue;
    }
    fmt::print("{:>4} {:>5}->{:<5} {:8.1f} {:9.1f} {:9.1f} {:+7.1f}%\n", s.dir > 0 ? "up" : "down", s.from_us,
               s.to_us, s.force_g, 1e3 * s.tau_s, 1e3 * s.truth_s, 100 * (s.tau_s / s.truth_s - 1));
  }
  for (const auto& l : r.summary) fmt::print("{}\n", l);
  fmt::print("dyn session {:.1f} s simulated ({:.1f} s wall for the whole run)\n", r.session_s, r.wall_s);
  if (!a.json.empty()) {
    std::ofstream out(a.json, std::ios::trunc);
    if (!out) throw std::runtime_error(a.json + ": cannot write the JSON result");
    out << toJson(r, a).dump(2) << "\n";
  }
}

}  // namespace

void addDynCommand(CLI::App& sim) {
  auto* cmd = sim.add_subcommand(
      "dyn",
      "gather_store's dynamics session on the virtual bench (issue 26): dyn cell (a weight lifted off\n"
      "the plate), a calibration sweep and store v2, then dyn; prints every step's time constant beside\n"
      "the plant's own (thrustcal plant step) and what was stored. --log keeps the step log as streamed\n"
      "(docs/gather_store.md, \"The step log\").");
  auto a = std::make_shared<DynArgs>();
  a->o.elf_path = defaultElf("gather_store");
  cmd->add_option("--elf", a->o.elf_path, "gather_store image")->capture_default_str();
  cmd->add_option("--part", a->part, "stock, or a part of the swap experiment (kv1100_9x4.7, kv900_11x4.7, prop-8pct)")
      ->capture_default_str();
  cmd->add_option("--seed", a->seed, "stock: the motor's seed (the swap's stock motors: 11..14)")->capture_default_str();
  cmd->add_option("--preset", a->preset, "stock: the plant preset")->capture_default_str();
  cmd->add_option("--slot", a->o.slot, "the slot and ESC output")->check(CLI::Range(0, 3))->capture_default_str();
  cmd->add_option("--log", a->o.log_path, "write dyn's output (the step log) here");
  cmd->add_option("--sweep-settle-ms", a->o.sweep_settle_ms, "the calibration sweep's settle time per step")
      ->capture_default_str();
  cmd->add_option("--sweep-step-us", a->o.sweep_step_us, "the calibration sweep's step")->capture_default_str();
  cmd->add_option("--eeprom", a->eeprom,
                  "Intel HEX EEPROM image: read if it exists (other slots and a bench's dyn cell are kept), "
                  "written after the session (sim gather --eeprom then sweeps with these dynamics)");
  cmd->add_option("--json", a->json, "write the steps and the stored dynamics as JSON");
  cmd->add_option("--truth", a->o.truth_path, "write the plant every millisecond during dyn (t_s, pulse_us, rpm, "
                                             "thrust_g, bus_v; simulated time)");
  cmd->callback([a] { guarded("dyn", [&] { runDynCommand(*a); }); });
}

}  // namespace sim
