// Benchmark 7 (issue 19 item 4): the real fly image on the virtual airframe (tools/sim's
// AirframeRig: the quad on its 3-DOF gimbal in the thesis's plus layout, the four motors of
// bench/records.hpp, an MPU-6050 on the chip-true TWI), armed in each mode: force with v2
// records, force with thesis records, generic (slot 0's v2 record for all four), pwm (the
// thesis's pulses around hover) and ardupilot (one fitted curve). Per mode one boot: the
// settings, then the measured window from `arm`: the spool-up, 1 s of hover, `sp 10 0`, 1.5 s,
// and status's own figures over it; then 0.5 s with `stream on`; then the deepest console paths
// and status's stack figure
// (sim/stack_scenario.hpp). In the windows (bench/fly.hpp says what each figure is):
//   Board::sleptCycles         the CPU load;
//   Board::setProfiling        each instruction's awake cycles at its address, summed per
//                              function (sim::flashSymbols): where a frame's cycles go;
//   Board::watchPc             entries of FlyApp::runOnce, FlyApp::flyFrame, hal::Esc::writeAll;
//   Twi tracing                the statuses the TWI set (0x58: a read's last byte is in);
//   a pulse listener           each pulse's rising edge on ESC 0 (all four rise together).
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <regex>

#include "bench/fly.hpp"
#include "bench/sections.hpp"

#ifdef THRUSTCAL_BENCH_HAVE_SIM
#include "bench/records.hpp"
#include "sim/airframe.hpp"
#include "sim/console.hpp"
#include "sim/elf_symbols.hpp"
#include "sim/stack_scenario.hpp"
#include "sim/twi.hpp"
#endif

namespace bench {

#ifndef THRUSTCAL_BENCH_HAVE_SIM

Section flySection(const AvrPaths&) {
  return unavailableSection("fly", "7. fly",
                            "tools/sim (thrustcal_sim) is not part of this build: no virtual airframe");
}

#else

namespace {

constexpr double kCyclesPerUs = sim::kCpuHz / 1e6;
constexpr uint8_t kStatusLastByteIn = 0x58;  // TWSR: data received, NACK returned (a read's end)

struct FlyMode {
  const char* key;
  const char* name;
  const std::vector<uint8_t> BenchRecords::*records;  // the EEPROM image it flies
  std::vector<std::string> setup;  // after `layout plus` and `thrust 1200`
};

std::vector<FlyMode> flyModes(const BenchRecords& r) {
  const lab::autopilot::ArduPilotParams& ap = r.ardupilot.params;
  const auto e4 = [](double v) { return static_cast<int>(std::lround(v * 10000.0)); };
  const std::string ap_line = fmt::format("ap {} {} {} {}", e4(ap.thst_expo), e4(ap.spin_min),
                                          e4(ap.spin_max), std::lround(r.ardupilot.full_g));
  const std::string volts = fmt::format("apvolt {} {}", std::lround(ap.bat_volt_max_v * 1000.0),
                                        std::lround(ap.bat_volt_min_v * 1000.0));
  return {
      {"force_v2", "force, model v2 records", &BenchRecords::v2, {"mode force"}},
      {"force_v2_dyn", "force, v2 records, dyn on", &BenchRecords::v2_dyn, {"mode force", "dyn on"}},
      {"force_thesis", "force, thesis records", &BenchRecords::v1, {"mode force"}},
      {"generic", "generic (slot 0's v2 record)", &BenchRecords::v2, {"mode generic 0"}},
      {"pwm", "pwm (hover 1480 us, 1.44 g/us)", &BenchRecords::v2, {"mode pwm", "hover 1480 1440"}},
      {"ardupilot", "ardupilot (one fitted curve)", &BenchRecords::v2, {ap_line, volts, "mode ardupilot"}},
  };
}

// "unsigned int tc::X::f<hal::Eeprom>(unsigned int) const" -> "tc::X::f<...>".
std::string functionName(const std::string& demangled) {
  static const std::string kAnonymous = "(anonymous namespace)";
  std::string s = demangled;
  for (std::size_t at; (at = s.find(kAnonymous)) != std::string::npos;)
    s.replace(at, kAnonymous.size(), "{anon}");
  std::string name;
  int depth = 0;
  for (const char c : s) {
    if (depth == 0 && c == '(') break;
    if (depth == 0 && c == ' ') {  // what came before was a return type
      name.clear();
      continue;
    }
    if (c == '>') --depth;
    if (depth == 0) name += c;
    if (c == '<' && depth++ == 0) name += "...";
  }
  return name;
}

// A part of the image as the breakdown names it: the function, avr-libc's float routines as one,
// the interrupt vectors by what they serve.
std::string partOf(const std::string& symbol) {
  static const std::map<std::string, std::string> kVectors = {
      {"__vector_18", "ISR: the frame's phase (Timer1 COMPB)"},
      {"__vector_21", "ISR: the 1 ms tick"},
      {"__vector_25", "ISR: UART receive"},
      {"__vector_26", "ISR: UART transmit"},
      {"__vector_29", "ISR: ADC"},
      {"__vector_39", "ISR: TWI"}};
  if (const auto it = kVectors.find(symbol); it != kVectors.end()) return it->second;
  static const std::regex kFloat(
      R"(^__(fp_\w+|(add|sub|mul|div)sf3\w*|fix\w*sf\w*|float\w*sf|(cmp|eq|ne|lt|le|gt|ge|unord)sf2)$)");
  static const std::regex kDivide(R"(^__u?divmod[sh]i4\w*$)");
  static const std::regex kMultiply(R"(^__(u|us|mu|mul)?\w*mul\w*[sh]i3\w*$)");
  if (std::regex_match(symbol, kFloat)) return "float arithmetic (avr-libc)";
  if (std::regex_match(symbol, kDivide)) return "integer division (libgcc)";
  if (std::regex_match(symbol, kMultiply)) return "integer multiplication (libgcc)";
  return functionName(symbol);
}

// The part an instruction belongs to; a jump in the vector table counts to its interrupt.
std::string partAt(const std::vector<sim::FlashSymbol>& symbols, uint32_t byte_address) {
  constexpr uint32_t kVectorBytes = 4, kVectors = 57;  // the ATmega2560's table: one jmp each
  if (byte_address < kVectors * kVectorBytes)
    return byte_address < kVectorBytes ? "reset"
                                       : partOf(fmt::format("__vector_{}", byte_address / kVectorBytes));
  return partOf(sim::symbolAt(symbols, byte_address));
}

// Everything watched while fly flies; start() and stop() bracket a window.
class FlyMeter {
 public:
  FlyMeter(sim::AirframeRig& rig, const std::string& elf, const std::vector<sim::FlashSymbol>& symbols)
      : board_(rig.board()), symbols_(symbols) {
    board_.watchPc(sim::elfSymbol(elf, "fly::FlyApp::runOnce()").address,
                   [this](uint64_t c) { on(loop_, c); });
    board_.watchPc(sim::elfSymbol(elf, "fly::FlyApp::flyFrame(unsigned char, unsigned int)").address,
                   [this](uint64_t c) { on(frame_, c); });
    board_.watchPc(sim::elfSymbol(elf, "hal::Esc::writeAll(unsigned int const (&) [4])").address,
                   [this](uint64_t c) {
                     if (measuring_) writes_.push_back(c);
                   });
    board_.addPulseListener([this](int ch, double, double) {
      if (measuring_ && ch == 0) rises_.push_back(board_.escPin(0).last_rise_cycle);
    });
  }
  void start(bool profile);
  void stop(FlyModeFigures& f, bool stream_window);

 private:
  struct Periods {
    uint64_t last = 0, max = 0, count = 0;
  };
  void on(Periods& p, uint64_t cycle) {
    if (!measuring_) return;
    if (p.last) p.max = std::max(p.max, cycle - p.last);
    p.last = cycle;
    ++p.count;
  }
  std::vector<uint64_t> readEnds() const;
  std::map<std::string, uint64_t> cyclesByPart() const;

  sim::Board& board_;
  const std::vector<sim::FlashSymbol>& symbols_;
  bool measuring_ = false, profiling_ = false;
  uint64_t from_cycle_ = 0, from_slept_ = 0;
  Periods loop_, frame_;
  std::vector<uint64_t> writes_, rises_;
  std::vector<uint64_t> profile_from_;
};

void FlyMeter::start(bool profile) {
  measuring_ = true;
  profiling_ = profile;
  loop_ = Periods();
  frame_ = Periods();
  writes_.clear();
  rises_.clear();
  board_.twi().clearTrace();
  board_.twi().setTracing(true);
  if (profile) {
    board_.setProfiling(true);
    profile_from_ = board_.awakeCyclesByWord();
  }
  from_cycle_ = board_.cycle();
  from_slept_ = board_.sleptCycles();
}

std::vector<uint64_t> FlyMeter::readEnds() const {
  std::vector<uint64_t> ends;
  for (const sim::TwiEvent& e : board_.twi().trace())
    if (e.what == sim::TwiEvent::What::kStatus && e.value == kStatusLastByteIn) ends.push_back(e.cycle);
  return ends;
}

std::map<std::string, uint64_t> FlyMeter::cyclesByPart() const {
  std::map<std::string, uint64_t> parts;
  const std::vector<uint64_t>& now = board_.awakeCyclesByWord();
  for (std::size_t word = 0; word < now.size(); ++word) {
    const uint64_t cycles = now[word] - profile_from_[word];
    if (cycles != 0) parts[partAt(symbols_, static_cast<uint32_t>(2 * word))] += cycles;
  }
  return parts;
}

void FlyMeter::stop(FlyModeFigures& f, bool stream_window) {
  measuring_ = false;
  board_.twi().setTracing(false);
  const uint64_t cycles = board_.cycle() - from_cycle_;
  const double awake_pct = 100.0 * static_cast<double>(cycles - (board_.sleptCycles() - from_slept_)) /
                           static_cast<double>(cycles);
  if (stream_window) {
    f.cpu_load_stream_pct = awake_pct;
    return;
  }
  f.window_s = sim::cyclesToSeconds(cycles);
  f.cpu_load_pct = awake_pct;
  f.frames = frame_.count;
  f.loop_period_max_ms = 1000.0 * sim::cyclesToSeconds(loop_.max);
  f.frame_period_max_ms = 1000.0 * sim::cyclesToSeconds(frame_.max);
  f.read_to_edge = matchReadsToEdges(readEnds(), writes_, rises_, kCyclesPerUs);
  if (profiling_) {
    f.awake_cycles_by_part = cyclesByPart();
    board_.setProfiling(false);
  }
}

// `seconds` of flight with an empty line every 0.1 s (fly's link failsafe wants one per 500 ms).
void flyFor(sim::AirframeRig& rig, double seconds) {
  for (double done = 0; done < seconds - 1e-9; done += 0.1) {
    rig.board().sendText("\r");
    rig.run(std::min(0.1, seconds - done));
  }
}

void command(sim::Console& con, const std::string& line) {
  for (const std::string& reply : con.command(line))
    if (reply.rfind("error:", 0) == 0)
      throw std::runtime_error(fmt::format("fly bench: fly refused `{}`: {}\n{}", line, reply, con.tail()));
}

// Boot and the mode's settings.
void setUpMode(sim::AirframeRig& rig, sim::Console& con, const FlyMode& mode) {
  con.expectText("imu: gyro bias", 6.0);
  con.waitPrompt(1.0);
  while (rig.truth().t_s < 2.1) flyFor(rig, 0.1);  // the ESCs' 2 s at the stop pulse
  command(con, "layout plus");
  command(con, "thrust 1200");
  for (const std::string& line : mode.setup) command(con, line);
  sim::flyDisarmedPaths(con);  // `param save`'s stack counts in the figure flyDeepestPaths reads
}

void arm(sim::Console& con, const FlyMode& mode) {
  const std::vector<std::string> armed = con.command("arm");
  if (armed.empty() || armed[0].rfind("armed:", 0) != 0)
    throw std::runtime_error(fmt::format("fly bench: `arm` refused in mode {}:\n{}", mode.key, con.tail()));
}

// "loop: IMU read at P us of each 2500 us frame, computation budget B us; armed: computation at
// most C us, ..." from status (its figures count from the arm), waited for as a line of its own:
// stream rows before it would leave no prompt to go by.
void readLoopLine(sim::Console& con, FlyModeFigures& f) {
  con.send("status");
  const std::vector<std::string> m = con.expect(
      R"(loop: IMU read at (\d+) us of each \d+ us frame, computation budget (\d+) us; armed: computation at most (\d+) us)",
      2.0);
  f.read_phase_us = std::stoi(m[1]);
  f.budget_us = std::stoi(m[2]);
  f.status_compute_max_us = std::stoi(m[3]);
  con.waitPrompt(2.0);
}

FlyModeFigures flyMode(const std::string& elf, const FlyMode& mode, const BenchRecords& records,
                       const sim::AirframeOptions& options, const std::vector<sim::FlashSymbol>& symbols) {
  FlyModeFigures f;
  f.key = mode.key;
  f.name = mode.name;
  sim::AirframeRig rig(elf, options);
  rig.board().setEeprom(records.*mode.records);
  sim::Console con(rig.board(), "fly> ");
  FlyMeter meter(rig, elf, symbols);
  setUpMode(rig, con, mode);
  const std::size_t flight_from = rig.board().output().size();
  meter.start(true);  // from the arm: the spool-up is part of the flight
  arm(con, mode);
  flyFor(rig, 1.2);  // the spool-up (1 s)
  flyFor(rig, 1.0);
  f.roll_before_step_deg = rig.truth().roll_deg;
  con.send("sp 10 0");
  flyFor(rig, 1.5);
  meter.stop(f, false);
  f.roll_after_step_deg = rig.truth().roll_deg;
  readLoopLine(con, f);  // status over the same flight
  con.send("stream on");
  meter.start(false);
  flyFor(rig, 0.5);
  meter.stop(f, true);
  command(con, "stream off");
  f.stayed_armed = rig.board().output().find("disarmed", flight_from) == std::string::npos;
  const sim::StackHeadroom stack = sim::flyDeepestPaths(elf, con);
  f.stack_never_used_bytes = stack.untouched_bytes;
  f.stack_bytes = stack.stack_bytes;
  f.stayed_armed = f.stayed_armed && rig.board().output().find("disarmed", flight_from) == std::string::npos;
  return f;
}

sim::AirframeOptions airframe(const BenchRecords& records) {
  sim::AirframeOptions o;
  o.rig = sim::AirRig::kGimbal;
  o.gimbal.layout = plant::Layout::kPlus;
  o.motors = records.motors;
  o.imu_params.seed = 7;
  return o;
}

}  // namespace

Section flySection(const AvrPaths& paths) {
  const std::string elf = paths.elf("fly");
  if (!std::filesystem::exists(elf))
    return unavailableSection("fly", "7. fly",
                              elf + " not found: build the AVR tree (--target fly) or pass --avr-build DIR");
  const BenchRecords& records = benchRecords();
  const sim::AirframeOptions options = airframe(records);
  const std::vector<sim::FlashSymbol> symbols = sim::flashSymbols(elf);
  std::vector<FlyModeFigures> modes;
  for (const FlyMode& mode : flyModes(records)) {
    std::cerr << fmt::format("bench: fly on the virtual airframe in simavr, mode {}\n", mode.key);
    modes.push_back(flyMode(elf, mode, records, options, symbols));
  }
  FlyImage image;
  image.elf = shownPath(elf);
  image.size = imageSize(elf);
  {
    sim::AirframeRig rig(elf, options);
    image.rig = rig.describe();
  }
  return flyReport(image, modes);
}

#endif

}  // namespace bench
