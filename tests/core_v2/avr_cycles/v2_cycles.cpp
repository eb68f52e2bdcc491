// AVR side of the cycle benchmark (tests/core_v2/avr_cycles.sh), run in simavr by
// run_cycles.cpp: the scenario (scenario.hpp) brackets each measured call with marker
// writes that the host timestamps with the simulated cycle counter, and streams its results.
//   GPIOR1 = label, then GPIOR0 = 1 (start) ... GPIOR0 = 2 (end); GPIOR0 = 3: done.
//   GPIOR2 = one result byte.
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>

#include "scenario.hpp"

struct AvrIo {
  static void markStart(uint8_t label) {
    GPIOR1 = label;
    GPIOR0 = 1;
  }
  static void markEnd() { GPIOR0 = 2; }
  static void emit(uint8_t byte) { GPIOR2 = byte; }
};

static scenario::State state;  // ~1.6 KB: static, not on the stack

int main() {
  scenario::run<AvrIo>(state);
  GPIOR0 = 3;
  cli();
  sleep_enable();
  sleep_cpu();
}
