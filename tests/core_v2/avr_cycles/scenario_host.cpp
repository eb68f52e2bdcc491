// Host side of the AVR/host comparison (tests/core_v2/avr_cycles.sh): runs the same
// scenario as the AVR program with the host compiler and prints its result bytes as hex,
// 32 per line, exactly as run_cycles prints the AVR's.
#include <cstdio>

#include "scenario.hpp"

namespace {
unsigned long count = 0;
}

struct HostIo {
  static void markStart(uint8_t) {}
  static void markEnd() {}
  static void emit(uint8_t byte) {
    std::printf("%02x%s", byte, (++count % 32) ? "" : "\n");
  }
};

int main() {
  static scenario::State state;
  scenario::run<HostIo>(state);
  if (count % 32) std::printf("\n");
  return 0;
}
