// `thrustcal bench drift --from docs/results.json`: the cheap figures measured again and compared
// with the JSON the docs are generated from, each within its stated tolerance. The docs quote
// docs/results.json (bench/doc_blocks.hpp), so a figure that moved past its tolerance means the
// docs no longer say what the code does: run tools/results.sh and commit what it writes.
// Measured again (seconds, not minutes): the compute cycles (the bench probe in simavr), the
// images' flash and static SRAM (avr-size, fly included), the stacks never used and the models'
// SRAM (footprint), air_probe's TWI reads and the MPU-6050 model's DLPF figures (benchmarks 11 and
// 12, about a second), and a reduced swap (the gimbal, force mode, PD gains, one part, IMU unit 1),
// whose runs are compared with the same runs of the full swap.
#pragma once
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/table.hpp"

namespace bench {

// A figure (a path as bench/doc_blocks.hpp reads them) and how far it may move: within
// max(abs, rel * |the JSON's value|).
struct DriftFigure {
  std::string path;
  double abs = 0, rel = 0;
  std::string unit;  // for the table: "cycles", "B", "s", ...
};

// The figures compared: every one `now` has of the fixed list (compute, footprint, fly's image),
// each row of now's twi.rows[] (bus and driver cycles) and imu.dlpf[] (delay, -3 dB, noise), and
// each run of now's swap.runs[] with its step figures.
std::vector<DriftFigure> driftFigures(const nlohmann::json& now);

struct DriftResult {
  Table table;
  int compared = 0, drifted = 0, missing = 0;  // missing: not in the docs' JSON
};
// Each figure of `now` against `docs`.
DriftResult compareDrift(const nlohmann::json& docs, const nlohmann::json& now,
                         const std::vector<DriftFigure>& figures);

}  // namespace bench
