// fly with a receiver on the fake HAL (fly_receiver.cpp): PPM and PWM frames queued as hal::Rc
// would queue them (hal::fake::rcPpmFrame), every 20 ms from the fake's tick; stick arming behind
// every arming check, stick disarming, angle and rate mode from the sticks, the receiver's
// failsafe, and noise counted in `status`.
#include <gtest/gtest.h>

#include <vector>

#include "fly_fixture.hpp"

namespace {

using namespace fly_test;

constexpr uint16_t kCentre = 1500;

class FlyReceiver : public Fly {
 protected:
  // A transmitter in AETR order: roll, pitch, throttle, yaw, mode switch (channel 5).
  std::vector<uint16_t> sticks_ = {kCentre, kCentre, 1000, kCentre, 1000};
  bool transmitting_ = true;
  bool pwm_ = false;
  uint16_t ticks_ = 0;
  int noisy_frames_ = 0;  // the next frames carry an out-of-range channel

  void SetUp() override {
    Fly::SetUp();
    fake::setTickHook([this](uint32_t now_ms) {
      imu_.tick();
      if (!transmitting_ || now_ms % 20 != 0) return;
      std::vector<uint16_t> us = sticks_;
      if (noisy_frames_ > 0) {
        --noisy_frames_;
        us[1] = 2600;
      }
      ticks_ = pwm_ ? fake::rcPwmFrame(ticks_, us) : fake::rcPpmFrame(ticks_, us, 20000);
      ticks_ = static_cast<uint16_t>(ticks_ + (pwm_ ? 2 * 8000 : 0));
    });
  }
  // Booted and ready, pwm mode (no calibrated slot needed), the receiver on.
  void ready(const char* rc = "rc ppm") {
    storeFourV2Motors();
    bootReady();
    command("mode pwm");
    command("hover 1500 1440");
    const std::string out = command(rc);
    ASSERT_TRUE(contains(out, "rc: ")) << out;
    runFor(200);
  }
  void hold(uint16_t throttle, uint16_t yaw, uint32_t ms) {
    sticks_[2] = throttle;
    sticks_[3] = yaw;
    runFor(ms);
  }
};

TEST_F(FlyReceiver, ThrottleLowAndYawRightHeldASecondArmsAndYawLeftDisarms) {
  ready();
  hold(1000, 2000, 600);
  EXPECT_FALSE(app_->armed()) << "not held long enough";
  hold(1000, 2000, 600);
  ASSERT_TRUE(app_->armed()) << fake::output();
  EXPECT_EQ(app_->flight().source, fly::ArmSource::kSticks);
  EXPECT_TRUE(contains(fake::output(), "armed: mode pwm, layout x, from the sticks")) << fake::output();
  hold(1000, kCentre, 100);
  EXPECT_TRUE(app_->armed()) << "releasing the sticks keeps it armed";
  hold(1000, 1000, 1100);
  EXPECT_FALSE(app_->armed());
  EXPECT_TRUE(contains(fake::output(), "disarmed: sticks (throttle low, yaw left)")) << fake::output();
  EXPECT_TRUE(allStopped());
}

TEST_F(FlyReceiver, StickArmingGoesThroughEveryArmingCheck) {
  ready();
  imu_.roll_deg = 12;  // not level (the estimate follows in its 0.5 s time constant)
  runFor(2000);
  hold(1000, 2000, 1100);
  EXPECT_FALSE(app_->armed());
  EXPECT_TRUE(contains(fake::output(), "sticks: error: arm refused: not level")) << fake::output();
  hold(1000, kCentre, 100);
}

TEST_F(FlyReceiver, TheSticksFlyAnglesInAngleModeAndRatesInRateMode) {
  ready();
  hold(1000, 2000, 1100);
  ASSERT_TRUE(app_->armed());
  sticks_[3] = kCentre;
  sticks_[2] = 1500;  // half throttle: half the pwm line's 1440 g
  sticks_[0] = 2000;  // full right roll: 30 deg
  runFor(100);
  const fly::SetpointQ& sp = app_->command().setpoint_q;
  EXPECT_EQ(sp.mode, fly::FlightMode::kAngle);
  EXPECT_NEAR(sp.roll * fly::kRadPerAngleUnit / fly::kRadPerDeg, 30.0, 0.05);
  EXPECT_NEAR(fly::gramsOf(app_->flight().limits.collective), 720.0, 1.0);
  EXPECT_TRUE(contains(command("sp 5 0"), "error: the sticks fly")) << "the console does not";
  sticks_[4] = 2000;  // the mode switch: rate mode
  runFor(100);
  EXPECT_EQ(app_->command().setpoint_q.mode, fly::FlightMode::kRate);
  EXPECT_NEAR(app_->command().setpoint_q.rate[0] * fly::kRadPerRateUnit / fly::kRadPerDeg, 200.0, 0.5);
  EXPECT_EQ(app_->command().setpoint_q.roll, 0);
}

TEST_F(FlyReceiver, NoValidFrameStopsEveryPulseWithin100Ms) {
  ready();
  hold(1000, 2000, 1100);
  ASSERT_TRUE(app_->armed());
  sticks_[3] = kCentre;
  sticks_[2] = 1400;
  runFor(1200);  // spooled up
  ASSERT_FALSE(allStopped());
  // when: the transmitter goes away (no console line is needed to keep a stick flight armed)
  transmitting_ = false;
  const uint32_t took = runUntil([&] { return allStopped(); }, 500, false);
  // then: it acts kRcLossMs after the last frame (at most 20 ms before the transmitter stopped),
  // early enough that the pins carry the stop pulse within kRcStopMs of it
  EXPECT_GE(took, fly::kRcLossMs - 20);
  EXPECT_LE(took, fly::kRcLossMs + 5) << "the failsafe acts within a frame of its time";
  EXPECT_LT(fly::kRcLossMs, fly::kRcStopMs);
  EXPECT_FALSE(app_->armed());
  EXPECT_TRUE(contains(fake::output(), "disarmed: receiver lost (no valid frame for " +
                                           std::to_string(fly::kRcLossMs) + " ms)"))
      << fake::output();
}

TEST_F(FlyReceiver, NoisyFramesAreNotFlownAndCountedInStatus) {
  ready();
  noisy_frames_ = 3;
  runFor(100);
  const std::string out = command("status");
  EXPECT_TRUE(contains(out, "bad frames 3")) << out;
  EXPECT_TRUE(contains(out, "rejected pulses 3")) << out;
  EXPECT_TRUE(contains(out, "sticks roll 0 pitch 0 yaw 0 us, throttle 1000 us, angle mode")) << out;
}

TEST_F(FlyReceiver, APulsePerChannelOnTheFirstFivePinsFliesAlike) {
  pwm_ = true;
  ready("rc pwm 5");
  EXPECT_EQ(fake::rcMask(), 0x1F);
  hold(1000, 2000, 1100);
  EXPECT_TRUE(app_->armed()) << fake::output();
  EXPECT_GT(app_->rc().frames(), 50u);
}

}  // namespace
