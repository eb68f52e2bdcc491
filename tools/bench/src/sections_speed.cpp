// Benchmark 8 (issue 25 item 5): how fast the simulated board runs, in simulated seconds per
// second, for the project's images and for a firmware shaped like a third-party flight
// controller: phase-correct PWM (Timer3 mode 10, clk/1, as MultiWii 2.4 on a Mega) on D2/D3,
// which are INT4/INT5, held low most of the time, ten more compare outputs and a busy main loop
// (tests/timers/firmware/timer_phase_correct.c), beside the same loop with its timers off.
// simavr 1.6 polled such pins every cycle (0.26x real time for MultiWii); the board's own
// external interrupts (sim/ext_int.hpp) do not. Two clocks: the wall (what a user waits; it
// depends on the machine's load) and the process's CPU time (what the simulator costs).
#include <ctime>
#include <filesystem>

#include <fmt/format.h>

#include "bench/sections.hpp"

#ifdef THRUSTCAL_BENCH_HAVE_SIM
#include "sim/airframe.hpp"
#include "sim/board.hpp"
#endif

namespace bench {

#ifndef THRUSTCAL_BENCH_HAVE_SIM

Section speedSection(const AvrPaths&) {
  return unavailableSection("speed", "8. Simulator speed",
                            "tools/sim (thrustcal_sim) is not part of this build: no simulated board");
}

#else

namespace {

constexpr double kPwmTargetFactor = 5.0;  // the issue: such a firmware at >= 5x real time
constexpr double kSimulatedS = 2.0;

#ifdef THRUSTCAL_BENCH_PWM_ELF
const char* const kPwmElf = THRUSTCAL_BENCH_PWM_ELF;
const char* const kLoopElf = THRUSTCAL_BENCH_LOOP_ELF;
#else
const char* const kPwmElf = "";
const char* const kLoopElf = "";
#endif

struct Speed {
  std::string image, what, error;
  double simulated_s = 0, wall_s = 0, cpu_s = 0;
  double wallFactor() const { return wall_s > 0 ? simulated_s / wall_s : 0; }
  double cpuFactor() const { return cpu_s > 0 ? simulated_s / cpu_s : 0; }
};

double cpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// Runs `board` for kSimulatedS: the board's own wall clock (inside run() only) and CPU time.
Speed measure(const std::string& image, const std::string& what, sim::Board& board) {
  Speed s;
  s.image = image;
  s.what = what;
  const double sim0 = board.simulatedSeconds(), wall0 = board.wallSeconds(), cpu0 = cpuSeconds();
  board.runFor(kSimulatedS);
  s.cpu_s = cpuSeconds() - cpu0;
  s.simulated_s = board.simulatedSeconds() - sim0;
  s.wall_s = board.wallSeconds() - wall0;
  return s;
}

Speed missing(const std::string& image, const std::string& why) {
  Speed s;
  s.image = image;
  s.error = why;
  return s;
}

Speed bareImage(const std::string& elf, const std::string& what) {
  if (elf.empty() || !std::filesystem::exists(elf))
    return missing(std::filesystem::path(elf).filename().string(), elf + " not built (avr-gcc missing?)");
  sim::Board board(elf);
  board.runFor(0.1);  // past the start-up
  return measure(shownPath(elf), what, board);
}

Speed flyOnGimbal(const AvrPaths& paths) {
  const std::string elf = paths.elf("fly");
  if (!std::filesystem::exists(elf)) return missing("fly", elf + " not found: build the AVR tree (--target fly)");
  sim::AirframeRig rig(elf, sim::AirframeOptions{});
  rig.run(0.5);  // boot, the IMU woken
  return measure(shownPath(elf), "fly disarmed on the gimbal: its 400 Hz loop reading the MPU-6050", rig.board());
}

}  // namespace

Section speedSection(const AvrPaths& paths) {
  Section s;
  s.key = "speed";
  const std::vector<Speed> rows = {
      bareImage(paths.elf("read_run"), "read_run at its prompt: 50 Hz ESC frames, asleep between 1 ms ticks"),
      flyOnGimbal(paths),
      bareImage(kLoopElf, "a busy main loop, timers off"),
      bareImage(kPwmElf, "the same loop beside phase-correct PWM on D2/D3 (INT4/INT5) and 10 more outputs"),
  };
  Table t("8. Simulator speed (simulated seconds per second)",
          {"image", "what it does", "simulated", "wall", "CPU", "speed (wall)", "speed (CPU)", "target", "met?"});
  s.json["runs"] = nlohmann::json::array();
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const Speed& r = rows[i];
    const bool pwm = i + 1 == rows.size();
    if (!r.error.empty()) {
      t.addRow({r.image, "not available: " + r.error, "", "", "", "", "", pwm ? ">= 5x (CPU)" : "-", pwm ? "NO" : "-"});
      s.json["runs"].push_back({{"image", r.image}, {"available", false}, {"reason", r.error}});
      continue;
    }
    const bool met = r.cpuFactor() >= kPwmTargetFactor;
    t.addRow({r.image, r.what, fmt::format("{:.1f} s", r.simulated_s), fmt::format("{:.2f} s", r.wall_s),
              fmt::format("{:.2f} s", r.cpu_s), sim::speedText(r.wallFactor()), sim::speedText(r.cpuFactor()),
              pwm ? ">= 5x (CPU)" : "-", pwm ? verdict(met) : "-"});
    s.json["runs"].push_back({{"image", r.image}, {"what", r.what}, {"simulated_s", r.simulated_s},
                              {"wall_s", r.wall_s}, {"cpu_s", r.cpu_s}, {"realtime_factor", r.wallFactor()},
                              {"cpu_realtime_factor", r.cpuFactor()}});
    if (pwm)
      s.targets.push_back(TargetCheck{"simulator speed with PWM on INT pins (a MultiWii-shaped image)",
                                      sim::speedText(r.cpuFactor()) + " (CPU)", ">= 5x real time", met});
  }
  const Speed& loop = rows[2];
  const Speed& pwm = rows[3];
  if (loop.error.empty() && pwm.error.empty() && pwm.cpu_s > 0) {
    s.json["pwm_cost_ratio"] = pwm.cpu_s / loop.cpu_s;
    t.addNote(fmt::format("the PWM on INT pins costs {:.0f} % more CPU than the loop alone (simavr 1.6 polled a "
                          "low INT pin every cycle: MultiWii 2.4 on D2/D3 ran at 0.26x real time)",
                          100.0 * (pwm.cpu_s / loop.cpu_s - 1.0)));
  }
  t.addNote("speed: simulated time / wall time inside Board::run, and / the process's CPU time over the same "
            "run (the wall figure depends on the machine's load), two significant digits; docs/sim.md, \"Timers, "
            "ports and external interrupts\"");
  s.tables.push_back(t);
  return s;
}

#endif

}  // namespace bench
