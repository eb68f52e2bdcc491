#include "sim/lsan_simavr.hpp"
#include "bench/avr_probe.hpp"

#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>

#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <memory>
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

ProbeResult runProbe(const std::string& elf_path, uint64_t budget_cycles, int profile_label) {
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
  ProbeResult r;
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

std::vector<std::pair<std::string, uint64_t>> cyclesByRange(const ProbeResult& r, const std::string& elf,
                                                            const std::vector<ProfileRange>& ranges,
                                                            const std::string& end_symbol) {
  // Symbol addresses from avr-nm (local labels of inline assembly included).
  std::unique_ptr<FILE, int (*)(FILE*)> p(popen(("avr-nm -S '" + elf + "' 2>/dev/null").c_str(), "r"), pclose);
  if (!p) throw std::runtime_error("cannot run avr-nm on " + elf + ": is binutils-avr installed?");
  std::map<std::string, uint32_t> address, size;
  char line[512];
  while (fgets(line, sizeof line, p.get())) {
    char name[400];
    unsigned addr = 0, bytes = 0;
    char type = 0;
    if (std::sscanf(line, "%x %x %c %399s", &addr, &bytes, &type, name) == 4) {
      address[name] = addr;
      size[name] = bytes;
    } else if (std::sscanf(line, "%x %c %399s", &addr, &type, name) == 3) {
      address[name] = addr;
    }
  }
  std::vector<uint32_t> starts;
  for (const ProfileRange& range : ranges) {
    if (!address.count(range.symbol))
      throw std::runtime_error("the AVR probe " + elf + " has no symbol " + range.symbol +
                               ": rebuild it (tools/bench builds it from core/)");
    starts.push_back(address.at(range.symbol));
  }
  if (!size.count(end_symbol)) throw std::runtime_error("the AVR probe has no function " + end_symbol);
  const uint32_t end = address.at(end_symbol) + size.at(end_symbol);
  std::vector<std::pair<std::string, uint64_t>> out;
  for (size_t i = 0; i < ranges.size(); ++i) {
    const uint32_t lo = starts[i], hi = i + 1 < ranges.size() ? starts[i + 1] : end;
    uint64_t sum = 0;
    for (auto it = r.profile.lower_bound(lo); it != r.profile.end() && it->first < hi; ++it) sum += it->second;
    out.emplace_back(ranges[i].name, sum);
  }
  return out;
}

std::string builtinProbePath() {
#ifdef THRUSTCAL_BENCH_PROBE_ELF
  return THRUSTCAL_BENCH_PROBE_ELF;
#else
  return {};
#endif
}

}  // namespace bench
