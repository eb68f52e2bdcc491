// The thesis's tethered lift-off on read_run, driven from the host: `stream on` (CSV rows
// t_s,motor0_pwm_us..motor3_pwm_us,vbat_v, 10 a second), `liftoff G RAMP HOLD` (all four
// motors ramp to G grams, hold, stop), `stream off`. Everything read_run prints is logged;
// the abort key goes out on Ctrl-C and on a time-out.
#pragma once
#include <functional>
#include <string>
#include <vector>

#include "board/console_client.hpp"

namespace board {

struct LiftoffOptions {
  int force_g = 300;
  int ramp_ms = 2000, hold_ms = 5000;
  bool strict = true;
};

struct LiftoffLog {
  bool checksums = false;
  std::vector<std::string> boot;       // read_run's boot lines (which slots are calibrated)
  std::string header;                  // the stream's CSV header
  std::vector<std::string> rows;       // stream rows
  std::vector<std::string> info;       // "# ..." lines (ramp, hold, progress, done)
  int garbled = 0;                     // lines that are neither (echo mixed into a row)
  bool done = false;                   // "# liftoff done"
  double wall_s = 0;
  // The project's measurement CSV: the header, rows, '#' lines.
  std::string csv(const std::string& first_comment) const;
};

// Flies the lift-off on a console that booted read_run. `confirm` is asked before anything
// spins (false: nothing is sent). Throws CommandRefused (e.g. a slot not calibrated),
// BoardTimeout, Interrupted, PortError.
LiftoffLog flyLiftoff(ConsoleClient& con, const LiftoffOptions& o,
                      const std::function<bool(const std::string&)>& confirm,
                      const std::function<void(const std::string&)>& on_line = {});

}  // namespace board
