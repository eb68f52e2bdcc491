// Cycle counts of an AVR program in simavr, by markers. The program (its side of the protocol:
// sim/cycle_probe_avr.hpp) writes the GPIOR registers around the calls it wants timed and to
// report values; runCycleProbe runs it on an ATmega2560 at 16 MHz and timestamps those writes
// with the simulated cycle counter. One home for the protocol and its runner: the bench's AVR
// probe (`thrustcal bench compute|footprint`) and the model v2 cycle comparison
// (tests/core_v2/avr_cycles.sh) both use it.
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace sim {

// Cycles of one label's sections, net of the empty bracket's overhead (label 0).
struct CycleStat {
  uint64_t count = 0, mean = 0, min = 0, max = 0;
};

struct CycleProbeRun {
  std::map<int, CycleStat> sections;             // by label (1..0x7F)
  std::map<int, std::vector<uint8_t>> reported;  // bytes reported under each key (0x80..0xFE)
  uint64_t overhead_cycles = 0;                  // the empty bracket's cycles (subtracted)
  uint64_t total_cycles = 0;
  // With a profile label: the cycles spent at each program address (bytes) inside that
  // label's sections, summed over all of them.
  std::map<uint32_t, uint64_t> profile;
};

// Runs the image until it says it is done. Throws std::runtime_error when the image cannot be
// loaded, or crashes or does not finish within budget_cycles.
CycleProbeRun runCycleProbe(const std::string& elf_path, uint64_t budget_cycles,
                            int profile_label = -1);

}  // namespace sim
