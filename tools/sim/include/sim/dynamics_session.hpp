// gather_store's dynamics session on the virtual bench (issue 26; `thrustcal bench dynamics`,
// the swap's force+dyn calibrations): the real image in simavr on the plant's thesis bench,
// typed into its UART in simulated time, as a person at the bench would run it:
//
//   motor K, plate, cal W; (once per bench) a weight hung on the plate, `dyn cell`, the weight
//   lifted off when gather_store asks; a calibration sweep and `store v2` unless the slot holds
//   a model; `dyn`, whose step logs and fits are captured. Each step's time constant is set
//   beside the plant's own for the same pulses at the step's bus voltage
//   (plant::stepTimeConstant_s, what `thrustcal plant step` prints).
// The plant steps every 0.25 ms here (the rig's default is 1 ms): an ESC edge reaches the motor
// and the cell's voltage the ADC within that, as on the analog bench.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "plant/bench.hpp"
#include "sim/scenarios.hpp"
#include "thrustcal/dynamics.hpp"

namespace sim {

struct DynSessionOptions {
  std::string elf_path;               // gather_store.elf
  plant::ActuatorParams motor;        // the part on the bench
  int slot = 0;
  std::vector<uint8_t> eeprom;        // the board's EEPROM before (empty: erased)
  bool calibrate = true;              // sweep and store v2 first (false: the slot holds a model)
  double cell_weight_g = 100.0;       // dyn cell: hung on the plate, lifted off
  double headroom_g = 120.0;          // the amplifier's offset set so the cell reads this much
                                      // weight above the mounted part (the thesis's: 15 g)
  int sweep_step_us = 20, sweep_settle_ms = 300;
  uint64_t noise_seed = 1;            // the load cell's and battery monitor's noise
  std::string log_path;               // dyn's output as streamed ("" = none)
  std::string truth_path;             // the plant at every 0.25 ms step during dyn ("" = none):
                                      // t_s (simulated), pulse_us, rpm, thrust_g, bus_v
  ProgressFn progress;
  bool watch_kicks = false;           // measure the longest work between two watchdog kicks
                                      // (sim/watchdog_gaps.hpp; slower: a check per instruction)
};

struct DynStep {
  int dir = 0;                        // +1 up, -1 down
  int from_us = 0, to_us = 0;
  double bus_v = 0;                   // before the step, as gather_store read it
  bool ok = false;                    // the fit was usable
  double force_g = 0, tau_s = 0;      // gather_store's fit
  double truth_s = 0;                 // the plant's own
};

struct DynSessionResult {
  std::vector<DynStep> steps;         // in the order dyn ran them (up, down per point)
  tc::BenchResponse bench;            // the board settings' after the session
  tc::MotorDynamics dynamics;         // the slot's record after the session
  double session_s = 0;               // `dyn` alone, simulated seconds
  double simulated_s = 0, wall_s = 0; // the whole run
  std::vector<uint8_t> eeprom;
  std::vector<std::string> summary;   // dyn's lines that are neither CSV nor comments
  double longest_kick_gap_ms = 0;     // with watch_kicks: from the first prompt to the end
  std::string kick_gap_where;         // "from -> to" (the kicks' callers)
};

// Throws std::runtime_error with gather_store's last lines when a command is refused or a
// session does not finish.
DynSessionResult runDynSession(const DynSessionOptions& options);

// A slot's dynamics as its v2 record in `eeprom` holds them (the board settings' limits); none
// when the slot holds no valid v2 record or no dynamics.
tc::MotorDynamics storedDynamics(const std::vector<uint8_t>& eeprom, int slot);
// The plant's own dynamics (plant::recordDynamics) into slot's v2 record in `eeprom`, as
// gather_store's dyn stores them (the power-fail-safe writer: the next copy): what the swap's
// force+dyn (--dyn-from plant) and `sim liftoff --dyn` fly without dyn sessions. False (nothing
// written) when the slot holds no model v2; throws std::runtime_error when the write fails.
bool storePlantDynamics(std::vector<uint8_t>& eeprom, int slot, const plant::ActuatorParams& motor);

// The thesis bench with `motor` mounted, the amplifier's offset set for `headroom_g`.
plant::BenchParams dynBenchParams(const plant::ActuatorParams& motor, double headroom_g, uint64_t noise_seed);

}  // namespace sim
