// `thrustcal bench fly` on the real fly image (THRUSTCAL_AVR_BUILD_DIR) in simavr: the section
// has every mode and every figure, each measured (non-zero, in a plausible range) and
// consistent with the others. Simulated cycles only: the run is the same on any host, so no
// bound here depends on the machine. Skipped when the AVR tree has not been built.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "bench/fly.hpp"
#include "bench/sections.hpp"

namespace {

bench::AvrPaths flyAvrPaths() {
  bench::AvrPaths p;
  p.avr_build = THRUSTCAL_AVR_BUILD_DIR;
  return p;
}

const char* const kFlyModes[] = {"force_v2", "force_v2_dyn", "force_thesis", "generic", "pwm", "ardupilot"};

void everyModeFliesTheWholeWindowWithEveryFigureMeasured(const nlohmann::json& j) {
  ASSERT_EQ(j["modes"].size(), 6u);
  for (const char* key : kFlyModes) {
    SCOPED_TRACE(key);
    const nlohmann::json& m = j["modes"][key];
    ASSERT_TRUE(m.is_object());
    EXPECT_TRUE(m["stayed_armed"].get<bool>());
    // the window: from `arm` (its reply), the 1.2 s spool-up, 1 s of hover and 1.5 s after the
    // step, one armed frame each 2.5 ms
    EXPECT_NEAR(m["window_s"].get<double>(), 3.7, 0.05);
    EXPECT_NEAR(m["frames"].get<double>(), 400 * m["window_s"].get<double>(), 3);
    // CPU: awake / all cycles; a stream of rows costs more
    const double cpu = m["cpu_load_pct"];
    EXPECT_GT(cpu, 10.0);
    EXPECT_LT(cpu, 100.0);
    EXPECT_GT(m["cpu_load_stream_pct"].get<double>(), cpu);
    // the loop runs every frame; nothing stalls it for a frame
    EXPECT_GT(m["loop_period_max_ms"].get<double>(), 0.5);
    EXPECT_LT(m["loop_period_max_ms"].get<double>(), 5.0);
    EXPECT_GE(m["frame_period_max_ms"].get<double>(), 2.49);
    EXPECT_LT(m["frame_period_max_ms"].get<double>(), 5.01);
    // read to edge: every read reached an edge, after its computation and before the next read
    const nlohmann::json& r = m["read_to_edge_us"];
    EXPECT_GE(r["frames"].get<double>(), 990);
    EXPECT_EQ(m["frames_without_pulses"].get<int>(), 0);
    EXPECT_GT(r["min"].get<double>(), m["compute_max_us"].get<double>() / 4);
    EXPECT_LE(r["min"].get<double>(), r["mean"].get<double>());
    EXPECT_LE(r["mean"].get<double>(), r["max"].get<double>());
    EXPECT_LT(r["mean"].get<double>(), 2500.0);
    EXPECT_GT(m["compute_max_us"].get<double>(), 100.0);
    EXPECT_GT(m["edge_margin_min_us"].get<double>(), 0.0);
    // the read's place in the frame, as status says it: read, budget and a 720 us read fill it
    const int phase = m["read_phase_us"], budget = m["budget_us"];
    EXPECT_GT(budget, 0);
    EXPECT_GE(phase, 100);
    EXPECT_TRUE(phase == 100 || phase + budget + 720 == 2500) << phase << " + " << budget;
    // the stack: painted at boot, the deepest paths leave more than the target untouched
    EXPECT_GT(m["stack_never_used_bytes"].get<int>(), 512);
    EXPECT_LT(m["stack_never_used_bytes"].get<int>(), m["stack_bytes"].get<int>());
    // the flight it measured: the 10 deg roll step was followed
    EXPECT_NEAR(m["roll_after_step_deg"].get<double>(), 10.0, 3.0);
  }
}

void whereTheCyclesGoAddsUpToTheCpuLoad(const nlohmann::json& j) {
  const double frame_cycles = 16e6 / j["frame_hz"].get<double>();
  for (const char* key : kFlyModes) {
    SCOPED_TRACE(key);
    const nlohmann::json& parts = j["breakdown"][key];
    double sum = 0;
    for (const auto& p : parts.items()) sum += p.value().get<double>();
    EXPECT_NEAR(sum / frame_cycles * 100.0, j["modes"][key]["cpu_load_pct"].get<double>(), 1.0);
    EXPECT_GT(parts.value("ISR: TWI", 0.0), 0.0) << "the IMU read is interrupt-driven";
  }
  // each mode's own output path is where it shows
  EXPECT_GT(j["breakdown"]["force_thesis"].value("tc::forceToPwmDg<...>", 0.0), 0.0);  // the 16-bit path
  EXPECT_GT(j["breakdown"]["force_v2"].value("tc::V2Frame::fly", 0.0), 0.0);
  EXPECT_GT(j["breakdown"]["force_v2_dyn"].value("tc::DynShaper::stepAll", 0.0), 0.0);  // dyn on shapes
  EXPECT_FALSE(j["breakdown"]["force_v2"].contains("tc::DynShaper::stepAll"));           // dyn off does not
  EXPECT_GT(j["breakdown"]["ardupilot"].value("fly::ArduPilotCurve::pulseUsDg", 0.0), 0.0);
  EXPECT_FALSE(j["breakdown"]["pwm"].contains("tc::V2Frame::fly"));
}

void modesRankAsTheirOutputPathsCostAndTheImageFits(const nlohmann::json& j) {
  const auto cpu = [&](const char* key) { return j["modes"][key]["cpu_load_pct"].get<double>(); };
  // pwm has no record; v2 one multiply-only frame; thesis records EEPROM steps and two curves
  EXPECT_LT(cpu("pwm"), cpu("force_v2"));
  EXPECT_LT(cpu("force_v2"), cpu("force_thesis"));
  EXPECT_NEAR(cpu("generic"), cpu("force_v2"), 1.0) << "generic flies the same v2 arithmetic";
  EXPECT_GT(cpu("force_v2_dyn"), cpu("force_v2")) << "dyn on adds four filters to the same frame";
  // flash and static SRAM of fly.elf, within the ATmega2560
  EXPECT_GT(j["flash_bytes"].get<int>(), 10000);
  EXPECT_LT(j["flash_bytes"].get<int>(), 256 * 1024);
  EXPECT_GT(j["sram_static_bytes"].get<int>(), 500);
  EXPECT_LT(j["sram_static_bytes"].get<int>(), 8 * 1024);
  // the verdicts are the figures against the targets
  for (const char* key : kFlyModes) {
    SCOPED_TRACE(key);
    EXPECT_EQ(j["met"][key]["cpu_load"].get<bool>(), cpu(key) <= bench::kFlyCpuTargetPct);
    EXPECT_EQ(j["met"][key]["read_to_edge"].get<bool>(),
              j["modes"][key]["read_to_edge_us"]["max"].get<double>() <= bench::kFlyReadToEdgeTargetUs);
  }
  EXPECT_EQ(j["worst"]["stack_never_used_bytes"].get<int>(), [&] {
    int least = 1 << 30;
    for (const char* key : kFlyModes) least = std::min(least, j["modes"][key]["stack_never_used_bytes"].get<int>());
    return least;
  }());
}

}  // namespace

// One simulated run (~3 s of CPU, more with the sanitizers) for all three checks.
TEST(BenchFlySection, EveryModeIsMeasuredAndTheFiguresAgree) {
  if (!std::filesystem::exists(flyAvrPaths().elf("fly"))) GTEST_SKIP() << "no fly image in " << THRUSTCAL_AVR_BUILD_DIR;
  // when: fly flies in each mode in simavr
  const bench::Section s = bench::flySection(flyAvrPaths());
  ASSERT_TRUE(s.json.value("available", false)) << s.json.dump();
  {
    SCOPED_TRACE("every mode flies the whole window with every figure measured");
    everyModeFliesTheWholeWindowWithEveryFigureMeasured(s.json);
  }
  {
    SCOPED_TRACE("where the cycles go adds up to the CPU load");
    whereTheCyclesGoAddsUpToTheCpuLoad(s.json);
  }
  {
    SCOPED_TRACE("the modes rank as their output paths cost, the image fits");
    modesRankAsTheirOutputPathsCostAndTheImageFits(s.json);
  }
}
