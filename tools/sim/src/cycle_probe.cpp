#include "sim/cycle_probe.hpp"

#include "hal/board.hpp"
#include "sim/lsan_simavr.hpp"

#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>

#include <algorithm>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace sim {

namespace {

constexpr avr_io_addr_t kGpior0 = 0x3E;  // I/O 0x1E + 0x20
constexpr avr_io_addr_t kGpior1 = 0x4A;  // I/O 0x2A + 0x20
constexpr avr_io_addr_t kGpior2 = 0x4B;  // I/O 0x2B + 0x20
constexpr uint8_t kDone = 0xFF;
constexpr uint8_t kFirstKey = 0x80;

struct Raw {
  uint64_t n = 0, sum = 0, min = UINT64_MAX, max = 0;
};

struct State {
  std::map<int, Raw> raw;
  std::map<int, std::vector<uint8_t>> reported;
  uint8_t label = 0;
  avr_cycle_count_t started = 0;
  bool done = false;
  bool in_section = false;
};

void onGpior0(avr_t* avr, avr_io_addr_t addr, uint8_t v, void* param) {
  auto* s = static_cast<State*>(param);
  avr->data[addr] = v;
  if (v == 1) {
    s->started = avr->cycle;
    s->in_section = true;
  } else if (v == 2) {
    s->in_section = false;
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
  if (v == kDone) s->done = true;
}
void onGpior2(avr_t* avr, avr_io_addr_t addr, uint8_t v, void* param) {
  auto* s = static_cast<State*>(param);
  avr->data[addr] = v;
  if (s->label >= kFirstKey && s->label != kDone) s->reported[s->label].push_back(v);
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

// Net statistics per label, the empty bracket's overhead subtracted.
void summarize(const State& s, CycleProbeRun& r) {
  r.overhead_cycles = s.raw.count(0) ? s.raw.at(0).min : 0;
  for (const auto& [label, raw] : s.raw) {
    if (label == 0 || raw.n == 0) continue;
    const uint64_t o = r.overhead_cycles;
    r.sections[label] = {raw.n, raw.sum / raw.n - o, raw.min - o, raw.max - o};
  }
  r.reported = s.reported;
}

}  // namespace

CycleProbeRun runCycleProbe(const std::string& elf_path, uint64_t budget_cycles, int profile_label) {
  const QuietLog quiet;
  elf_firmware_t fw;
  std::memset(&fw, 0, sizeof fw);
  if (elf_read_firmware(elf_path.c_str(), &fw) != 0)
    throw std::runtime_error("cannot read the AVR image " + elf_path + ": build it first");
  avr_t* avr = avr_make_mcu_by_name("atmega2560");
  if (!avr) throw std::runtime_error("simavr has no atmega2560 core");
  avr_init(avr);
  avr->frequency = hal::kCpuHz;
  avr->log = 0;
  avr_load_firmware(avr, &fw);
  avr->sleep = noSleep;
  State s;
  avr_register_io_write(avr, kGpior0, onGpior0, &s);
  avr_register_io_write(avr, kGpior1, onGpior1, &s);
  avr_register_io_write(avr, kGpior2, onGpior2, &s);
  CycleProbeRun r;
  while (!s.done && avr->cycle < budget_cycles) {
    // avr_run executes one instruction: its cycles belong to the address it started at.
    const bool profiling = s.in_section && s.label == profile_label;
    const uint32_t pc = avr->pc;
    const avr_cycle_count_t before = avr->cycle;
    const int state = avr_run(avr);
    if (profiling) r.profile[pc] += avr->cycle - before;
    if (state == cpu_Done || state == cpu_Crashed) break;
  }
  r.total_cycles = avr->cycle;
  avr_terminate(avr);
  if (!s.done)
    throw std::runtime_error("the AVR image " + elf_path + " did not finish within " +
                             std::to_string(budget_cycles) + " simulated cycles (crashed or hung)");
  summarize(s, r);
  return r;
}

}  // namespace sim
