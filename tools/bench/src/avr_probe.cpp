#include "sim/lsan_simavr.hpp"
#include "bench/avr_probe.hpp"

#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>

#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace bench {

namespace {

constexpr avr_io_addr_t kGpior0 = 0x3E;  // I/O 0x1E + 0x20
constexpr avr_io_addr_t kGpior1 = 0x4A;  // I/O 0x2A + 0x20
constexpr avr_io_addr_t kGpior2 = 0x4B;  // I/O 0x2B + 0x20

struct Raw {
  uint64_t n = 0, sum = 0, min = UINT64_MAX, max = 0;
};

struct State {
  std::map<int, Raw> raw;
  std::map<int, std::string> bytes;
  uint8_t label = 0;
  avr_cycle_count_t started = 0;
  bool done = false;
};

void onGpior0(avr_t* avr, avr_io_addr_t addr, uint8_t v, void* param) {
  auto* s = static_cast<State*>(param);
  avr->data[addr] = v;
  if (v == 1) {
    s->started = avr->cycle;
  } else if (v == 2) {
    const uint64_t d = avr->cycle - s->started;
    Raw& r = s->raw[s->label];
    ++r.n;
    r.sum += d;
    r.min = std::min(r.min, d);
    r.max = std::max(r.max, d);
  }
}
void onGpior1(avr_t* avr, avr_io_addr_t addr, uint8_t v, void* param) {
  auto* s = static_cast<State*>(param);
  avr->data[addr] = v;
  s->label = v;
  if (v == 0xFF) s->done = true;
}
void onGpior2(avr_t* avr, avr_io_addr_t addr, uint8_t v, void* param) {
  auto* s = static_cast<State*>(param);
  avr->data[addr] = v;
  if (s->label >= 0x80 && s->label != 0xFF) s->bytes[s->label].push_back(static_cast<char>(v));
}
void noSleep(avr_t*, avr_cycle_count_t) {}
void quietLogger(avr_t*, const int level, const char* format, va_list ap) {
  if (level <= LOG_ERROR) std::vfprintf(stderr, format, ap);
}

// simavr's global logger prints "Loaded ... .text" on stdout; keep only errors while loading.
struct QuietLog {
  avr_logger_p old = avr_global_logger_get();
  QuietLog() { avr_global_logger_set(quietLogger); }
  ~QuietLog() { avr_global_logger_set(old); }
};

}  // namespace

ProbeResult runProbe(const std::string& elf_path, uint64_t budget_cycles) {
  const QuietLog quiet;
  elf_firmware_t fw;
  std::memset(&fw, 0, sizeof fw);
  if (elf_read_firmware(elf_path.c_str(), &fw) != 0)
    throw std::runtime_error("cannot read the AVR probe " + elf_path +
                             ": rebuild the host tree (tools/bench builds it with avr-g++)");
  avr_t* avr = avr_make_mcu_by_name("atmega2560");
  if (!avr) throw std::runtime_error("simavr has no atmega2560 core");
  avr_init(avr);
  avr->frequency = 16000000;
  avr->log = 0;
  avr_load_firmware(avr, &fw);
  avr->sleep = noSleep;
  State s;
  avr_register_io_write(avr, kGpior0, onGpior0, &s);
  avr_register_io_write(avr, kGpior1, onGpior1, &s);
  avr_register_io_write(avr, kGpior2, onGpior2, &s);
  while (!s.done && avr->cycle < budget_cycles) {
    const int state = avr_run(avr);
    if (state == cpu_Done || state == cpu_Crashed) break;
  }
  ProbeResult r;
  r.total_cycles = avr->cycle;
  avr_terminate(avr);
  if (!s.done)
    throw std::runtime_error("the AVR probe " + elf_path + " did not finish within " +
                             std::to_string(budget_cycles) + " simulated cycles (crashed or hung)");
  r.overhead_cycles = s.raw.count(0) ? s.raw[0].min : 0;
  for (const auto& [label, raw] : s.raw) {
    if (label == 0 || raw.n == 0) continue;
    const uint64_t o = r.overhead_cycles;
    r.sections[label] = {raw.n, raw.sum / raw.n - o, raw.min - o, raw.max - o};
  }
  for (const auto& [key, b] : s.bytes)
    if (b.size() >= 2)
      r.values[key] = static_cast<uint16_t>(static_cast<uint8_t>(b[0]) | static_cast<uint8_t>(b[1]) << 8);
  return r;
}

std::string builtinProbePath() {
#ifdef THRUSTCAL_BENCH_PROBE_ELF
  return THRUSTCAL_BENCH_PROBE_ELF;
#else
  return {};
#endif
}

}  // namespace bench
