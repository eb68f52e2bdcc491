// One benchmark = one section: its printed table(s) and its JSON object. `thrustcal bench all`
// prints every section and writes {"accuracy": ..., "compute": ..., ...} to --json.
#pragma once
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/accuracy.hpp"
#include "bench/table.hpp"

namespace bench {

// One target of the issue and where this run stands against it.
struct TargetCheck {
  std::string what;    // "v2 force error over the grid"
  std::string figure;  // "RMS 0.25 %, max 1.15 %"
  std::string target;  // "RMS <= 1 %, max <= 3 %"
  bool met = false;
};

struct Section {
  std::string key;
  std::vector<Table> tables;
  nlohmann::json json;
  std::vector<TargetCheck> targets;
};

// A section that could not be measured (no simulator in this build, an image not built): one
// "not available" row and the reason, in the table and as {"available": false, "reason": why}.
Section unavailableSection(const std::string& key, const std::string& title, const std::string& why);

// The targets of several sections as one table (printed last by `bench all`) and as JSON.
Table targetsTable(const std::vector<Section>& sections);
nlohmann::json targetsJson(const std::vector<Section>& sections);

// Paths the AVR-based sections need. Empty avr_build: <source>/build/avr.
struct AvrPaths {
  std::string avr_build;   // AVR build tree with firmware/{gather_store,read_run}/*.elf
  std::string probe_elf;   // the bench probe (built by tools/bench with avr-g++); "" = built-in
  std::string elf(const std::string& image) const;  // <avr_build>/firmware/<image>/<image>.elf
};

// Targets more than one section checks (issues 8 and 19).
constexpr int kStackTargetBytes = 512;              // stack never used after the deepest paths
constexpr uint64_t kStaticSramTargetBytes = 6144;  // 8 KB minus 2 KB for the stack

// avr-size -A on an image (sections_avr.cpp): flash = .text + .data, static SRAM = .data +
// .bss + .noinit. Throws std::runtime_error when avr-size fails (binutils-avr missing).
struct ImageSize {
  uint64_t flash_bytes = 0, sram_static_bytes = 0;
};
ImageSize imageSize(const std::string& elf);
// A path as the docs show it: relative to the source tree when inside it (docs/results.md is
// written from the JSON and must not name the machine it was measured on).
std::string shownPath(const std::string& path);
// `rel` under the source tree this tool was built from ("build/avr" -> /.../build/avr).
std::string sourcePath(const std::string& rel);

// Benchmark 10 (sections_rigs.cpp): the seesaw's and the gimbal's physics against hand
// calculations, plant only (docs/sim.md, "The rigs").
Section rigsSection();
// Benchmarks 11 and 12 (sections_airframe.cpp; docs/sim.md, "The TWI" and "The MPU-6050"):
// the test image air_probe reading the MPU-6050 in simavr at 400 and 100 kHz, the TWI's bus time
// against the datasheet's formula and each driver's cycles; the MPU-6050 model's DLPF settings
// measured (delay, -3 dB, noise) beside the datasheet's table. A second each.
Section twiSection();
Section imuSection();
Section accuracySection(const AccuracyConfig& config);
Section computeSection(const AvrPaths& paths);
Section footprintSection(const AvrPaths& paths);
// fast_sweeps: also 200 ms and 100 ms sweeps, as read and corrected with each motor's measured
// dynamics (issue 26 item 2; several minutes more of simavr).
Section calibrationSection(const AvrPaths& paths, bool fast_sweeps = false);
// Issue 26 item 2's fast calibration on the motors of `seeds` (slots 0, 1, ...): gather_store's
// default sweep (settle auto) from an erased EEPROM; then, on the models it stored, `dyn cell`
// and per slot `dyn`, and the fast sweep (tc::kFastSweepStepUs, tc::kFastSweepSettleMs) corrected with the
// measured dynamics; store v2 after each sweep. JSON: `settle_auto` and `fast` as benchmark 4's
// rows, `speedup_over_settle_auto` (first sweeps, simulated), `met` (issue 26's target). Needs
// tools/sim; throws std::runtime_error when a session fails.
nlohmann::json fastCalibrationCheck(const AvrPaths& paths, const std::vector<uint64_t>& seeds);
// quick: 10 s hold instead of 60 s.
Section liftoffSection(const AvrPaths& paths, bool quick);
// read_run's CPU load, frame cycles and loop period in simavr at 50 and 400 Hz.
Section runtimeSection(const AvrPaths& paths);
// Issue 8 (sections_safety.cpp): time to stop after a hang in both images, read_run's loop
// timing under floods.
Section safetySection(const AvrPaths& paths);
// Issue 19 item 4 (sections_fly.cpp): fly, the 400 Hz attitude loop, on the virtual airframe
// in each of its modes: CPU load, loop period, IMU read to the ESC edge that carries it, flash
// and static SRAM, stack never used.
Section flySection(const AvrPaths& paths);
// Issue 19 item 3 (sections_swap.cpp): the swap experiment's full run (sim/swap.hpp): targets,
// figures per rig, axis and gains, the motors' time constants. out_dir holds the calibration
// cache and the series (empty: <source>/build/bench/swap); quick: one IMU unit, PD gains only;
// reduced: `bench drift`'s run, the gimbal, force mode, PD, the KV900 part, IMU unit 1.
struct SwapBenchOptions {
  std::string out_dir;
  int jobs = 1;
  bool quick = false;
  bool reduced = false;
};
Section swapSection(const AvrPaths& paths, const SwapBenchOptions& options);
// Issue 25 item 5 (sections_speed.cpp): simulated seconds per wall second for read_run, fly on
// the gimbal and a firmware with phase-correct PWM on INT4/INT5 (target >= 5x real time).
Section speedSection(const AvrPaths& paths);
// Issue 26 item 1 (sections_dynamics.cpp): gather_store's dyn in simavr on the stock motors and
// the swap parts, each time constant against the plant's own. quick: the KV900 part alone, a coarser calibration sweep.
Section dynamicsSection(const AvrPaths& paths, bool quick);
// Footprint rows: each image's stack never used after its deepest paths (simulated).
void addStackHeadroom(const AvrPaths& paths, Table& table, nlohmann::json& json,
                      std::vector<TargetCheck>& targets);

}  // namespace bench
