// Runs an AVR probe image in libsimavr (ATmega2560, 16 MHz) and collects what it reports
// through the GPIOR registers (protocol in tools/bench/avr/probe.cpp): cycle counts of
// labelled sections, net of the empty bracket's overhead, and 16-bit values.
#pragma once
#include <cstdint>
#include <map>
#include <string>

namespace bench {

struct CycleStat {
  uint64_t count = 0, mean = 0, min = 0, max = 0;
};

struct ProbeResult {
  std::map<int, CycleStat> sections;  // by label
  std::map<int, uint16_t> values;     // by key (0x80..0xFE)
  uint64_t overhead_cycles = 0;
  uint64_t total_cycles = 0;
};

// Throws std::runtime_error when the image cannot be loaded or does not finish within
// budget_cycles.
ProbeResult runProbe(const std::string& elf_path, uint64_t budget_cycles = 400000000ull);

// The probe built with this host build (empty if avr-g++ was missing at configure time).
std::string builtinProbePath();

}  // namespace bench
