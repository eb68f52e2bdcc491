// Benchmark 6 (runtime): the real read_run image in simavr, stepped one instruction at a time so
// that every cycle is attributed.
//
// read_run flies the tethered quad (tools/sim's QuadRig: four varied KV1100 + 9x4.7 motors on one
// 3S LiPo at 50 % charge) through `liftoff 300 1000 3000` (commands change every frame during the
// 1 s ramp, then a 3 s hold), at 50 and at 400 Hz, once with thesis (v1) records and once with v2
// records made on the host from the plant's sweeps (bench/records.hpp, as benchmark 1). Over
// the lift-off it counts:
//   CPU load      cycles the CPU is awake / all cycles (the image sleeps until the next
//                 interrupt between loop passes; simavr skips asleep cycles: Board::sleptCycles);
//   frame         awake cycles from entering rr::ReadRunApp::frame to its return: the four
//                 battery conversions (asleep while converting), the median, the v2 frame, the
//                 v1 motors and the four pulses, with the 1 ms tick and UART interrupts that hit it;
//   V2Frame::fly  the same for the v2 frame alone (benchmark 2 measures it without interrupts);
//   loop period   the longest time between two entries of rr::ReadRunApp::runOnce (normal
//                 running, with the lift-off's progress lines; the flood case is another bench).
// Stack: the SRAM between the end of .bss and the top is painted before reset; after the boot and
// the lift-off the lowest byte changed is the stack's high-water mark (benchmark 3's stack rows
// are sections_safety.cpp's, after the deepest paths).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>

#include <fmt/format.h>

#include "bench/sections.hpp"

#ifdef THRUSTCAL_BENCH_HAVE_SIM
extern "C" {
#include <simavr/sim_avr.h>
}
#include "bench/records.hpp"
#include "plant/bench.hpp"
#include "sim/board.hpp"
#include "sim/console.hpp"
#include "sim/rigs.hpp"
#include "sim/scenarios.hpp"
#endif

namespace bench {

#ifndef THRUSTCAL_BENCH_HAVE_SIM

Section runtimeSection(const AvrPaths&) {
  return unavailableSection("runtime", "6. Runtime",
                            "tools/sim (thrustcal_sim) is not part of this build: no simulated board");
}

#else

namespace {

constexpr uint16_t kRamEnd = 0x21FF;  // ATmega2560
constexpr uint8_t kPaint = 0xA5;

struct Symbol {
  uint32_t addr = 0, size = 0;
};

// Symbols of an image by mangled name (avr-nm -S): functions' addresses in bytes, data's in the
// data space (0x800000 + address).
std::map<std::string, Symbol> symbols(const std::string& elf) {
  std::unique_ptr<FILE, int (*)(FILE*)> p(popen(("avr-nm -S '" + elf + "' 2>/dev/null").c_str(), "r"), pclose);
  if (!p) throw std::runtime_error("cannot run avr-nm on " + elf + ": is binutils-avr installed?");
  std::map<std::string, Symbol> out;
  char line[512];
  while (fgets(line, sizeof line, p.get())) {
    // "ADDR SIZE TYPE NAME" or "ADDR TYPE NAME": split into words first (a type letter such
    // as B or D also reads as a hex size).
    char w[4][400];
    const int n = std::sscanf(line, "%399s %399s %399s %399s", w[0], w[1], w[2], w[3]);
    if (n == 4) {
      out[w[3]] = {static_cast<uint32_t>(std::strtoul(w[0], nullptr, 16)),
                   static_cast<uint32_t>(std::strtoul(w[1], nullptr, 16))};
    } else if (n == 3) {
      out[w[2]] = {static_cast<uint32_t>(std::strtoul(w[0], nullptr, 16)), 0};
    }
  }
  return out;
}

uint32_t need(const std::map<std::string, Symbol>& syms, const std::string& name, const std::string& elf) {
  auto it = syms.find(name);
  if (it == syms.end())
    throw std::runtime_error(fmt::format("{} has no symbol {}: is it the image of this source tree?", elf, name));
  return it->second.addr;
}

// Paints the SRAM the stack may use (end of .bss/.noinit to the top) before the first instruction.
uint16_t paintStack(sim::Board& board, const std::string& elf) {
  const auto syms = symbols(elf);
  // _end: the linker script's end of .bss and .noinit (__heap_start only exists with malloc)
  const uint16_t heap_start = static_cast<uint16_t>(need(syms, "_end", elf) & 0xFFFF);
  for (uint32_t a = heap_start; a <= kRamEnd; ++a) board.avr()->data[a] = kPaint;
  return heap_start;
}

// Bytes of stack used at the deepest: from the top down to the lowest byte changed.
uint32_t stackHighWater(sim::Board& board, uint16_t heap_start) {
  for (uint32_t a = heap_start; a <= kRamEnd; ++a)
    if (board.avr()->data[a] != kPaint) return kRamEnd - a + 1;
  return 0;
}

uint16_t stackPointer(const avr_t* avr) { return static_cast<uint16_t>(avr->data[0x5D] | (avr->data[0x5E] << 8)); }

// The 3-byte return address (the ATmega2560's PC is 17 bits) stacked above sp, in bytes.
uint32_t stackedReturn(const avr_t* avr, uint16_t sp) {
  const uint8_t* ret = &avr->data[sp + 1];
  return (static_cast<uint32_t>(ret[0]) << 16 | static_cast<uint32_t>(ret[1]) << 8 | ret[2]) * 2u;
}

constexpr uint32_t kVectorsEnd = 57 * 4;  // the ATmega2560's interrupt vectors, in bytes

// Cycles from a function's entry to its return, awake only (the CPU may sleep inside: the ADC).
struct CallTimer {
  uint32_t entry = 0;
  bool inside = false;
  uint16_t sp_at_entry = 0;
  uint32_t return_pc = 0;
  uint64_t awake = 0;
  uint64_t calls = 0, sum = 0, max = 0;
  uint64_t quiet_calls = 0, quiet_sum = 0, quiet_max = 0;  // calls that printed nothing
  uint64_t clean_max = 0;  // calls that printed nothing and no interrupt hit
  bool interrupted = false;
  const std::string* output = nullptr;  // the board's UART output
  size_t output_at_entry = 0;

  // Before an instruction: at the entry, SP is just below the return address the call pushed.
  void before(const avr_t* avr) {
    if (inside || avr->pc != entry) return;
    sp_at_entry = stackPointer(avr);
    return_pc = stackedReturn(avr, sp_at_entry);
    inside = true;
    awake = 0;
    interrupted = false;
    output_at_entry = output ? output->size() : 0;
  }
  // After it: the return lands on return_pc with the address popped, or on an interrupt vector
  // that stacked return_pc in the same place.
  void after(const avr_t* avr, uint64_t awake_cycles) {
    if (!inside) return;
    awake += awake_cycles;
    const uint16_t sp = stackPointer(avr);
    const bool returned = (avr->pc == return_pc && sp == sp_at_entry + 3) ||
                          (avr->pc < kVectorsEnd && sp == sp_at_entry && stackedReturn(avr, sp) == return_pc);
    if (!returned) {
      if (avr->pc < kVectorsEnd) interrupted = true;
      return;
    }
    inside = false;
    ++calls;
    sum += awake;
    max = std::max(max, awake);
    if (output && output->size() != output_at_entry) return;
    ++quiet_calls;
    quiet_sum += awake;
    quiet_max = std::max(quiet_max, awake);
    if (!interrupted) clean_max = std::max(clean_max, awake);
  }
};

struct FlightFigures {
  int hz = 0;
  std::string records;
  double cpu_load_pct = 0;    // all awake cycles / all cycles
  double frame_load_pct = 0;  // frame()'s awake cycles / all cycles
  uint64_t frames = 0, frame_mean = 0, frame_max = 0, frame_max_quiet = 0;
  uint64_t fly_calls = 0, fly_mean = 0, fly_max = 0, fly_max_clean = 0;
  double loop_period_max_ms = 0, loop_period_max_quiet_ms = 0, loop_period_mean_ms = 0;
  uint32_t stack_bytes = 0;
  double simulated_s = 0;
};

// The main loop's periods: from one entry of runOnce() to the next; quiet: nothing printed.
struct LoopPeriods {
  uint64_t last = 0, max = 0, max_quiet = 0, sum = 0, count = 0;
  size_t output_at_last = 0;
  void enter(uint64_t cycle, size_t output_size) {
    if (last) {
      const uint64_t period = cycle - last;
      max = std::max(max, period);
      if (output_size == output_at_last) max_quiet = std::max(max_quiet, period);
      sum += period;
      ++count;
    }
    last = cycle;
    output_at_last = output_size;
  }
};

// Everything timed while read_run flies.
struct FlightTimers {
  CallTimer frame, fly;  // rr::ReadRunApp::frame, tc::V2Frame::fly
  bool has_fly = false;  // the image has V2Frame::fly
  uint32_t run_once = 0; // rr::ReadRunApp::runOnce's entry
  LoopPeriods loop;
  uint64_t awake = 0;    // cycles the CPU did not sleep
};

// Runs one instruction with every timer around it.
void stepTimed(sim::Board& board, FlightTimers& t) {
  avr_t* avr = board.avr();
  const std::string& output = board.output();
  const uint64_t before = avr->cycle, slept_before = board.sleptCycles();
  if (avr->state != cpu_Sleeping && avr->pc == t.run_once) t.loop.enter(before, output.size());
  t.frame.before(avr);
  if (t.has_fly) t.fly.before(avr);
  const int state = avr_run(avr);
  if (state == cpu_Done || state == cpu_Crashed)
    throw std::runtime_error(fmt::format("read_run stopped at pc 0x{:05X} during the runtime bench", avr->pc));
  const uint64_t awake_now = avr->cycle - before - (board.sleptCycles() - slept_before);
  t.awake += awake_now;
  t.frame.after(avr, awake_now);
  if (t.has_fly) t.fly.after(avr, awake_now);
}

// True once read_run has printed the end of its lift-off (done, aborted or stopped) near or
// after `seen`.
bool liftoffEnded(const std::string& out, size_t seen) {
  const size_t from = seen > 64 ? seen - 64 : 0;
  return out.find("# liftoff done", from) != std::string::npos ||
         out.find("# liftoff aborted", from) != std::string::npos ||
         out.find("# liftoff stopped", from) != std::string::npos;
}

// The figures of a flight of `total` cycles from its timers.
void fillFigures(FlightFigures& f, uint64_t total, const FlightTimers& t) {
  f.simulated_s = sim::cyclesToSeconds(total);
  f.cpu_load_pct = total ? 100.0 * static_cast<double>(t.awake) / static_cast<double>(total) : 0.0;
  f.frames = t.frame.calls;
  f.frame_mean = t.frame.calls ? t.frame.sum / t.frame.calls : 0;
  f.frame_max = t.frame.max;
  f.frame_max_quiet = t.frame.quiet_max;
  f.frame_load_pct = total ? 100.0 * static_cast<double>(t.frame.sum) / static_cast<double>(total) : 0.0;
  f.fly_calls = t.fly.calls;
  f.fly_mean = t.fly.calls ? t.fly.sum / t.fly.calls : 0;
  f.fly_max = t.fly.max;
  f.fly_max_clean = t.fly.clean_max;
  f.loop_period_max_ms = 1000.0 * sim::cyclesToSeconds(t.loop.max);
  f.loop_period_max_quiet_ms = 1000.0 * sim::cyclesToSeconds(t.loop.max_quiet);
  f.loop_period_mean_ms = t.loop.count ? 1000.0 * sim::cyclesToSeconds(t.loop.sum / t.loop.count) : 0.0;
}

// The timers on read_run's frame(), V2Frame::fly and runOnce().
FlightTimers timersFor(const std::string& elf, const std::string& output) {
  const auto syms = symbols(elf);
  FlightTimers t;
  t.frame.output = t.fly.output = &output;
  t.frame.entry = need(syms, "_ZN2rr10ReadRunApp5frameEm", elf);
  t.has_fly = syms.count("_ZN2tc7V2Frame3flyEjh") != 0;
  t.fly.entry = t.has_fly ? syms.at("_ZN2tc7V2Frame3flyEjh").addr : 0xFFFFFFFF;
  t.run_once = need(syms, "_ZN2rr10ReadRunApp7runOnceEv", elf);
  return t;
}

// read_run through a lift-off on the tethered quad, stepped one instruction at a time.
FlightFigures flyReadRun(const std::string& elf, const std::vector<uint8_t>& eeprom, const std::string& records,
                         int hz) {
  FlightFigures f;
  f.hz = hz;
  f.records = records;
  plant::QuadFrameParams qp;
  qp.power = plant::BatteryParams::lipo3s(0.5);
  sim::QuadRig rig(elf, qp, benchRecords().motors, 0.05);
  rig.board.setEeprom(eeprom);
  const uint16_t heap_start = paintStack(rig.board, elf);
  sim::Console con(rig.board, "rr> ");
  con.waitPrompt(10.0);
  if (hz != 50) {
    const auto lines = con.command(fmt::format("rate {}", hz));
    for (const std::string& l : lines)
      if (l.rfind("error:", 0) == 0) throw std::runtime_error("read_run refused the rate: " + l);
  }
  FlightTimers timers = timersFor(elf, rig.board.output());
  con.send("liftoff 300 1000 3000");
  avr_t* avr = rig.board.avr();
  const uint64_t start = avr->cycle;
  size_t seen = rig.board.output().size();
  bool done = false;
  uint64_t instructions = 0;
  // read_run's lift-off stops without a line end for 500 ms: an empty line every 200 ms, as
  // board liftoff sends them
  const uint64_t keepalive = sim::secondsToCycles(0.2);
  uint64_t next_keepalive = start + keepalive;
  while (!done && avr->cycle - start < sim::secondsToCycles(8.0)) {
    if (avr->cycle >= next_keepalive) {
      con.send("");
      next_keepalive += keepalive;
    }
    stepTimed(rig.board, timers);
    if ((++instructions & 0x3FFF) == 0 && rig.board.output().size() != seen) {
      done = liftoffEnded(rig.board.output(), seen);
      seen = rig.board.output().size();
    }
  }
  if (!done || rig.board.output().find("# liftoff done") == std::string::npos)
    throw std::runtime_error("read_run did not finish the lift-off in the runtime bench:\n" + con.tail());
  fillFigures(f, avr->cycle - start, timers);
  con.waitPrompt(2.0);
  f.stack_bytes = stackHighWater(rig.board, heap_start);
  return f;
}

}  // namespace

Section runtimeSection(const AvrPaths& paths) {
  Section s;
  s.key = "runtime";
  const std::string title =
      "6. Runtime: read_run in simavr on the tethered quad, liftoff 300 g (1 s ramp, 3 s hold), one 3S "
      "LiPo at 50 %; cycles awake, interrupts included";
  const std::string elf = paths.elf("read_run");
  if (!std::filesystem::exists(elf))
    return unavailableSection("runtime", title,
                              elf + " not found: build the AVR tree (--target read_run) or pass --avr-build DIR");
  Table t(title, {"records", "rate", "CPU load", "frame() load", "frame() mean", "max, quiet", "max, printing",
                  "V2Frame::fly max", "no interrupt", "loop period max, quiet", "with a print"});
  const BenchRecords& records = benchRecords();
  for (const int hz : {50, 400}) {
    for (const char* kind : {"v2", "v1"}) {
      std::cerr << fmt::format("bench: read_run runtime in simavr, {} records, {} Hz\n", kind, hz);
      const bool v2 = std::string(kind) == "v2";
      const FlightFigures f = flyReadRun(elf, v2 ? records.v2 : records.v1, kind, hz);
      t.addRow({v2 ? "v2 (store v2)" : "thesis v1", fmt::format("{} Hz", hz), fmt::format("{:.1f} %", f.cpu_load_pct),
                fmt::format("{:.1f} %", f.frame_load_pct), std::to_string(f.frame_mean),
                std::to_string(f.frame_max_quiet), std::to_string(f.frame_max),
                f.fly_calls ? std::to_string(f.fly_max) : "-", f.fly_calls ? std::to_string(f.fly_max_clean) : "-",
                fmt::format("{:.2f} ms", f.loop_period_max_quiet_ms),
                fmt::format("{:.2f} ms", f.loop_period_max_ms)});
      s.json[fmt::format("hz{}", hz)][kind] = {{"cpu_load_pct", f.cpu_load_pct},
                                               {"frame_load_pct", f.frame_load_pct},
                                               {"frames", f.frames},
                                               {"frame_cycles_mean", f.frame_mean},
                                               {"frame_cycles_max_quiet", f.frame_max_quiet},
                                               {"frame_cycles_max", f.frame_max},
                                               {"fly_calls", f.fly_calls},
                                               {"fly_cycles_mean", f.fly_mean},
                                               {"fly_cycles_max", f.fly_max},
                                               {"fly_cycles_max_no_interrupt", f.fly_max_clean},
                                               {"loop_period_mean_ms", f.loop_period_mean_ms},
                                               {"loop_period_max_quiet_ms", f.loop_period_max_quiet_ms},
                                               {"loop_period_max_ms", f.loop_period_max_ms},
                                               {"stack_bytes", f.stack_bytes},
                                               {"simulated_s", f.simulated_s}};
      if (!v2) continue;
      s.targets.push_back({fmt::format("6. read_run CPU load at {} Hz (v2, lift-off)", hz),
                           fmt::format("{:.1f} % (frames {:.1f} %)", f.cpu_load_pct, f.frame_load_pct),
                           "measured by bench", true});
      s.targets.push_back({fmt::format("6. read_run worst loop period at {} Hz (v2, lift-off)", hz),
                           fmt::format("{:.2f} ms ({:.2f} ms with a progress line)", f.loop_period_max_quiet_ms,
                                       f.loop_period_max_ms),
                           "measured by bench", true});
    }
  }
  t.addNote("CPU load: awake cycles / all cycles over the lift-off (simavr skips the idle sleep); frame() load: "
            "the awake cycles inside rr::ReadRunApp::frame / all cycles (the four battery conversions sleep)");
  t.addNote("frame() cycles from entry to return, awake, with the 1 ms tick and UART interrupts that hit it; quiet: "
            "frames that printed nothing; printing: the frames that wrote a lift-off progress line (the UART write "
            "waits for the transmitter); V2Frame::fly: the v2 motors' frame inside it, with the interrupts that hit it and over the calls no "
            "interrupt hit (benchmark 2 times it in the probe)");
  t.addNote("loop period: between entries of rr::ReadRunApp::runOnce (the main loop wakes on each 1 ms tick); "
            "quiet: periods in which nothing was printed; the flood case is another bench");
  t.addNote("records made on the host from the plant's sweeps (as benchmark 1): thesis curves at 12.4 V and "
            "10.5 V with the sag offsets, model v2 fit + refine");
  s.json["available"] = true;
  s.tables.push_back(std::move(t));
  return s;
}

#endif

}  // namespace bench
