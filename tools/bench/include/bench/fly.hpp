// `thrustcal bench fly` (issue 19 item 4): fly, the 400 Hz attitude loop, measured in simulated
// cycles on the virtual airframe in each of its modes. The measuring is in sections_fly.cpp;
// what is here turns events and figures into the section (pure, tested in tests/bench):
//   read to edge  from the end of an IMU read (the TWI's status 0x58: the last byte is in) to
//                 the rising edge of the ESC pulses that carry the result computed from it: the
//                 first write of the compare registers after the read (hal::Esc::writeAll), then
//                 the first rising edge after that write (the registers are double-buffered: a
//                 write takes effect at the next edge);
//   CPU load      awake cycles / all cycles (the image sleeps between its loop passes);
//   loop period   between entries of FlyApp::runOnce (one pass of the main loop), and between
//                 entries of FlyApp::flyFrame (the armed computation, once per frame).
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "bench/sections.hpp"

namespace bench {

constexpr double kFlyCpuTargetPct = 50.0;
constexpr double kFlyReadToEdgeTargetUs = 1000.0;

struct ReadToEdge {
  uint64_t frames = 0;          // reads whose result reached an edge in the window
  uint64_t without_pulses = 0;  // reads followed by another read with no write in between
  double min_us = 0, mean_us = 0, max_us = 0;
  double compute_max_us = 0;  // read end -> compare registers written
  double margin_min_us = 0;   // compare registers written -> the edge
};

// Each list in cycles, ascending: read ends, compare writes (entries of writeAll), rising edges.
// Reads before the first write (disarmed) count for nothing.
ReadToEdge matchReadsToEdges(const std::vector<uint64_t>& read_ends, const std::vector<uint64_t>& writes,
                             const std::vector<uint64_t>& rises, double cycles_per_us);

// What one mode's flight gave.
struct FlyModeFigures {
  std::string key;            // "force_v2", "force_thesis", "generic", "pwm", "ardupilot"
  std::string name;           // as the table shows it
  bool stayed_armed = false;  // the flight was not cut by a failsafe (else no figure counts)
  double window_s = 0;
  double cpu_load_pct = 0;
  double cpu_load_stream_pct = 0;  // with `stream on` (50 rows a second)
  double loop_period_max_ms = 0, frame_period_max_ms = 0;
  uint64_t frames = 0;  // flyFrame calls in the window
  ReadToEdge read_to_edge;
  int read_phase_us = 0, budget_us = 0;  // as status shows them
  int status_compute_max_us = -1;        // status's own worst computation over the same flight
  int stack_never_used_bytes = -1, stack_bytes = -1;
  double roll_before_step_deg = 0, roll_after_step_deg = 0;  // the airframe's truth
  std::map<std::string, uint64_t> awake_cycles_by_part;      // the window, by function
};

struct FlyImage {
  std::string elf;  // as shown
  ImageSize size;
  std::string rig;  // the airframe, described
};

// The section: its tables (per mode, and where the cycles go), JSON (fly.modes.<key>...) and
// targets (CPU <= 50 % and read to edge <= 1 ms per mode, stack >= 512 B and static SRAM).
Section flyReport(const FlyImage& image, const std::vector<FlyModeFigures>& modes);

}  // namespace bench
