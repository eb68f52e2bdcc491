// `thrustcal bench fly` (issue 19 item 4) without the simulator: the read-to-edge matching on
// hand-made event lists, and the section built from given figures (its JSON keys, targets and
// verdicts). The flights themselves run in `thrustcal bench fly`, not here.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "bench/fly.hpp"

namespace {

constexpr double kCyclesPerUs = 16.0;

struct MatchCase {
  const char* what;
  std::vector<uint64_t> reads, writes, rises;
  uint64_t frames, without_pulses;
  double min_us, max_us, compute_max_us, margin_min_us;
};

TEST(FlyBenchReadToEdge, MatchesEachReadToTheEdgeAfterItsFirstWrite) {
  const MatchCase cases[] = {
      {"two frames: read, write, edge",
       {1600, 41600},
       {9600, 49600},
       {16000, 56000},
       2,
       0,
       900,
       900,
       500,
       400},
      {"a late write waits for the next edge", {1600}, {20000}, {16000, 56000}, 1, 0, 3400, 3400, 1150, 2250},
      {"a second write from the same read is not a frame",
       {1600},
       {9600, 12000},
       {16000},
       1,
       0,
       900,
       900,
       500,
       400},
      {"a read with no write before the next read",
       {1600, 41600, 81600},
       {9600, 89600},
       {16000, 96000},
       2,
       1,
       900,
       900,
       500,
       400},
      {"reads before the first write (disarmed) are no frames without pulses",
       {1600, 41600},
       {49600},
       {56000},
       1,
       0,
       900,
       900,
       500,
       400},
      {"a write before any read, an edge after the window", {1600}, {800, 9600}, {}, 0, 0, 0, 0, 0, 0},
  };
  for (const MatchCase& c : cases) {
    SCOPED_TRACE(c.what);
    // when
    const bench::ReadToEdge r = bench::matchReadsToEdges(c.reads, c.writes, c.rises, kCyclesPerUs);
    // then
    EXPECT_EQ(r.frames, c.frames);
    EXPECT_EQ(r.without_pulses, c.without_pulses);
    EXPECT_DOUBLE_EQ(r.min_us, c.min_us);
    EXPECT_DOUBLE_EQ(r.max_us, c.max_us);
    EXPECT_DOUBLE_EQ(r.compute_max_us, c.compute_max_us);
    EXPECT_DOUBLE_EQ(r.margin_min_us, c.margin_min_us);
  }
}

bench::FlyModeFigures figures(const std::string& key, double cpu_pct, double edge_max_us) {
  bench::FlyModeFigures f;
  f.key = key;
  f.name = key + " mode";
  f.stayed_armed = true;
  f.window_s = 2.5;
  f.frames = 1000;
  f.cpu_load_pct = cpu_pct;
  f.read_to_edge.frames = 999;
  f.read_to_edge.max_us = edge_max_us;
  f.read_to_edge.mean_us = edge_max_us - 5;
  f.read_to_edge.compute_max_us = 600;
  f.status_compute_max_us = 596;  // status's own clock, a few us short of the bench's
  f.stack_never_used_bytes = 4000;
  f.stack_bytes = 5800;
  f.awake_cycles_by_part = {{"fly::Mixer::mix", 800000}, {"ISR: TWI", 1700000}};
  return f;
}

TEST(FlyBenchSection, HasEveryModeItsTargetsAndTheirVerdicts) {
  // given: three modes, one over the CPU target, one late, and one cut by a failsafe
  bench::FlyImage image;
  image.elf = "build/avr/firmware/fly/fly.elf";
  image.size = {57000, 2300};
  std::vector<bench::FlyModeFigures> modes = {figures("force_v2", 45.0, 950), figures("ardupilot", 55.0, 990),
                                              figures("pwm", 40.0, 1200)};
  modes.push_back(figures("generic", 40.0, 900));
  modes.back().stayed_armed = false;
  // when
  const bench::Section s = bench::flyReport(image, modes);
  // then: the JSON scripts read
  EXPECT_EQ(s.key, "fly");
  EXPECT_TRUE(s.json["available"].get<bool>());
  EXPECT_EQ(s.json["sram_static_bytes"].get<int>(), 2300);
  for (const char* key : {"force_v2", "ardupilot", "pwm", "generic"}) {
    SCOPED_TRACE(key);
    const auto& m = s.json["modes"][key];
    for (const char* field :
         {"cpu_load_pct", "cpu_load_stream_pct", "loop_period_max_ms", "frame_period_max_ms",
          "frames_without_pulses", "compute_max_us", "status_compute_max_us", "stack_never_used_bytes",
          "budget_us"})
      EXPECT_TRUE(m.contains(field)) << field;
    EXPECT_TRUE(m["read_to_edge_us"].contains("max"));
  }
  EXPECT_TRUE(s.json["met"]["force_v2"]["cpu_load"].get<bool>());
  EXPECT_TRUE(s.json["met"]["force_v2"]["read_to_edge"].get<bool>());
  EXPECT_FALSE(s.json["met"]["ardupilot"]["cpu_load"].get<bool>());
  EXPECT_FALSE(s.json["met"]["pwm"]["read_to_edge"].get<bool>());
  EXPECT_FALSE(s.json["met"]["generic"]["cpu_load"].get<bool>()) << "a disarmed flight meets nothing";
  EXPECT_EQ(s.json["breakdown"]["pwm"]["ISR: TWI"].get<double>(), 1700.0);
  EXPECT_TRUE(s.json["met"]["force_v2"]["status_agrees"].get<bool>());
  // and: per mode a CPU, an edge and a status-agrees target, then the loop period, the stack and
  // the SRAM
  ASSERT_EQ(s.targets.size(), 3 * modes.size() + 3);
  EXPECT_EQ(s.targets[0].what, "7. fly CPU load at 400 Hz, force_v2 mode");
  EXPECT_TRUE(s.targets.back().met);
  EXPECT_TRUE(s.targets[s.targets.size() - 2].met) << "4000 B of stack never used";
  ASSERT_EQ(s.tables.size(), 2u);
  EXPECT_NE(s.tables[0].str().find("NO (disarmed)"), std::string::npos);
}

TEST(FlyBenchSection, StatusDisagreeingWithTheBenchsComputationIsNotMet) {
  std::vector<bench::FlyModeFigures> modes = {figures("force_v2", 45.0, 950)};
  modes[0].status_compute_max_us = 560;  // status measured less than the bench (another span)
  const bench::Section s = bench::flyReport(bench::FlyImage{}, modes);
  EXPECT_FALSE(s.json["met"]["force_v2"]["status_agrees"].get<bool>());
  EXPECT_FALSE(s.targets[2].met) << s.targets[2].what;
}

}  // namespace
