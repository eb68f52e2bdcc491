// Each image's deepest paths, then how much stack was never used (docs/safety.md): the boot
// code paints the SRAM above the static data, `status` reports the paint still intact, and the
// harness scans the simulated SRAM itself as a check on that figure. One home for the
// scenario: the HIL test (tests/hil_safety/stack_hil_test.cpp) asserts on it, `thrustcal bench
// footprint` reports it, and `thrustcal bench fly` for fly in each of its modes.
#pragma once
#include <string>
#include <vector>

namespace sim {

class Console;

struct StackHeadroom {
  int untouched_bytes = -1;          // status: "stack: N of M bytes never used" (-1: no line)
  int stack_bytes = -1;              // M
  int scanned_untouched_bytes = -1;  // the paint byte intact from the linker's _end upwards
  std::vector<std::string> status;   // what status printed
  std::vector<std::string> deepest;  // the reply of the deepest command (gather_store: store v2)
  std::string console_tail;          // the console's last lines, for messages
};

// gather_store on the plant's thesis bench (motor seed 13): cal, range 1040 1800, settle 60,
// sweep, store v2 (the fit: its deepest path), show, store 1, help under a flood, status.
StackHeadroom gatherStoreDeepestPaths(const std::string& elf);
// read_run with two v1 and two v2 slots (the boot decodes both v2 copies): a lift-off, f 200,
// help under a flood with every motor running (its wait hook flies the frames on top of the
// reply), status.
StackHeadroom readRunDeepestPaths(const std::string& elf);
// fly (image `elf`) armed and flying on the caller's board (the virtual airframe) behind
// `con`: a stream of rows, help under a flood and status, each while the frames run (the wait
// hook serves them inside the long replies), keep-alive lines between them. Call it after the
// flight whose paths count (each mode its own); status reports the stack never used since reset.
StackHeadroom flyDeepestPaths(const std::string& elf, Console& con);
// fly disarmed, before that flight: `param list` and `param save` (its frames are served between
// the EEPROM bytes, on top of the record's buffers), so the status flyDeepestPaths reads counts
// their stack too. Throws std::runtime_error when fly refuses one.
void flyDisarmedPaths(Console& con);

}  // namespace sim
