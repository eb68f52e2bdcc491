// Benchmark 6 (safety, issue 8) and the stack rows of benchmark 3 (footprint): the real images
// in simavr, measured in simulated cycles (docs/safety.md).
//
// Time to stop after a hang: a hang is injected into the running image by patching its flash
// (the main loop's function, or the ADC read a sweep waits in, becomes "rjmp ." or
// "cli; rjmp ."); from the moment the program runs into the patch (a PC probe) to the end of
// the last ESC pulse wider than 1050 us.
// Loop timing: read_run with all four motors at 200 g (two v1, two v2 slots) while the UART
// delivers a flood: frame starts seen from outside (the first of each frame's four battery
// conversions on A1), the main loop's passes and the time-critical service() calls seen by
// probes on the instructions that start rr::ReadRunApp::runOnce() and ::service().
// Stack: each image runs its deepest paths, then `status` reports the stack bytes never used.
#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>

#include "bench/sections.hpp"

#ifdef THRUSTCAL_BENCH_HAVE_SIM
#include "plant/bench.hpp"
#include "sim/board.hpp"
#include "sim/console.hpp"
#include "sim/elf_symbols.hpp"
#include "sim/faults.hpp"
#include "sim/rigs.hpp"
#include "sim/scenarios.hpp"
#include "sim/stack_scenario.hpp"
#endif

namespace bench {

namespace {
constexpr double kStopTargetMs = 100.0;    // issue 8: target 100 ms (required 150 ms)
constexpr double kStopRequiredMs = 150.0;
}  // namespace

#ifndef THRUSTCAL_BENCH_HAVE_SIM

Section safetySection(const AvrPaths&) {
  Section s;
  s.key = "safety";
  Table t("6. Safety", {"item", "figure", "target", "met?"});
  t.addRow({"not available", "-", "-", "-"});
  t.addNote("tools/sim (thrustcal_sim) is not part of this build");
  s.tables.push_back(std::move(t));
  s.json = {{"available", false}};
  return s;
}

void addStackHeadroom(const AvrPaths&, Table& t, nlohmann::json&, std::vector<TargetCheck>&) {
  t.addRow({"stack never used: not available (no tools/sim in this build)", "", "", "-", "-"});
}

#else

namespace {

std::string ms(double s) { return fmt::format("{:.1f} ms", s * 1000.0); }

// --- time to stop after a hang ---------------------------------------------------------------

struct StopRun {
  double stop_s = -1;   // hang -> end of the last pulse > 1050 us
  double reset_s = -1;  // hang -> watchdog reset
  bool boot_says_watchdog = false;
  double widest_after_us = 0;  // widest pulse from the reset to 1 s later
};

// Hangs `symbol` in the running image, runs on through the watchdog reset (the patch is taken
// out at the reset) and the next boot, and measures.
StopRun hangAndMeasure(sim::Board& board, sim::Console& con, const sim::PulseLog& log,
                       const std::string& elf, const std::string& symbol, sim::Hang how) {
  StopRun r;
  sim::FlashPatch patch;
  board.addResetListener([&](uint64_t) { sim::restoreFlash(board, patch); });
  patch = sim::hangFunction(board, elf, symbol, how);
  board.runFor(0.5);
  const double t_hang = *patch.hung_at_s;
  if (board.resets() == 0 || t_hang < 0) return r;
  r.stop_s = log.lastWiderThan(1050.0) - t_hang;
  r.reset_s = sim::cyclesToSeconds(board.lastResetCycle()) - t_hang;
  con.waitPrompt(10.0);
  const double t_reset = sim::cyclesToSeconds(board.lastResetCycle());
  board.runFor(1.0);
  r.boot_says_watchdog = board.output().find("reset: watchdog") != std::string::npos;
  r.widest_after_us = log.widestBetween(t_reset, board.timeS());
  return r;
}

StopRun hangReadRun(const std::string& elf, sim::Hang how) {
  sim::Board board(elf);
  board.setAdcSource([](int ch) { return ch == 1 ? sim::batteryPinMv() : 0.0; });
  board.setEeprom(sim::calibratedTestEeprom());
  sim::Console con(board, "rr> ");
  sim::PulseLog log(board);
  con.waitPrompt(10.0);
  con.command("f 200");
  for (int i = 0; i < 5; ++i) {
    con.send("");
    board.runFor(0.2);
  }
  return hangAndMeasure(board, con, log, elf, "rr::ReadRunApp::runOnce()", how);
}

StopRun hangGatherStoreSweep(const std::string& elf, sim::Hang how) {
  sim::Board board(elf);
  board.setAdcSource([](int ch) { return ch == 1 ? sim::batteryPinMv() : 2000.0; });
  sim::Console con(board, "gs> ");
  sim::PulseLog log(board);
  con.waitPrompt(10.0);
  con.command("tare", 5.0);
  con.command("settle 50");
  con.send("sweep");
  if (!board.runUntil([&] { return board.escPulseUs(0) > 1200.0; }, sim::secondsToCycles(30)))
    return StopRun{};
  return hangAndMeasure(board, con, log, elf, "hal::Adc::readCounts(unsigned char)", how);
}

// --- loop timing under floods ----------------------------------------------------------------

struct Timing {
  int frames = 0;
  double frame_max_s = 0, frame_min_s = 1e9;  // distance between successive frame starts
  double loop_max_s = 0;                     // between runOnce() entries
  double service_max_s = 0;                  // between service() entries
  bool failsafe = false;                     // it tripped during the flood
};

struct Interval {
  double last = -1, max = 0, min = 1e9;
  int n = 0;
  void at(double t) {
    if (last >= 0) {
      max = std::max(max, t - last);
      min = std::min(min, t - last);
    }
    last = t;
    ++n;
  }
};

Timing loopTiming(const std::string& elf, int rate_hz, const std::string& flood, bool keep_alive) {
  sim::Board board(elf);
  sim::Console con(board, "rr> ");
  board.setEeprom(sim::calibratedTestEeprom());
  bool measuring = false;
  Interval frames, loops, services;
  double last_conv = -1;
  board.setAdcSource([&](int ch) {
    if (ch == 1) {
      const double t = board.timeS();
      if (measuring && (last_conv < 0 || t - last_conv > 0.001)) frames.at(t);
      last_conv = t;
    }
    return ch == 1 ? sim::batteryPinMv() : 0.0;
  });
  board.watchPc(sim::elfSymbol(elf, "rr::ReadRunApp::runOnce()").address, [&](uint64_t c) {
    if (measuring) loops.at(sim::cyclesToSeconds(c));
  });
  board.watchPc(sim::elfSymbol(elf, "rr::ReadRunApp::service()").address, [&](uint64_t c) {
    if (measuring) services.at(sim::cyclesToSeconds(c));
  });
  con.waitPrompt(10.0);
  if (rate_hz != 50) con.command(fmt::format("rate {}", rate_hz));
  con.command("f 200");
  board.runFor(0.1);
  const std::size_t out_from = board.output().size();
  measuring = true;
  board.sendText(flood);
  const uint64_t end = board.cycle() + sim::secondsToCycles(2.0);
  while (board.cycle() < end) {
    if (keep_alive) con.send("");
    board.run(std::min<uint64_t>(sim::secondsToCycles(0.2), end - board.cycle()));
  }
  measuring = false;
  const double t_end = board.timeS();
  Timing r;
  r.frames = frames.n;
  r.frame_max_s = std::max(frames.max, t_end - frames.last);
  r.frame_min_s = frames.min;
  r.loop_max_s = std::max(loops.max, t_end - loops.last);
  r.service_max_s = std::max(services.max, t_end - services.last);
  r.failsafe = board.output().find("failsafe:", out_from) != std::string::npos;
  return r;
}

std::string repeat(const std::string& s, std::size_t bytes) {
  std::string out;
  while (out.size() < bytes) out += s;
  return out;
}

// Table 6a: a hang in each image (main loop or sweep, interrupts on or off) and the time until
// every ESC pulse wider than 1050 us has stopped.
Table hangTable(const std::string& rr, const std::string& gs, Section& s) {
  Table stop("6a. Safety: a hang stops every ESC pulse wider than 1050 us (watchdog, simavr "
             "cycles; hang injected by patching the image's flash)",
             {"hang", "last pulse > 1050 us ends", "watchdog reset", "after the reset", "target",
              "met?"});
  struct HangSpec {
    const char* key;
    const char* name;
    bool read_run;
    sim::Hang how;
  };
  const HangSpec hangs[] = {
      {"read_run_loop_interrupts_on", "read_run main loop, interrupts on (rjmp .)", true, sim::Hang::kInterruptsOn},
      {"read_run_loop_interrupts_off", "read_run main loop, interrupts off (cli; rjmp .)", true, sim::Hang::kInterruptsOff},
      {"gather_store_sweep_interrupts_on", "gather_store sweep in its ADC read, interrupts on", false, sim::Hang::kInterruptsOn},
      {"gather_store_sweep_interrupts_off", "gather_store sweep in its ADC read, interrupts off", false, sim::Hang::kInterruptsOff},
  };
  double worst_stop = 0;
  bool all_ok = true;
  for (const HangSpec& h : hangs) {
    const StopRun r = h.read_run ? hangReadRun(rr, h.how) : hangGatherStoreSweep(gs, h.how);
    const bool ok = r.stop_s >= 0 && r.stop_s * 1000 <= kStopTargetMs && r.boot_says_watchdog &&
                    r.widest_after_us <= 1000.6;
    all_ok = all_ok && ok;
    worst_stop = std::max(worst_stop, r.stop_s < 0 ? 1e9 : r.stop_s);
    stop.addRow({h.name, r.stop_s < 0 ? "no reset" : ms(r.stop_s),
                 r.reset_s < 0 ? "-" : ms(r.reset_s),
                 r.stop_s < 0 ? "-" : fmt::format("\"reset: watchdog\" {}, widest {:.0f} us",
                                                  r.boot_says_watchdog ? "printed" : "MISSING",
                                                  r.widest_after_us),
                 "<= 100 ms, then 1000 us", verdict(ok)});
    s.json["hang"][h.key] = {{"time_to_stop_ms", r.stop_s * 1000}, {"reset_after_ms", r.reset_s * 1000},
                             {"boot_says_watchdog", r.boot_says_watchdog},
                             {"widest_pulse_after_reset_us", r.widest_after_us}, {"met", ok}};
  }
  stop.addNote("watchdog WDTO_60MS: 8192 cycles of the 128 kHz oscillator, 64 ms in simavr; kicked "
               "by read_run's service() (every 1 ms tick) and inside gather_store's waits; worst "
               "case on the chip about 64 ms + the longest gap between kicks (the oscillator "
               "runs slow at 5 V: ~70-75 ms)");
  stop.addNote("a pulse in progress at the reset ends there: the chip releases every pin");
  s.targets.push_back({"6. time to stop every ESC pulse > 1050 us after a hang (worst of 4)",
                       ms(worst_stop), "<= 100 ms (required 150 ms)", all_ok});
  return stop;
}

// Table 6b: read_run's frames, service() and loop passes under four kinds of input, at 50 and
// 400 Hz.
Table floodTable(const std::string& rr, Section& s) {
  Table loop("6b. Safety: read_run's loop under floods, four motors at 200 g (simavr; 2 s each)",
             {"input", "rate", "frames", "frame interval min..max", "jitter", "service() max gap",
              "runOnce() max gap", "target", "met?"});
  struct FloodSpec {
    const char* key;
    const char* name;
    std::string bytes;
    bool keep_alive;
  };
  const FloodSpec floods[] = {
      {"idle", "keep-alive lines only", "", true},
      {"flood_no_line_end", "char + backspace, no line end (3 s)", repeat("a\b", 35000), false},
      {"burst_short_lines", "300 'f 200' lines at once", repeat("f 200\r", 1800), true},
      {"burst_long_replies", "10 help + 10 status at once", repeat("help\rstatus\r", 120), true},
  };
  double worst_jitter = 0;
  bool loop_ok = true;
  for (int hz : {50, 400}) {
    const double period = 1.0 / hz;
    // The frame schedule runs on the 1 ms clock (400 Hz alternates 2 and 3 ms): a frame may
    // start up to 1 ms after its tick.
    const double allowed = std::ceil(period * 1000.0 - 1e-9) / 1000.0 + 0.001;
    for (const FloodSpec& f : floods) {
      const Timing t = loopTiming(rr, hz, f.bytes, f.keep_alive);
      const bool ok = t.frame_max_s <= allowed && t.service_max_s <= 0.003;
      loop_ok = loop_ok && ok;
      const double jitter = std::max(t.frame_max_s - period, period - t.frame_min_s);
      worst_jitter = std::max(worst_jitter, jitter);
      loop.addRow({f.name, fmt::format("{} Hz", hz), std::to_string(t.frames),
                   fmt::format("{:.2f}..{:.2f} ms", t.frame_min_s * 1000, t.frame_max_s * 1000),
                   fmt::format("{:.2f} ms", jitter * 1000), ms(t.service_max_s), ms(t.loop_max_s),
                   fmt::format("frames <= {:.1f} ms apart", allowed * 1000), verdict(ok)});
      s.json["loop"][fmt::format("{}_{}hz", f.key, hz)] = {
          {"input", f.name}, {"rate_hz", hz}, {"frames", t.frames},
          {"frame_interval_min_ms", t.frame_min_s * 1000}, {"frame_interval_max_ms", t.frame_max_s * 1000},
          {"frame_jitter_ms", jitter * 1000},
          {"service_max_gap_ms", t.service_max_s * 1000}, {"loop_max_gap_ms", t.loop_max_s * 1000},
          {"failsafe_tripped", t.failsafe}, {"met", ok}};
    }
  }
  loop.addNote("frames: the first of each frame's four A1 conversions; service() runs the frame, "
               "the battery filter, the failsafe and the lift-off timeout, from the main loop and "
               "from inside a reply that waits for room in the 128-byte transmit ring; a runOnce() "
               "gap is the longest single pass (one line, its whole reply)");
  loop.addNote("the flood without line ends trips the failsafe 500 ms after the last keep-alive, "
               "as it must; with bursts, keep-alives queue behind the burst's lines");
  loop.addNote("jitter: the largest difference between a frame interval and the nominal period "
               "(400 Hz: 0.5 ms of it is the 1 ms clock's 2/3 ms alternation)");
  s.targets.push_back({"6. frames under a flood (4 inputs, 50 and 400 Hz)",
                       fmt::format("jitter {:.2f} ms at most", worst_jitter * 1000),
                       "at most 1 ms after their 1 ms tick", loop_ok});
  return loop;
}

}  // namespace

Section safetySection(const AvrPaths& paths) {
  Section s;
  s.key = "safety";
  const std::string rr = paths.elf("read_run"), gs = paths.elf("gather_store");
  Table stop = hangTable(rr, gs, s);
  Table loop = floodTable(rr, s);
  s.json["available"] = true;
  s.tables.push_back(std::move(stop));
  s.tables.push_back(std::move(loop));
  return s;
}

// --- stack headroom (benchmark 3) ------------------------------------------------------------

void addStackHeadroom(const AvrPaths& paths, Table& t, nlohmann::json& j,
                      std::vector<TargetCheck>& targets) {
  const sim::StackHeadroom gs = sim::gatherStoreDeepestPaths(paths.elf("gather_store"));
  const sim::StackHeadroom rr = sim::readRunDeepestPaths(paths.elf("read_run"));
  for (const auto& [name, h] : {std::pair<const char*, const sim::StackHeadroom&>{"gather_store", gs},
                                std::pair<const char*, const sim::StackHeadroom&>{"read_run", rr}}) {
    const int free = h.untouched_bytes, size = std::max(h.stack_bytes, 0);
    const bool ok = free >= kStackTargetBytes;
    t.addRow({fmt::format("{} stack never used after its deepest paths (status)", name),
              free < 0 ? "no status" : std::to_string(free), std::to_string(size), ">= 512",
              verdict(ok)});
    j["stack"][name] = {{"never_used_bytes", free}, {"stack_bytes", size}, {"met", ok}};
    targets.push_back({fmt::format("3. {} stack never used (deepest paths)", name),
                       fmt::format("{} of {} bytes", free, size), ">= 512 bytes", ok});
  }
  t.addNote("stack: the boot code paints the SRAM above the static data; gather_store ran cal, "
            "sweep, store v2, show, store 1 and help under a flood, read_run a lift-off and help "
            "under a flood with all motors running (sim/stack_scenario.hpp, docs/safety.md)");
}

#endif

}  // namespace bench
