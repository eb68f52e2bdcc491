// The thesis workflow on gather_store (fig. 6.8), driven from the host over the console:
//   motor K, plate P, range MIN MAX, step US, settle MS|auto, cal W (also tares),
//   [ask] sweep (streamed: CSV rows, progress), store 1 | store v2,
//   [--second-sweep: the operator changes the supply and lets the propeller stop] tare,
//   [ask] sweep, store 2 | store v2, show.
// Lines go out with the console checksum when the firmware offers strict mode. A sweep is
// aborted (the abort key) on Ctrl-C, on a time-out and on an error; a lost port ends the run
// (nothing can be sent any more: the firmware ends the sweep by itself).
//
// The person at the bench is an Operator: a terminal for `thrustcal board calibrate`, the
// simulated bench's harness for `thrustcal sim gather` (which changes the plant's supply).
#pragma once
#include <string>
#include <vector>

#include "board/console_client.hpp"

namespace board {

struct CalibrateOptions {
  int slot = 0;                 // motor slot = ESC output = EEPROM record (0..3)
  int mount_g = 0;              // motor + propeller (+ mount) weight for `cal`
  int plate_g = 60;             // the load cell's plate
  std::string model = "v1";     // v1: store 1 / store 2 (thesis); v2: store v2 after each sweep
  bool second_sweep = false;    // a second sweep at another supply voltage
  int pwm_min_us = 1040, pwm_max_us = 1800, step_us = 10;
  int settle_ms = 500;          // per step (the cap with settle_auto)
  bool settle_auto = false;
  bool strict = true;           // use strict mode + checksums if the firmware offers them
};

// One sweep as it came over the line.
struct SweepLog {
  std::vector<std::string> lines;  // every line of the answer, as printed
  std::string header;              // the CSV header ("pwm_us,force_g,...")
  std::vector<std::string> rows;   // CSV rows, in order
  double max_force_g = 0;          // "# max force N g"
  bool done = false;               // "# done: ..."
  double wall_s = 0;
  // The project's measurement CSV: header, rows, '#' lines as comments.
  std::string csv(const std::string& first_comment) const;
};

struct SweepProgress {
  int sweep = 1;              // 1 or 2
  int pwm_us = 0;
  double force_g = 0;
  int rows = 0, rows_total = 0;
  double eta_s = 0;           // wall-clock estimate of what is left
};

class Operator {
 public:
  virtual ~Operator() = default;
  // Before the propeller spins: true to go on. `what` says which motor and how far.
  virtual bool confirmSpin(const std::string& what) = 0;
  // Between the sweeps: change to another supply voltage and let the propeller stop; return
  // when done (throw to give up).
  virtual void prepareSecondSweep(const std::string& what) = 0;
  // Right before `sweep` is sent / after its prompt came back.
  virtual void sweepStarting(int /*sweep*/) {}
  virtual void sweepEnded(int /*sweep*/, const SweepLog& /*log*/) {}
  virtual void progress(const SweepProgress& /*p*/) {}
  virtual void note(const std::string& /*line*/) {}
};

struct CalibrateResult {
  bool checksums = false;              // strict mode with checksums was on
  std::vector<std::string> boot;       // lines before the first prompt
  std::vector<std::string> cal;        // the answer to `cal W`
  std::vector<SweepLog> sweeps;        // one or two
  std::vector<std::string> store;      // the answers to the store commands
  std::vector<std::string> show;
  double wall_s = 0;
};

// Runs the workflow on a console that has booted gather_store (waitForBoot done). Throws
// CommandRefused (the firmware said error: ...), BoardTimeout, Interrupted, PortError, or
// std::runtime_error when the operator declines.
CalibrateResult calibrate(ConsoleClient& con, const CalibrateOptions& o, Operator& op);

// The ESC pin of a slot on the Mega2560, for messages ("D6 (PH3)").
std::string escPinName(int slot);

}  // namespace board
