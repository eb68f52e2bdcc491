// Host side of the cycle benchmark: runs v2_cycles.elf with sim::runCycleProbe (ATmega2560,
// 16 MHz, sim/cycle_probe.hpp) and prints per label: count, mean, min and max cycles, net of
// the empty bracket's overhead. The result bytes the program reports go to RESULTS_HEX (hex,
// 32 per line) for the AVR/host comparison.
//   run_cycles path/to/v2_cycles.elf RESULTS_HEX
#include <cstdint>
#include <cstdio>
#include <exception>
#include <vector>

#include "sim/cycle_probe.hpp"

namespace {

constexpr int kResultsKey = 0x80;  // v2_cycles.cpp reports its results under this key

const char* nameOf(int l) {
  switch (l) {
    case 1: return "v2 four-motor frame as read_run flies it (V2Frame::fly)";
    case 2: return "v2 four-motor frame with sag prediction";
    case 3: return "thesis option 2.1 frame (forceToPwm x4, no voltage filter)";
    case 4: return "v2 four-motor frame, one forceToPwmV2 call per motor";
    case 5: return "v2 bus voltage filter update alone";
    case 10: case 11: case 12: case 13: return "v2 fit on the AVR, one 101-sample sweep";
    case 20: return "v2 refine, one 101-sample sweep";
  }
  return "?";
}

bool writeHex(const char* path, const std::vector<uint8_t>& results) {
  FILE* hex = std::fopen(path, "w");
  if (!hex) return false;
  for (size_t i = 0; i < results.size(); ++i)
    std::fprintf(hex, "%02x%s", results[i], ((i + 1) % 32) ? "" : "\n");
  if (results.size() % 32) std::fprintf(hex, "\n");
  std::fclose(hex);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s v2_cycles.elf RESULTS_HEX\n", argv[0]);
    return 2;
  }
  sim::CycleProbeRun r;
  try {
    r = sim::runCycleProbe(argv[1], 2000000000ull);  // 125 simulated seconds
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s (build it with tests/core_v2/avr_cycles.sh)\n", e.what());
    return 1;
  }
  const auto results = r.reported.count(kResultsKey) ? r.reported.at(kResultsKey) : std::vector<uint8_t>{};
  if (!writeHex(argv[2], results)) {
    std::fprintf(stderr, "cannot write %s\n", argv[2]);
    return 1;
  }
  std::printf("ATmega2560 cycles (simavr, 16 MHz), net of %llu cycles of marker overhead:\n",
              static_cast<unsigned long long>(r.overhead_cycles));
  for (const auto& [label, s] : r.sections)
    std::printf("  [%2d] %-62s n=%4llu mean %7llu  min %7llu  max %7llu\n", label, nameOf(label),
                static_cast<unsigned long long>(s.count), static_cast<unsigned long long>(s.mean),
                static_cast<unsigned long long>(s.min), static_cast<unsigned long long>(s.max));
  return 0;
}
