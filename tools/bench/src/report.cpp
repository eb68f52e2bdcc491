#include "bench/report.hpp"

#include <algorithm>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>

#include "bench/table.hpp"

namespace bench {

namespace {

// The member at a dotted path ("safety.hang.read_run_loop_interrupts_on.time_to_stop_ms").
const nlohmann::json& at(const nlohmann::json& j, const std::string& path) {
  const nlohmann::json* node = &j;
  std::size_t from = 0;
  while (from <= path.size()) {
    const std::size_t dot = std::min(path.find('.', from), path.size());
    const std::string key = path.substr(from, dot - from);
    if (!node->is_object() || !node->contains(key))
      throw std::runtime_error(fmt::format("the bench JSON has no {} (at \"{}\"): run `thrustcal bench all "
                                           "--json` with every section available (tools/results.sh)",
                                           path, key));
    node = &node->at(key);
    from = dot + 1;
  }
  return *node;
}

double num(const nlohmann::json& j, const std::string& path) { return at(j, path).get<double>(); }

// The largest (or smallest) of one figure over several members: "loop.<key>.frame_jitter_ms".
double maxOf(const nlohmann::json& j, const std::string& path, const std::vector<std::string>& keys,
             const std::string& field) {
  double v = -1e300;
  for (const auto& k : keys) v = std::max(v, num(j, path + "." + k + "." + field));
  return v;
}
double minOf(const nlohmann::json& j, const std::string& path, const std::vector<std::string>& keys,
             const std::string& field) {
  double v = 1e300;
  for (const auto& k : keys) v = std::min(v, num(j, path + "." + k + "." + field));
  return v;
}

const std::vector<std::string> kFloods = {"idle", "flood_no_line_end", "burst_short_lines",
                                          "burst_long_replies"};

std::vector<std::string> floodKeys(int hz) {
  std::vector<std::string> keys;
  for (const auto& f : kFloods) keys.push_back(fmt::format("{}_{}hz", f, hz));
  return keys;
}

std::string hangRow(const nlohmann::json& b) {
  const double rr = maxOf(b, "safety.hang", {"read_run_loop_interrupts_on", "read_run_loop_interrupts_off"},
                          "time_to_stop_ms");
  const double gs = maxOf(b, "safety.hang", {"gather_store_sweep_interrupts_on", "gather_store_sweep_interrupts_off"},
                          "time_to_stop_ms");
  const std::vector<std::string> all = {"read_run_loop_interrupts_on", "read_run_loop_interrupts_off",
                                        "gather_store_sweep_interrupts_on", "gather_store_sweep_interrupts_off"};
  return fmt::format("| a hung main loop (interrupts on or off): last ESC pulse > 1050 us ends | {:.1f} ms "
                     "(read_run), {:.1f} ms (gather_store mid-sweep); watchdog reset at {:.0f}-{:.0f} ms, then "
                     "`reset: watchdog` and 1000 us until a new command | `thrustcal bench safety` (table 6a) |\n",
                     rr, gs, minOf(b, "safety.hang", all, "reset_after_ms"),
                     maxOf(b, "safety.hang", all, "reset_after_ms"));
}

std::string floodRow(const nlohmann::json& b) {
  std::vector<std::string> both = floodKeys(50);
  for (const auto& k : floodKeys(400)) both.push_back(k);
  return fmt::format("| read_run's frames under four kinds of flood | 50 Hz: {:.2f}..{:.2f} ms apart; 400 Hz: "
                     "jitter <= {:.2f} ms; longest single loop pass {:.1f} ms (`help`), frames served inside it "
                     "| `thrustcal bench safety` (6b) |\n",
                     minOf(b, "safety.loop", floodKeys(50), "frame_interval_min_ms"),
                     maxOf(b, "safety.loop", floodKeys(50), "frame_interval_max_ms"),
                     maxOf(b, "safety.loop", floodKeys(400), "frame_jitter_ms"),
                     maxOf(b, "safety.loop", both, "loop_max_gap_ms"));
}

std::string footprintRows(const nlohmann::json& b) {
  const auto image = [&](const char* name, const char* field) {
    return num(b, fmt::format("footprint.images.{}.{}", name, field));
  };
  const auto stack = [&](const char* name, const char* field) {
    return num(b, fmt::format("footprint.stack.{}.{}", name, field));
  };
  return fmt::format(
      "| stack never used after the deepest paths | gather_store {:.0f} of {:.0f} B, read_run {:.0f} of {:.0f} B "
      "(>= 512 B asked) | `thrustcal bench footprint` |\n"
      "| static SRAM / flash | gather_store {:.0f} B / {:.1f} KB, read_run {:.0f} B / {:.1f} KB; read_run's four "
      "slots {:.0f} B | `avr-size --format=avr --mcu=atmega2560 build/avr/firmware/*/*.elf` |\n",
      stack("gather_store", "never_used_bytes"), stack("gather_store", "stack_bytes"),
      stack("read_run", "never_used_bytes"), stack("read_run", "stack_bytes"),
      image("gather_store", "sram_static_bytes"), image("gather_store", "flash_bytes") / 1000.0,
      image("read_run", "sram_static_bytes"), image("read_run", "flash_bytes") / 1000.0,
      num(b, "footprint.models_sram.read_run_four_slots_bytes"));
}

std::string computeAndRuntimeRows(const nlohmann::json& b) {
  return fmt::format(
      "| model v2 as read_run flies it, four motors (`V2Frame::fly`) | {:.0f} cycles mean, {:.0f} max (<= 1000) "
      "| `thrustcal bench compute` |\n"
      "| read_run CPU load in a lift-off (v2 / thesis records) | {:.1f} / {:.1f} % at 50 Hz, {:.1f} / {:.1f} % at "
      "400 Hz | `thrustcal bench runtime` |\n",
      num(b, "compute.updates.v2_read_run.mean_cycles"), num(b, "compute.updates.v2_read_run.max_cycles"),
      num(b, "runtime.hz50.v2.cpu_load_pct"), num(b, "runtime.hz50.v1.cpu_load_pct"),
      num(b, "runtime.hz400.v2.cpu_load_pct"), num(b, "runtime.hz400.v1.cpu_load_pct"));
}

std::string calibrationRow(const nlohmann::json& b) {
  return fmt::format(
      "| calibration with gather_store's default sweep (settle auto), 100-450 g | thesis curves max {:.2f} %, "
      "model v2 max {:.2f} %, {:.1f} s per sweep | `thrustcal bench calibration` |\n",
      num(b, "calibration.thesis.curve_error_max_pct_100_450g"),
      num(b, "calibration.v2_default.curve_error_max_pct_100_450g"),
      num(b, "calibration.thesis.sweep_simulated_s_max"));
}

std::string flyRow(const nlohmann::json& b) {
  const std::vector<std::string> modes = {"force_v2", "force_thesis", "generic", "pwm", "ardupilot"};
  std::string cpu;
  for (const auto& m : modes)
    cpu += fmt::format("{}{:.1f}", cpu.empty() ? "" : " / ", num(b, "fly.modes." + m + ".cpu_load_pct"));
  return fmt::format(
      "| fly's 400 Hz attitude loop on the simulated gimbal, five modes (force v2 / thesis records, generic, "
      "pwm, ardupilot) | CPU {} %; IMU read to the ESC edge that carries it {:.0f}..{:.0f} us; loop period "
      "<= {:.2f} ms; stack {:.0f} B never used | `thrustcal bench fly` |\n",
      cpu, minOf(b, "fly.modes", modes, "read_to_edge_us.max"), maxOf(b, "fly.modes", modes, "read_to_edge_us.max"),
      num(b, "fly.worst.loop_period_max_ms"), num(b, "fly.worst.stack_never_used_bytes"));
}

const char* kResultsIntro =
    "# Results: what was measured, and how to measure it again\n"
    "\n"
    "<!-- Written by `thrustcal bench report --from docs/results.json` (tools/results.sh): do not edit.\n"
    "     Change the bench, then run tools/results.sh. ctest's Checks.ResultsDocsAreTheBenchJson fails\n"
    "     when this file and docs/results.json disagree. -->\n"
    "\n"
    "Every figure on this page is in [`results.json`](results.json), written by\n"
    "`thrustcal bench all --json` {}.\n"
    "Cycles are simulated ATmega2560 cycles and times are simulated seconds: a re-run gives the\n"
    "same figures on any machine (the same seeds) unless the code measured has changed.\n"
    "Re-measure and rewrite this page and README's \"Measured\" table with `tools/results.sh`.\n"
    "What each benchmark measures and how:\n"
    "[tools/bench/README.md](../tools/bench/README.md); the safety figures explained:\n"
    "[safety.md](safety.md).\n"
    "\n"
    "Not from the bench, and so not here: the demo prints its own closing table (`tools/demo.sh`,\n"
    "[sim.md](sim.md)); plant fidelity is `thrustcal plant table51|datasheet|step`\n"
    "([tools/plant/README.md](../tools/plant/README.md)); the model lab's walkthroughs are in\n"
    "[lab.md](lab.md).\n";

std::string provenance(const nlohmann::json& b) {
  if (!b.contains("source")) return "at an unrecorded commit";
  const nlohmann::json& s = b.at("source");
  return fmt::format("at commit {}{}", s.value("commit", std::string("?")),
                     s.value("dirty", false) ? " with uncommitted changes" : "");
}

}  // namespace

std::string resultsMarkdown(const nlohmann::json& bench) {
  const nlohmann::json& tables = at(bench, "tables");
  if (!tables.is_array() || tables.empty())
    throw std::runtime_error("the bench JSON's \"tables\" is empty: write it with `thrustcal bench all --json`");
  std::string md = fmt::format(fmt::runtime(kResultsIntro), provenance(bench));
  std::vector<Table> all;
  for (const auto& t : tables) all.push_back(Table::fromJson(t));
  // the targets table (printed last by the bench) first: the page's summary
  std::stable_partition(all.begin(), all.end(), [](const Table& t) { return t.title().rfind("Targets", 0) == 0; });
  for (const Table& t : all) md += fmt::format("\n## {}\n\n{}", t.title(), t.markdown());
  return md;
}

std::string measuredTable(const nlohmann::json& b) {
  return "| what | figure | reproduce |\n|---|---|---|\n" + hangRow(b) + floodRow(b) + footprintRows(b) +
         computeAndRuntimeRows(b) + flyRow(b) + calibrationRow(b) +
         "| console fuzz | 10,000+ lines per image, every rule held | `ctest --test-dir build/checked -R "
         "ConsoleFuzz` |\n";
}

}  // namespace bench
