// fly against the fake HAL: every disarm cause (a crash, the IMU failing, a stuck bus, link loss,
// disarm) stops every ESC pulse within 100 ms of simulated time; the watchdog's kicks; status and
// the stream. The same fixture as test_fly_app.cpp (fly_fixture.hpp).
#include <gtest/gtest.h>

#include <cstdio>
#include <sstream>

#include "fly_fixture.hpp"

namespace {

using namespace fly_test;

// ---------------------------------------------------------------------------------------------
// Disarming: each cause stops every ESC pulse within 100 ms

TEST_F(Fly, ACrashDisarmsWithinAFewFramesOfTheAttitudeLimit) {
  storeFourV2Motors();
  bootReady();
  command("crash 30");
  armAndSpool(1200);
  ASSERT_FALSE(allStopped());
  // when: the vehicle rolls over at 500 deg/s
  imu_.rate_dps[0] = 500;
  runUntil([&] { return imu_.roll_deg > 30; }, 200);
  const uint32_t crossed_ms = fake::nowMs();
  const uint32_t took_ms = runUntil([&] { return allStopped(); }, 200);
  // then
  EXPECT_LE(took_ms, 100u);
  EXPECT_LE(took_ms, 10u) << "a few frames";
  EXPECT_FALSE(app_->armed());
  EXPECT_EQ(app_->flight().last_cause, fly::DisarmCause::kCrash);
  EXPECT_TRUE(contains(fake::output(), "disarmed: crash (attitude 3")) << fake::output();
  EXPECT_GE(fake::nowMs(), crossed_ms);
}

struct ImuFailure {
  const char* name;
  void (*inject)(FakeImu& imu);
  fly::ImuFault fault;
  const char* says;
};

void PrintTo(const ImuFailure& f, std::ostream* os) { *os << f.name; }  // names, not bytes, in ctest

class FlyImuFailure : public Fly, public ::testing::WithParamInterface<ImuFailure> {};

TEST_P(FlyImuFailure, DisarmsWithin100MsAndSaysWhy) {
  storeFourV2Motors();
  bootReady();
  armAndSpool(1200);
  ASSERT_FALSE(allStopped());
  GetParam().inject(imu_);
  const uint32_t took_ms = runUntil([&] { return allStopped(); }, 300);
  EXPECT_LE(took_ms, 100u);
  EXPECT_FALSE(app_->armed());
  EXPECT_EQ(app_->flight().last_cause, fly::DisarmCause::kImu);
  EXPECT_EQ(app_->imu().fault(), GetParam().fault);
  runFor(20);
  EXPECT_TRUE(contains(fake::output(), std::string("disarmed: IMU fault (") + GetParam().says))
      << fake::output();
  // and nothing spins until a new arm, whatever the IMU does meanwhile; its retries every
  // second fail alike and are not news
  runFor(3000);
  EXPECT_TRUE(allStopped());
  const std::string out = fake::output();
  EXPECT_EQ(out.find("imu: fault:"), out.rfind("imu: fault:")) << "said once\n" << out;
  EXPECT_FALSE(contains(out, "running again")) << out;
  EXPECT_GE(app_->imu().faults(), 3);
}

INSTANTIATE_TEST_SUITE_P(
    Causes, FlyImuFailure,
    ::testing::Values(ImuFailure{"Silent", [](FakeImu&) { fake::twiSetNack(true); }, fly::ImuFault::kNoAnswer,
                                 "no answer at its address"},
                      ImuFailure{"StuckBus", [](FakeImu&) { fake::twiHoldSdaLow(0); },
                                 fly::ImuFault::kBusStuck,
                                 "the bus is stuck (a line held low): a transfer never ended"},
                      ImuFailure{"FrozenData", [](FakeImu& imu) { imu.frozen = true; },
                                 fly::ImuFault::kFrozen, "frozen data"}),
    [](const ::testing::TestParamInfo<ImuFailure>& info) { return std::string(info.param.name); });

TEST_F(Fly, AStuckBusIsRecoveredByNineClocksAndTheImuComesBack) {
  storeFourV2Motors();
  bootReady();
  fake::twiHoldSdaLow(9);  // a slave mid-byte: nine SCL clocks free it
  runFor(50);
  EXPECT_GE(app_->imu().recoveries(), 1);
  EXPECT_GE(fake::twiRecoveries(), 1u);
  runFor(2500);  // the bus is free: no fault, or one and a new start-up within a second
  EXPECT_TRUE(app_->imuReady());
  EXPECT_TRUE(contains(command("arm"), "armed:"));
}

TEST_F(Fly, LinkLossDisarmsAfterTheFailsafeTime) {
  storeFourV2Motors();
  bootReady();
  armAndSpool(1200);
  fake::feedInput("\n");
  runFor(1);
  const uint32_t last_line_ms = fake::nowMs();
  const uint32_t took_ms = runUntil([&] { return allStopped(); }, 1000, false);
  EXPECT_GE(fake::nowMs() - last_line_ms, tc::kFailsafeMs);
  EXPECT_LE(fake::nowMs() - last_line_ms, tc::kFailsafeMs + 5u) << "at its frame";
  EXPECT_LE(took_ms, tc::kFailsafeMs + 100u);
  EXPECT_EQ(app_->flight().last_cause, fly::DisarmCause::kLink);
  EXPECT_TRUE(contains(fake::output(), "disarmed: link lost (no line for 500 ms)")) << fake::output();
  EXPECT_EQ(app_->link().trips, 1u);
}

TEST_F(Fly, DisarmStopsEveryEscAtOnceAndNothingSpinsUntilTheNextArm) {
  storeFourV2Motors();
  bootReady();
  armAndSpool(1200);
  EXPECT_TRUE(contains(command("disarm"), "disarmed: command; every ESC at the stop pulse"));
  EXPECT_TRUE(allStopped());
  command("thrust 2000");
  command("sp 10 -10");
  runFor(2000);
  EXPECT_TRUE(allStopped());
  command("sp 0 0");
  EXPECT_TRUE(contains(command("arm"), "armed:"));
  runFor(100);
  EXPECT_FALSE(allStopped());
}

// ---------------------------------------------------------------------------------------------
// Watchdog

TEST_F(Fly, TheWatchdogIsKickedOncePerFrameAndOnlyWhileFramesComeRound) {
  storeFourV2Motors();
  bootReady();
  EXPECT_TRUE(fake::watchdogStarted());
  uint32_t kicks = fake::watchdogKicks();
  runFor(1000);
  EXPECT_EQ(fake::watchdogKicks() - kicks, 400u) << "one per frame";
  // a stuck bus: the loop times each read out at the next frame and goes on (a read that
  // timed out takes its frame and the next), then the faulted IMU rests a frame at a time
  fake::twiHoldSdaLow(0);
  kicks = fake::watchdogKicks();
  runFor(1000);
  EXPECT_GE(fake::watchdogKicks() - kicks, 400u - fly::kImuMaxBadReads);
  EXPECT_LE(fake::watchdogKicks() - kicks, 400u);
  // frames that stop (the frame interrupt never comes): no kick, whatever the console does
  hal::Esc::setPhaseHook(0, nullptr);
  kicks = fake::watchdogKicks();
  command("help");
  command("status");
  runFor(200);
  EXPECT_EQ(fake::watchdogKicks(), kicks) << "the chip would reset";
}

// ---------------------------------------------------------------------------------------------
// Status and stream

TEST_F(Fly, StatusSaysStateImuAttitudeLoopTimingAndEachMotor) {
  storeFourV2Motors();
  bootReady();
  armAndSpool(1200);
  const std::string out = command("status");
  const uint16_t budget_us = fly::computeBudgetUs(fly::OutputMode::kForce, 0, 4);
  const std::string loop = "loop: IMU read at " + std::to_string(fly::readPhaseUs(budget_us)) +
                           " us of each 2500 us frame, computation budget " + std::to_string(budget_us) +
                           " us";
  for (const std::string& part :
       {std::string("state: armed, disarms 0, mode force, layout x"), std::string("imu: running; reads "),
        std::string("attitude: roll 0.0 pitch 0.0 deg"), std::string("thrust: 1200 g over 4 motors"),
        std::string("gains: roll/pitch kp 800 ki 0 kd 146, yaw kp 100 ki 0 (mN m)"),
        std::string("integrators: roll 0.0 pitch 0.0 yaw 0.0 mN m"), loop,
        std::string("motor 0: 300 g, "), std::string(" us; slot 0 (model v2)"), std::string("stack: ")}) {
    EXPECT_TRUE(contains(out, part)) << part << "\n" << out;
  }
  EXPECT_EQ(app_->loopStats().late, 0);
}

TEST_F(Fly, StatusSaysWhatTheIntegratorsHold) {
  storeFourV2Motors();
  bootReady();
  command("gains 800 1000 146");
  armAndSpool(1200);
  command("sp 10 0");  // the fake IMU stays level: a steady roll error of 10 degrees
  runFor(400);
  const float before_mnm = app_->controller().integralNm(0) * 1000.0f;
  const std::string out = command("status");  // it goes on integrating while status prints
  const float after_mnm = app_->controller().integralNm(0) * 1000.0f;
  EXPECT_GT(before_mnm, 50.0f) << "1 N m/(rad s) x 0.17 rad for ~0.4 s";
  const std::size_t at = out.find("integrators: roll ");
  ASSERT_NE(at, std::string::npos) << out;
  float shown = 0;
  char rest[32] = {};
  ASSERT_EQ(std::sscanf(out.c_str() + at, "integrators: roll %f %31[^\r\n]", &shown, rest), 2) << out;
  EXPECT_GE(shown, before_mnm - 0.051f) << out;
  EXPECT_LE(shown, after_mnm + 0.051f) << out;
  EXPECT_STREQ(rest, "pitch 0.0 yaw 0.0 mN m") << out;
}

TEST_F(Fly, TheStreamIsACsvOfFiftyRowsASecond) {
  storeFourV2Motors();
  bootReady();
  armAndSpool(1200);
  command("stream on");
  fake::takeOutput();
  runFor(1000);
  const std::string out = fake::takeOutput();
  int rows = 0;
  long last_ms = -1;
  for (const std::string& line : lines(out)) {
    if (line.empty()) continue;
    std::stringstream fields(line);
    std::string field;
    int n = 0;
    while (std::getline(fields, field, ',')) ++n;
    EXPECT_EQ(n, 16) << line;
    // t_s as seconds.milliseconds (advanced row by row, not divided): 20 ms apart, across
    // whole seconds too
    long s = 0, ms = 0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%ld.%3ld,", &s, &ms), 2) << line;
    ASSERT_LT(ms, 1000) << line;
    EXPECT_EQ(line.find('.'), line.find(',') - 4) << "three digits of milliseconds: " << line;
    if (last_ms >= 0) {
      EXPECT_EQ(s * 1000 + ms - last_ms, 20) << line;
    }
    last_ms = s * 1000 + ms;
    ++rows;
  }
  EXPECT_EQ(rows, 50);
  EXPECT_TRUE(contains(out, ",0.00,0.00,0.00,0.00,0.0,0.0,0.0,300.0,300.0,300.0,300.0,")) << out.substr(0, 200);
  EXPECT_TRUE(contains(command("stream off"), "# stream off"));
}

}  // namespace
