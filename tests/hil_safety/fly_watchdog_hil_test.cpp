// Issue 27 item 4: fly's watchdog in simavr, as read_run's and gather_store's (watchdog_hil_test):
// fly armed on the virtual airframe (the gimbal, pwm mode: no calibrated slot needed), its main
// loop hung by patching the entry of FlyApp::runOnce with "rjmp ." (interrupts on: the ESC
// frame's phase hook still starts IMU reads, the TWI, UART and tick interrupts run) or
// "cli; rjmp ." (interrupts off). fly kicks the watchdog only when a frame comes round the main
// loop, so either way the chip resets within ~64 ms, the pulse in progress ends there, and after
// the reset nothing spins until a new `arm`.
#include <gtest/gtest.h>

#include <memory>

#include "safety_support.hpp"
#include "sim/airframe.hpp"
#include "sim/stack_scenario.hpp"
#include "sim/watchdog_gaps.hpp"

namespace {

using safety::contains;
using safety::Hang;

constexpr double kFlyStopTargetS = 0.100;

// fly on the simulated gimbal (IMU seed 7), booted to its prompt: flown with an empty line every
// 0.1 s (its link failsafe wants one per 500 ms).
struct FlyOnGimbal {
  sim::AirframeRig rig;
  sim::Console con;
  static sim::AirframeOptions options() {
    sim::AirframeOptions o;
    o.imu_params.seed = 7;
    return o;
  }
  FlyOnGimbal() : rig(hil::imagePath("fly"), options()), con(rig.board(), "fly> ") {}
  void boot() {
    con.expectText("imu: gyro bias", 5.0);
    con.waitPrompt(1.0);
  }
  void fly(double s) {
    for (double done = 0; done < s - 1e-9; done += 0.1) {
      rig.board().sendText("\r");
      rig.run(std::min(0.1, s - done));
    }
  }
  void waitForTheEscsArming() {  // their 2 s at the stop pulse
    while (rig.truth().t_s < 2.1) fly(0.1);
  }
};

class FlyHang : public ::testing::TestWithParam<Hang> {};

TEST_P(FlyHang, StopsEveryPulseWithin100MsAndNothingSpinsAfterTheResetUntilArmedAgain) {
  HIL_REQUIRE_IMAGE("fly");
  // given: fly armed in pwm mode, spooled up on the gimbal
  FlyOnGimbal g;
  sim::AirframeRig& rig = g.rig;
  sim::Console& con = g.con;
  const auto fly = [&](double s) { g.fly(s); };
  safety::PulseLog log(rig.board());
  g.boot();
  g.waitForTheEscsArming();
  for (const char* line : {"mode pwm", "hover 1480 1440"}) con.command(line);
  ASSERT_EQ(con.command("arm").at(0).rfind("armed:", 0), 0u) << con.tail();
  fly(1.2);
  for (int ch = 0; ch < 4; ++ch) ASSERT_GT(rig.board().escPulseUs(ch), 1300.0) << ch;
  ASSERT_EQ(rig.board().resets(), 0);
  safety::HangPatch patch;
  rig.board().addResetListener([&](uint64_t) { safety::unpatch(rig.board(), patch); });

  // when: the main loop hangs
  patch = safety::hangFunction(rig.board(), hil::imagePath("fly"), "fly::FlyApp::runOnce()", GetParam());
  rig.run(0.3);
  const double t_hang = *patch.hung_at_s;  // when the loop ran into the patch
  ASSERT_GE(t_hang, 0.0);

  // then: reset by the watchdog, no pulse above the stop pulse ends later than 100 ms after
  ASSERT_EQ(rig.board().resets(), 1);
  const double t_reset = sim::cyclesToSeconds(rig.board().lastResetCycle());
  const double stop_s = log.lastWiderThan(1050.0) - t_hang;
  RecordProperty("time_to_stop_ms", fmt::format("{:.1f}", stop_s * 1000));
  std::printf("fly, %s: reset %.1f ms after the hang, last pulse > 1050 us ended %.1f ms after it\n",
              GetParam() == Hang::kInterruptsOn ? "interrupts on" : "interrupts off",
              (t_reset - t_hang) * 1000, stop_s * 1000);
  EXPECT_LE(stop_s, kFlyStopTargetS);
  EXPECT_LE(t_reset - t_hang, kFlyStopTargetS);
  // the image boots again, says why, and holds every ESC at the stop pulse
  con.expectText("imu: gyro bias", 6.0);
  fly(1.0);
  EXPECT_TRUE(contains(rig.board().output(), "reset: watchdog")) << con.tail();
  // (the pulse in progress at the reset ends at the reset itself, cut short: ~1 ms of a 1480 us
  // one, counted in stop_s above; every pulse that ends after it is the stop pulse)
  EXPECT_LE(log.widestBetween(t_reset + 1e-6, rig.board().timeS()), 1000.6);
  EXPECT_GT(log.countBetween(t_reset, rig.board().timeS()), 4 * 300) << "the ESCs get their stop pulse";
  EXPECT_EQ(rig.board().resets(), 1) << "no reset loop";
}

INSTANTIATE_TEST_SUITE_P(Table, FlyHang, ::testing::Values(Hang::kInterruptsOn, Hang::kInterruptsOff),
                         [](const ::testing::TestParamInfo<Hang>& info) {
                           return info.param == Hang::kInterruptsOn ? "InterruptsOn" : "InterruptsOff";
                         });

// fly's watchdog headroom (docs/safety.md, "Watchdog headroom"), as gather_store's and
// read_run's in watchdog_hil_test.cpp: its longest work between two kicks, disarmed (`param
// list`, `param save` with the chip's 3.4 ms per EEPROM byte, `help`) and armed (the frames
// with `stream on`, `status`, `help` under way), within half the 64 ms time-out.
TEST(FlyWatchdogHeadroom, TheLongestWorkBetweenTwoKicksIsAtMostHalfTheTimeOut) {
  HIL_REQUIRE_IMAGE("fly");
  FlyOnGimbal g;
  g.rig.board().setEepromWriteTime(3.4e-3);
  sim::KickGapMeter meter(g.rig.board(), hil::imagePath("fly"));
  g.boot();
  meter.restart();
  g.waitForTheEscsArming();
  sim::flyDisarmedPaths(g.con);  // param list, param save
  g.con.command("help", 5.0);
  for (const char* line : {"mode pwm", "hover 1480 1440"}) g.con.command(line);
  ASSERT_EQ(g.con.command("arm").at(0).rfind("armed:", 0), 0u) << g.con.tail();
  g.fly(1.2);
  for (const char* line : {"stream on", "status", "help"}) {  // each while the frames run
    g.con.send(line);
    g.fly(0.5);
  }
  safety::expectKickHeadroom(meter, "fly");
  EXPECT_EQ(g.rig.board().resets(), 0) << g.con.tail();
}

}  // namespace
