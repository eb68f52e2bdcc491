// Benchmark 9 (issue 26 item 1): each motor's dynamics as gather_store measures them in simavr
// (`dyn cell` once, then `dyn` per part: sim/dynamics_session.hpp), every step's time constant
// beside the plant's own for the same pulses at the step's bus voltage (what `thrustcal plant
// step` prints), for the four stock motors of the swap experiment and each part that can replace
// motor 1.
#include <cmath>
#include <filesystem>
#include <iostream>

#include <fmt/format.h>

#include "bench/sections.hpp"

#ifdef THRUSTCAL_BENCH_HAVE_SIM
#include "sim/dynamics_session.hpp"
#include "sim/scenarios.hpp"
#include "sim/swap.hpp"
#include "sim/watchdog_gaps.hpp"
#endif

namespace bench {

#ifndef THRUSTCAL_BENCH_HAVE_SIM

Section dynamicsSection(const AvrPaths&, bool) {
  return unavailableSection("dynamics", "9. Dynamics",
                            "tools/sim (thrustcal_sim) is not part of this build: no gather_store session");
}

#else

namespace {

constexpr double kTauTargetPct = 5.0;
constexpr double kSessionTargetS = 40.0;
constexpr double kKickGapTargetMs = sim::KickGapMeter::kHeadroomTargetMs;

struct BenchPart {
  std::string name;  // "stock" for the four stock motors, else the swap part's name
  uint64_t seed;
  plant::ActuatorParams motor;
};

std::vector<BenchPart> benchParts(bool quick) {
  namespace sw = sim::swap;
  const sw::SwapOptions so;
  std::vector<BenchPart> parts;
  for (std::size_t i = 0; i < so.stock_seeds.size() && !quick; ++i) {
    const sw::Part stock{sw::kStock, so.stock_preset, so.stock_seeds[i], 1.0, ""};
    parts.push_back({sw::kStock, so.stock_seeds[i], sw::actuatorOf(stock, so.variation)});
  }
  for (const sw::Part& p : sw::swapParts()) {
    if (quick && p.name != "kv900_11x4.7") continue;
    parts.push_back({p.name, p.seed, sw::actuatorOf(p, so.variation)});
  }
  return parts;
}

double errorPct(double measured, double truth) { return 100.0 * (measured / truth - 1.0); }

}  // namespace

Section dynamicsSection(const AvrPaths& paths, bool quick) {  // long: one table row per operating point
  Section s;
  s.key = "dynamics";
  const std::string elf = paths.elf("gather_store");
  if (!std::filesystem::exists(elf))
    return unavailableSection("dynamics", "9. Dynamics",
                              elf + " not found: build the AVR tree (--target gather_store) or pass --avr-build DIR");
  Table t("9. Dynamics: gather_store's dyn in simavr against the plant's own time constants (spin-up / spin-down)",
          {"part", "seed", "force g", "up ms (plant)", "error", "down ms (plant)", "error"});
  nlohmann::json points = nlohmann::json::array(), sessions = nlohmann::json::array();
  std::vector<uint8_t> eeprom;
  double worst_pct = 0, longest_s = 0, longest_gap_ms = 0;
  std::string gap_where;
  int usable = 0, steps = 0;
  tc::BenchResponse cell;
  for (const BenchPart& part : benchParts(quick)) {
    sim::DynSessionOptions o;
    o.elf_path = elf;
    o.motor = part.motor;
    o.eeprom = eeprom;  // the bench's response, once identified, stays in the settings
    o.noise_seed = part.seed;
    if (quick) o.sweep_step_us = 40;  // the model only places dyn's operating points
    o.progress = [](const std::string& l) { std::cerr << "bench: dyn: " << l << '\n'; };
    o.watch_kicks = true;  // the session's longest work between two watchdog kicks
    const sim::DynSessionResult r = sim::runDynSession(o);
    eeprom = r.eeprom;
    cell = r.bench;
    longest_s = std::max(longest_s, r.session_s);
    if (r.longest_kick_gap_ms > longest_gap_ms) {
      longest_gap_ms = r.longest_kick_gap_ms;
      gap_where = r.kick_gap_where;
    }
    sessions.push_back({{"part", part.name}, {"seed", part.seed}, {"session_s", r.session_s},
                        {"stored_points", r.dynamics.points}, {"wall_s", r.wall_s},
                        {"longest_kick_gap_ms", r.longest_kick_gap_ms}, {"kick_gap_where", r.kick_gap_where}});
    for (std::size_t i = 0; i + 1 < r.steps.size(); i += 2) {
      const sim::DynStep& up = r.steps[i];
      const sim::DynStep& down = r.steps[i + 1];
      steps += 2;
      if (!up.ok || !down.ok) {
        t.addRow({part.name, std::to_string(part.seed), "-", "fit not usable", "-", "-", "-"});
        worst_pct = std::max(worst_pct, 100.0);
        continue;
      }
      usable += 2;
      const double force_g = 0.5 * (up.force_g + down.force_g);
      const double eu = errorPct(up.tau_s, up.truth_s), ed = errorPct(down.tau_s, down.truth_s);
      worst_pct = std::max({worst_pct, std::fabs(eu), std::fabs(ed)});
      t.addRow({part.name, std::to_string(part.seed), fmt::format("{:.0f}", force_g),
                fmt::format("{:.1f} ({:.1f})", 1e3 * up.tau_s, 1e3 * up.truth_s), fmt::format("{:+.1f} %", eu),
                fmt::format("{:.1f} ({:.1f})", 1e3 * down.tau_s, 1e3 * down.truth_s), fmt::format("{:+.1f} %", ed)});
      points.push_back({{"part", part.name}, {"seed", part.seed}, {"force_g", force_g},
                        {"tau_up_s", up.tau_s}, {"tau_down_s", down.tau_s}, {"truth_up_s", up.truth_s},
                        {"truth_down_s", down.truth_s}, {"pulses_us", {up.from_us, up.to_us}},
                        {"bus_v", up.bus_v}});
    }
  }
  t.addNote(fmt::format("the bench's load cell as dyn cell identified it: {} stages of {:.1f} ms (the plant's: 3 of "
                        "30.0 ms)",
                        cell.stages, cell.tauS() * 1e3));
  t.addNote("plant: the rpm's 63.2 % time for the same pulses at the step's bus voltage (plant::stepTimeConstant_s, "
            "`thrustcal plant step`); dyn's: the speed lag fitted through the cell's response, the bus sag taken out");
  t.addNote(fmt::format("dyn session per motor (simulated): at most {:.1f} s; 5 operating points at 20..80 % of the "
                        "model's force, each stepped 0.9 -> 1.1 -> 0.9 of it",
                        longest_s));
  s.tables.push_back(t);
  s.json = {{"points", points},
            {"sessions", sessions},
            {"bench", {{"stages", cell.stages}, {"tau_ms", cell.tauS() * 1e3}}},
            {"worst_error_pct", worst_pct},
            {"usable_steps", usable},
            {"steps", steps},
            {"session_s_max", longest_s},
            {"longest_kick_gap_ms", longest_gap_ms}};
  s.targets.push_back({"9. dynamics: every time constant vs the plant's (stock motors and swap parts)",
                       fmt::format("worst {:.1f} % over {} steps ({} usable)", worst_pct, steps, usable),
                       fmt::format("within {:.0f} %", kTauTargetPct), worst_pct <= kTauTargetPct && usable == steps});
  s.targets.push_back({"9. dynamics: the dyn session for one motor", fmt::format("{:.1f} s simulated", longest_s),
                       fmt::format("<= {:.0f} s", kSessionTargetS), longest_s <= kSessionTargetS});
  // docs/safety.md, "Watchdog headroom": the sweep, the store and dyn's fits in one session
  s.targets.push_back({"9. dynamics: gather_store's longest work between two watchdog kicks in a session",
                       fmt::format("{:.1f} ms ({})", longest_gap_ms, gap_where),
                       fmt::format("<= {:.0f} ms (half the time-out)", kKickGapTargetMs),
                       longest_gap_ms <= kKickGapTargetMs});
  return s;
}

#endif

}  // namespace bench
