// Host side of the cycle benchmark: runs v2_cycles.elf in libsimavr (ATmega2560, 16 MHz) and
// timestamps the marker writes (GPIOR0/1) with avr->cycle. Prints per label: count, mean,
// min and max cycles, net of the empty bracket's overhead. The result bytes the program
// streams through GPIOR2 go to RESULTS_HEX (hex, 32 per line) for the AVR/host comparison.
//   run_cycles path/to/v2_cycles.elf RESULTS_HEX
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <vector>

namespace {

constexpr avr_io_addr_t kGpior0 = 0x3E;  // I/O 0x1E + 0x20
constexpr avr_io_addr_t kGpior1 = 0x4A;  // I/O 0x2A + 0x20
constexpr avr_io_addr_t kGpior2 = 0x4B;  // I/O 0x2B + 0x20

struct Stat {
  uint64_t n = 0, sum = 0, min = UINT64_MAX, max = 0;
};
Stat stats[256];
uint8_t label = 0;
avr_cycle_count_t started = 0;
bool done = false;
std::vector<uint8_t> results;

void onGpior0(avr_t* avr, avr_io_addr_t addr, uint8_t v, void*) {
  avr->data[addr] = v;
  if (v == 1) {
    started = avr->cycle;
  } else if (v == 2) {
    const uint64_t d = avr->cycle - started;
    Stat& s = stats[label];
    ++s.n;
    s.sum += d;
    if (d < s.min) s.min = d;
    if (d > s.max) s.max = d;
  } else if (v == 3) {
    done = true;
  }
}
void onGpior1(avr_t* avr, avr_io_addr_t addr, uint8_t v, void*) {
  avr->data[addr] = v;
  label = v;
}
void onGpior2(avr_t* avr, avr_io_addr_t addr, uint8_t v, void*) {
  avr->data[addr] = v;
  results.push_back(v);
}

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

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s v2_cycles.elf RESULTS_HEX\n", argv[0]);
    return 2;
  }
  elf_firmware_t fw;
  std::memset(&fw, 0, sizeof fw);
  if (elf_read_firmware(argv[1], &fw) != 0) {
    std::fprintf(stderr, "cannot read %s: build it with tests/core_v2/avr_cycles.sh\n", argv[1]);
    return 1;
  }
  avr_t* avr = avr_make_mcu_by_name("atmega2560");
  if (!avr) {
    std::fprintf(stderr, "simavr has no atmega2560 core\n");
    return 1;
  }
  avr_init(avr);
  avr->frequency = 16000000;
  avr_load_firmware(avr, &fw);
  avr_register_io_write(avr, kGpior0, onGpior0, nullptr);
  avr_register_io_write(avr, kGpior1, onGpior1, nullptr);
  avr_register_io_write(avr, kGpior2, onGpior2, nullptr);
  const avr_cycle_count_t budget = 2000000000ull;  // 125 simulated seconds
  while (!done && avr->cycle < budget) {
    const int state = avr_run(avr);
    if (state == cpu_Done || state == cpu_Crashed) break;
  }
  if (!done) {
    std::fprintf(stderr, "benchmark did not finish within %llu cycles\n",
                 static_cast<unsigned long long>(budget));
    return 1;
  }
  FILE* hex = std::fopen(argv[2], "w");
  if (!hex) {
    std::fprintf(stderr, "cannot write %s\n", argv[2]);
    return 1;
  }
  for (size_t i = 0; i < results.size(); ++i)
    std::fprintf(hex, "%02x%s", results[i], ((i + 1) % 32) ? "" : "\n");
  if (results.size() % 32) std::fprintf(hex, "\n");
  std::fclose(hex);
  const uint64_t overhead = stats[0].n ? stats[0].min : 0;
  std::printf("ATmega2560 cycles (simavr, 16 MHz), net of %llu cycles of marker overhead:\n",
              static_cast<unsigned long long>(overhead));
  for (int l = 1; l < 256; ++l) {
    const Stat& s = stats[l];
    if (!s.n) continue;
    std::printf("  [%2d] %-62s n=%4llu mean %7llu  min %7llu  max %7llu\n", l, nameOf(l),
                static_cast<unsigned long long>(s.n),
                static_cast<unsigned long long>(s.sum / s.n - overhead),
                static_cast<unsigned long long>(s.min - overhead),
                static_cast<unsigned long long>(s.max - overhead));
  }
  return 0;
}
