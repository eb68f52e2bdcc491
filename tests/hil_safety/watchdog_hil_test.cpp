// Issue 8, item 1 (docs/safety.md): the watchdog of both images in simavr 1.6 (its watchdog
// runs in simulated cycles: WDTO_60MS = 1,024,000 cycles = 64 ms).
//
// A hang is injected into the real image by patching its flash: the entry of the main loop's
// function becomes "rjmp ." (interrupts on: the timer, UART and ADC interrupts keep running)
// or "cli; rjmp ." (interrupts off). Time to stop = from the moment the program runs into the
// patch to the end of the last ESC pulse wider than 1050 us, on any channel. At a reset the chip releases every pin: the pulse
// in progress ends there (sim::Board models that; simavr does not raise the pin change).
// After the reset the patch is taken out again (a transient fault) and the image boots anew.
#include <gtest/gtest.h>

#include <filesystem>

#include "safety_support.hpp"
#include "hex/intel_hex.hpp"
#include "sim/rigs.hpp"
#include "sim/watchdog_gaps.hpp"

extern "C" {
#include <simavr/sim_avr.h>
}

namespace {

using safety::contains;
using safety::Hang;

constexpr double kStopTargetS = 0.100;  // issue 8: target 100 ms, required 150 ms

struct HangCase {
  const char* name;
  Hang how;
};

void PrintTo(const HangCase& c, std::ostream* os) { *os << c.name; }

class ReadRunHang : public ::testing::TestWithParam<HangCase> {};

TEST_P(ReadRunHang, StopsEveryMotorWithin100MsAndNothingSpinsAfterTheResetUntilCommanded) {
  HIL_REQUIRE_IMAGE("read_run");
  // given: all four motors running at 200 g
  safety::ReadRunBoard rr(safety::calibratedEeprom());
  rr.con.command("f 200");
  rr.keepAliveFor(1.0);
  for (int ch = 0; ch < 4; ++ch) ASSERT_GT(rr.board.escPulseUs(ch), 1100.0) << ch;
  ASSERT_EQ(rr.board.resets(), 0);
  const std::string elf = hil::imagePath("read_run");
  safety::HangPatch patch;
  rr.board.addResetListener([&](uint64_t) { safety::unpatch(rr.board, patch); });

  // when: the main loop hangs
  patch = safety::hangFunction(rr.board, elf, "rr::ReadRunApp::runOnce()", GetParam().how);
  rr.board.runFor(0.5);
  const double t_hang = *patch.hung_at_s;  // when the loop ran into the patch
  ASSERT_GE(t_hang, 0.0);

  // then: the watchdog reset the chip, and no pulse wider than 1050 us ended later than 100 ms
  // after the hang
  ASSERT_EQ(rr.board.resets(), 1);
  const double t_reset = sim::cyclesToSeconds(rr.board.lastResetCycle());
  const double t_stop = rr.log.lastWiderThan(1050.0);
  const double stop_s = t_stop - t_hang;
  RecordProperty("time_to_stop_ms", fmt::format("{:.1f}", stop_s * 1000));
  std::printf("%s: reset %.1f ms after the hang, last pulse > 1050 us ended %.1f ms after it\n",
              GetParam().name, (t_reset - t_hang) * 1000, stop_s * 1000);
  EXPECT_LE(stop_s, kStopTargetS);
  EXPECT_LE(t_reset - t_hang, kStopTargetS);
  // the image boots again, says why, and holds every ESC at 1000 us until a new command
  rr.con.waitPrompt(10.0);
  rr.board.runFor(2.0);  // nobody sends anything
  EXPECT_TRUE(contains(rr.board.output(), "reset: watchdog")) << rr.con.tail();
  EXPECT_LE(rr.log.widestBetween(t_reset, rr.board.timeS()), 1000.6);
  EXPECT_GT(rr.log.countBetween(t_reset, rr.board.timeS()), 4 * 50) << "the ESCs get 1000 us";
  EXPECT_EQ(rr.board.resets(), 1) << "the boot code switched the watchdog off: no reset loop";
  // a new command spins them again
  rr.con.command("f 200");
  rr.keepAliveFor(0.5);
  EXPECT_GT(rr.board.escPulseUs(0), 1100.0);
}

INSTANTIATE_TEST_SUITE_P(Table, ReadRunHang,
                         ::testing::Values(HangCase{"interrupts on", Hang::kInterruptsOn},
                                           HangCase{"interrupts off", Hang::kInterruptsOff}),
                         [](const ::testing::TestParamInfo<HangCase>& info) {
                           return info.param.how == Hang::kInterruptsOn ? "InterruptsOn"
                                                                        : "InterruptsOff";
                         });

class GatherStoreHang : public ::testing::TestWithParam<HangCase> {};

TEST_P(GatherStoreHang, StopsTheSweepingMotorWithin100Ms) {
  HIL_REQUIRE_IMAGE("gather_store");
  // given: a sweep on the plant bench, motor past 1200 us
  plant::BenchParams params = plant::BenchParams::thesis("kv1100_9x4.7");
  params.actuator = sim::motorForSeed("kv1100_9x4.7", 11, 0.03);
  sim::BenchRig rig(hil::imagePath("gather_store"), params, 0);
  sim::Console con(rig.board, "gs> ");
  safety::PulseLog log(rig.board);
  con.waitPrompt(10.0);
  con.command("tare", 5);
  con.command("settle 50");
  con.send("sweep");
  ASSERT_TRUE(rig.board.runUntil([&] { return rig.board.escPulseUs(0) > 1200.0; },
                                 sim::secondsToCycles(30)));
  safety::HangPatch patch;
  rig.board.addResetListener([&](uint64_t) { safety::unpatch(rig.board, patch); });

  // when: the ADC read the sweep waits in hangs
  patch = safety::hangFunction(rig.board, hil::imagePath("gather_store"),
                               "hal::Adc::readCounts(unsigned char)", GetParam().how);
  rig.board.runFor(0.5);
  const double t_hang = *patch.hung_at_s;  // the next ADC read (after the step's settling)
  ASSERT_GE(t_hang, 0.0);

  // then
  ASSERT_EQ(rig.board.resets(), 1);
  const double stop_s = log.lastWiderThan(1050.0) - t_hang;
  RecordProperty("time_to_stop_ms", fmt::format("{:.1f}", stop_s * 1000));
  EXPECT_LE(stop_s, kStopTargetS);
  con.waitPrompt(10.0);
  rig.board.runFor(1.0);
  EXPECT_TRUE(contains(rig.board.output(), "reset: watchdog")) << con.tail();
  EXPECT_LE(log.widestBetween(sim::cyclesToSeconds(rig.board.lastResetCycle()), rig.board.timeS()),
            1000.6);
  EXPECT_EQ(rig.board.resets(), 1);
}

INSTANTIATE_TEST_SUITE_P(Table, GatherStoreHang,
                         ::testing::Values(HangCase{"interrupts on", Hang::kInterruptsOn},
                                           HangCase{"interrupts off", Hang::kInterruptsOff}),
                         [](const ::testing::TestParamInfo<HangCase>& info) {
                           return info.param.how == Hang::kInterruptsOn ? "InterruptsOn"
                                                                        : "InterruptsOff";
                         });

// Behind the stock Mega2560 bootloader (stk500v2) a watchdog reset runs the bootloader first: it
// clears MCUSR, its shortcut back to the program misses (EIND = 1: the CPU runs through erased
// flash into the bootloader again), it waits its second for an upload, then starts the program.
// The motors stay stopped all along, and the boot line still tells a reset while running.
TEST(WatchdogThroughTheBootloader, KeepsTheMotorsStoppedAndSaysItResetWhileRunning) {
  HIL_REQUIRE_IMAGE("read_run");
  const std::string hex =
      "/usr/share/arduino/hardware/arduino/avr/bootloaders/stk500v2/stk500boot_v2_mega2560.hex";
  if (!std::filesystem::exists(hex)) GTEST_SKIP() << hex << " missing (apt-get install arduino-core-avr)";
  // given: read_run with the bootloader in the boot section, reset vector there (BOOTRST)
  safety::ReadRunBoard rr(safety::calibratedEeprom());
  const std::vector<uint8_t> flash = hex::readIntelHexFile(hex, 256 * 1024);
  const uint32_t boot = 0x3E000;
  rr.board.patchFlash(boot, std::vector<uint8_t>(flash.begin() + boot, flash.end()));
  rr.board.avr()->reset_pc = boot;
  rr.con.command("f 200");
  rr.keepAliveFor(0.3);
  ASSERT_GT(rr.board.escPulseUs(0), 1100.0);
  safety::HangPatch patch;
  rr.board.addResetListener([&](uint64_t) { safety::unpatch(rr.board, patch); });
  // when
  patch = safety::hangFunction(rr.board, hil::imagePath("read_run"), "rr::ReadRunApp::runOnce()",
                               Hang::kInterruptsOn);
  rr.board.runFor(0.2);
  ASSERT_EQ(rr.board.resets(), 1);
  const double t_reset = sim::cyclesToSeconds(rr.board.lastResetCycle());
  const auto boot_lines = rr.con.waitPrompt(10.0);
  // then
  const std::string all = ::testing::PrintToString(boot_lines);
  EXPECT_TRUE(contains(all, "reset: watchdog or external while running")) << rr.con.tail();
  EXPECT_LE(rr.log.widestBetween(t_reset, rr.board.timeS()), 1000.6);
  EXPECT_EQ(rr.board.resets(), 1) << "no reset loop";
}

// Every reset cause the boot line names, and after any of them nothing spins.
struct CauseCase {
  const char* name;
  sim::ResetKind kind;
  const char* line;
};

void PrintTo(const CauseCase& c, std::ostream* os) { *os << c.name; }

class ResetCause : public ::testing::TestWithParam<CauseCase> {};

TEST_P(ResetCause, BootSaysWhyAndHoldsTheMotorsAt1000Us) {
  HIL_REQUIRE_IMAGE("read_run");
  // given: motors running
  safety::ReadRunBoard rr(safety::calibratedEeprom());
  EXPECT_TRUE(contains(rr.board.output(), "reset: power-on")) << rr.con.tail();
  rr.con.command("f 250");
  rr.keepAliveFor(0.5);
  ASSERT_GT(rr.board.escPulseUs(1), 1100.0);
  // when
  rr.board.reset(GetParam().kind);
  const double t_reset = rr.board.timeS();
  const std::vector<std::string> boot = rr.con.waitPrompt(10.0);
  rr.board.runFor(1.0);
  // then
  EXPECT_TRUE(contains(::testing::PrintToString(boot), GetParam().line)) << rr.con.tail();
  EXPECT_LE(rr.log.widestBetween(t_reset, rr.board.timeS()), 1000.6);
  EXPECT_EQ(rr.board.resets(), 1);
}

INSTANTIATE_TEST_SUITE_P(
    Table, ResetCause,
    ::testing::Values(CauseCase{"BrownOut", sim::ResetKind::kBrownOut, "reset: brown-out"},
                      CauseCase{"External", sim::ResetKind::kExternal, "reset: external"},
                      CauseCase{"PowerOn", sim::ResetKind::kPowerOn, "reset: power-on"}),
    [](const ::testing::TestParamInfo<CauseCase>& info) { return info.param.name; });

// Long blocking work that must not trip the watchdog: read_run's arming (2 s), long replies in
// a burst (help is ~900 characters, 80 ms at 115200 baud), gather_store's sweep, the model v2
// store with the chip's EEPROM timing (3.4 ms per byte), show and help.
TEST(WatchdogQuiet, LongWorkInBothImagesNeverTripsIt) {
  HIL_REQUIRE_IMAGE("read_run");
  HIL_REQUIRE_IMAGE("gather_store");
  {
    safety::ReadRunBoard rr(safety::calibratedEeprom());
    rr.con.command("f 150");
    std::string burst;
    for (int i = 0; i < 10; ++i) burst += "help\rstatus\r";
    rr.board.sendText(burst);
    rr.keepAliveFor(3.0);
    EXPECT_EQ(rr.board.resets(), 0) << rr.con.tail();
    EXPECT_EQ(rr.board.output().find("reset: watchdog"), std::string::npos);
  }
  plant::BenchParams params = plant::BenchParams::thesis("kv1100_9x4.7");
  params.actuator = sim::motorForSeed("kv1100_9x4.7", 12, 0.03);
  sim::BenchRig rig(hil::imagePath("gather_store"), params, 0);
  rig.board.setEepromWriteTime(3.4e-3);
  sim::Console con(rig.board, "gs> ");
  con.waitPrompt(10.0);
  con.command(fmt::format("cal {}", static_cast<int>(std::lround(params.actuator.mountWeight_g()))), 10);
  con.command("range 1040 1800");
  con.command("settle 100");
  con.command("sweep", 120);
  const double t0 = rig.board.timeS();
  const auto stored = con.command("store v2", 20);
  const double store_s = rig.board.timeS() - t0;
  con.command("show", 10);
  con.command("store 1", 20);
  con.command("erase", 20);
  con.command("help", 10);
  EXPECT_EQ(rig.board.resets(), 0) << con.tail();
  EXPECT_TRUE(contains(::testing::PrintToString(stored), "stored model v2")) << con.tail();
  EXPECT_GT(store_s, 0.3) << "the store ran with the chip's EEPROM timing";
  std::printf("store v2 with 3.4 ms per EEPROM byte: %.2f s, no watchdog reset\n", store_s);
}

// The watchdog's headroom (docs/safety.md, "Watchdog headroom"): no reset is not enough, the
// longest work between two kicks must leave room for a chip whose watchdog oscillator runs fast
// or whose code a later change makes slower. gather_store's longest work: the largest sweep
// (161 steps), its end (the curve and sag table built, the summary printed), storing it, `show`
// and `help`; read_run's: a burst of `help` and `status` while four motors fly. Each within half
// the 64 ms time-out.
TEST(WatchdogHeadroom, TheLongestWorkBetweenTwoKicksIsAtMostHalfTheTimeOut) {
  HIL_REQUIRE_IMAGE("read_run");
  HIL_REQUIRE_IMAGE("gather_store");
  {
    safety::ReadRunBoard rr(safety::calibratedEeprom());
    sim::KickGapMeter meter(rr.board, hil::imagePath("read_run"));
    meter.restart();
    rr.con.command("f 150");
    std::string burst;
    for (int i = 0; i < 5; ++i) burst += "help\rstatus\r";
    rr.board.sendText(burst);
    rr.keepAliveFor(1.5);
    safety::expectKickHeadroom(meter, "read_run");
    EXPECT_EQ(rr.board.resets(), 0);
  }
  plant::BenchParams params = plant::BenchParams::thesis("kv1100_9x4.7");
  params.actuator = sim::motorForSeed("kv1100_9x4.7", 13, 0.03);
  sim::BenchRig rig(hil::imagePath("gather_store"), params, 0);
  rig.board.setEepromWriteTime(3.4e-3);
  sim::KickGapMeter meter(rig.board, hil::imagePath("gather_store"));
  sim::Console con(rig.board, "gs> ");
  con.waitPrompt(10.0);
  meter.restart();
  con.command(fmt::format("cal {}", static_cast<int>(std::lround(params.actuator.mountWeight_g()))), 10);
  con.command("range 1000 1800");
  con.command("step 5");
  con.command("settle 50");
  const auto swept = con.command("sweep", 120);
  EXPECT_TRUE(contains(::testing::PrintToString(swept), "161 steps")) << con.tail();
  con.command("store 1", 20);
  con.command("show", 10);
  con.command("help", 10);
  safety::expectKickHeadroom(meter, "gather_store");
  EXPECT_EQ(rig.board.resets(), 0) << con.tail();
}

}  // namespace
