// Runs the bench's AVR probe (tools/bench/avr/probe.cpp) with sim::runCycleProbe (the marker
// protocol: sim/cycle_probe.hpp) and collects what it reports: cycle counts of labelled
// sections, net of the empty bracket's overhead, and 16-bit values.
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "sim/cycle_probe.hpp"

namespace bench {

using CycleStat = sim::CycleStat;

struct ProbeResult {
  std::map<int, CycleStat> sections;  // by label
  std::map<int, uint16_t> values;     // by key (0x80..0xFE)
  uint64_t overhead_cycles = 0;
  uint64_t total_cycles = 0;
  // With profile_label: the cycles spent at each program address (bytes) inside that
  // label's sections, summed over all of them.
  std::map<uint32_t, uint64_t> profile;
};

// Throws std::runtime_error when the image cannot be loaded or does not finish within
// budget_cycles. profile_label >= 0: also fills `profile` for that label's sections.
ProbeResult runProbe(const std::string& elf_path, uint64_t budget_cycles = 400000000ull,
                     int profile_label = -1);

// Cycles per program range: each range starts at a symbol (by name, in address order) and ends
// at the next one's address; the last ends where the function `end_symbol` (mangled name)
// ends. Symbols not in the image make the call throw.
struct ProfileRange {
  std::string name;  // what the user reads
  std::string symbol;
};
std::vector<std::pair<std::string, uint64_t>> cyclesByRange(const ProbeResult& r, const std::string& elf,
                                                            const std::vector<ProfileRange>& ranges,
                                                            const std::string& end_symbol);

// The probe built with this host build (empty if avr-g++ was missing at configure time).
std::string builtinProbePath();

}  // namespace bench
