// The plant wired to a simulated board (used by the scenarios and the HIL tests).
//   BenchRig: thesis bench, one actuator on ESC output `slot`, load cell on A0, battery on A1.
//   QuadRig:  tethered quad frame, ESC output i drives motor i, battery monitor on A1 (A0 reads
//             0 mV: no load cell on the aircraft).
// The plant advances every 1 ms of simulated time; ESC pulses reach it with their edge times.
// A rig either makes its own board (from an ELF, or a bootloader + application) or wires a
// board that already exists (replacing the plant wiring it had: `sim board` swaps the bench
// for the quad when the flash changes).
#pragma once
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "plant/bench.hpp"
#include "plant/quad_frame.hpp"
#include "plant/sensors.hpp"
#include "sim/board.hpp"
#include "sim/console.hpp"
#include "sim/scenarios.hpp"

namespace sim {

struct BenchRig {
  std::unique_ptr<Board> owned;  // null when wired to a board that exists elsewhere
  Board& board;
  plant::Bench bench;
  int slot;
  double last_t = 0;

  BenchRig(const std::string& elf, const plant::BenchParams& params, int esc_slot);
  BenchRig(const FlashImages& images, const plant::BenchParams& params, int esc_slot);
  BenchRig(Board& existing, const plant::BenchParams& params, int esc_slot);

 private:
  void wire();
};

struct QuadRig {
  std::unique_ptr<Board> owned;
  Board& board;
  plant::QuadFrame quad;
  plant::BatterySensor vsense;
  int sample_every;  // ticks between samples
  int tick = 0;
  bool recording = false;
  double last_t = 0;
  std::vector<LiftoffSample> samples;

  QuadRig(const std::string& elf, const plant::QuadFrameParams& params,
          const std::array<plant::ActuatorParams, 4>& motors, double sample_period_s = 0.01);
  QuadRig(const FlashImages& images, const plant::QuadFrameParams& params,
          const std::array<plant::ActuatorParams, 4>& motors, double sample_period_s = 0.01);
  QuadRig(Board& existing, const plant::QuadFrameParams& params,
          const std::array<plant::ActuatorParams, 4>& motors, double sample_period_s = 0.01);

 private:
  void wire();
};

// Waits through read_run's boot (banner, calibration report, 2 s arming) to its first prompt;
// returns the lines printed before it.
std::vector<std::string> bootReadRun(Console& con);

}  // namespace sim
