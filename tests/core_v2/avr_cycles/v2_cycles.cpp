// AVR side of the cycle benchmark (tests/core_v2/avr_cycles.sh), run in simavr by
// run_cycles.cpp with sim::runCycleProbe: the scenario (scenario.hpp) brackets each measured
// call with the probe's markers (sim/cycle_probe_avr.hpp) and reports its results as bytes
// under kResultsKey.
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>

#include "scenario.hpp"
#include "sim/cycle_probe_avr.hpp"

constexpr uint8_t kResultsKey = 0x80;  // run_cycles.cpp reads the results under this key

struct AvrIo {
  static void markStart(uint8_t label) { probe::markStart(label); }
  static void markEnd() { probe::markEnd(); }
  static void emit(uint8_t byte) { probe::report8(kResultsKey, byte); }
};

static scenario::State state;  // ~1.6 KB: static, not on the stack

int main() {
  scenario::run<AvrIo>(state);
  probe::done();
  cli();
  sleep_enable();
  sleep_cpu();
}
