// fly's IMU driver alone (firmware/fly/mpu6050.hpp, linking fly_imu, the flight types and the fake
// HAL): its start-up one step per frame, the burst it reads every frame, and its faults, with
// the frames played by hand (onPhase, then poll) on the fake TWI's register-map slave.
#include <gtest/gtest.h>

#include <vector>

#include "hal/fake.hpp"
#include "mpu6050.hpp"

namespace {

using namespace fly;
namespace fake = hal::fake;

class Imu : public ::testing::Test {
 protected:
  void SetUp() override {
    fake::reset();
    hal::Twi::init(hal::kTwiFastHz);
    fake::twiAttach(hal::kImuI2cAddress);
    fake::twiClearOnRead(0x3A);
    fake::twiRegisters()[0x75] = 0x68;
    imu_.begin();
  }
  // One frame: the phase hook starts the prepared transfer, the loop takes its end.
  ImuFrame frame() {
    imu_.onPhase();
    ImuFrame f;
    EXPECT_TRUE(imu_.poll(f));
    return f;
  }
  uint16_t framesUntilRunning(uint16_t max) {
    for (uint16_t n = 1; n <= max; ++n) {
      frame();
      if (imu_.running() || imu_.state() == ImuState::kFaulted) return n;
    }
    return 0;
  }
  Mpu6050 imu_;
};

TEST_F(Imu, StartsInOneStepPerFrameWithTheResetWaitInFramesOfTheLoopRate) {
  // WHO_AM_I; DEVICE_RESET, whose frame is the first of the 100 ms wait; six settings; the
  // read-back
  const uint16_t n = framesUntilRunning(200);
  EXPECT_EQ(n, 1 + mpu::kResetFrames + 6 + 1);
  EXPECT_EQ(mpu::kResetFrames, kLoopHz / 10) << "100 ms of frames";
  EXPECT_TRUE(imu_.running());
  ASSERT_EQ(fake::twiWrites().size(), 7u);
  EXPECT_EQ(fake::twiWrites()[0].reg, mpu::kPwrMgmt1);
  EXPECT_EQ(fake::twiWrites()[0].value, mpu::kDeviceReset);
}

TEST_F(Imu, EachFrameReadsOneConsistentSampleInTheFlightTypesUnits) {
  ASSERT_GT(framesUntilRunning(200), 0);
  uint8_t* r = fake::twiRegisters();
  r[0x3A] = 0x01;                       // DATA_RDY
  r[0x3B] = 0x10, r[0x3C] = 0x00;       // accel x 4096: 1 g (kAccelLsbPerG)
  r[0x47] = 0xFF, r[0x48] = 0xF0;       // gyro z -16
  const ImuFrame f = frame();
  ASSERT_TRUE(f.has_sample);
  EXPECT_EQ(f.frames, 1);
  EXPECT_EQ(f.sample.accel[0], kAccelLsbPerG);
  EXPECT_EQ(f.sample.gyro[2], -16);
  EXPECT_TRUE(f.sample.fresh);
  const ImuFrame stale = frame();  // INT_STATUS cleared on read: no new sample
  EXPECT_FALSE(stale.has_sample);
  EXPECT_EQ(imu_.staleReads(), 1);
}

TEST_F(Imu, TwentyMillisecondsOfStaleReadsIsFrozenDataAndItTriesAgainASecondLater) {
  ASSERT_GT(framesUntilRunning(200), 0);
  EXPECT_EQ(kImuMaxStaleReads, framesIn(20));
  uint16_t frames = 0;
  bool faulted = false;
  while (!faulted && frames < 100) {
    faulted = frame().fault_now;
    ++frames;
  }
  EXPECT_EQ(frames, kImuMaxStaleReads);
  EXPECT_EQ(imu_.fault(), ImuFault::kFrozen);
  for (uint16_t k = 2; k < mpu::kRetryFrames; ++k) frame();  // the fault's frame was the first
  EXPECT_EQ(imu_.state(), ImuState::kFaulted) << "a second of frames not over yet";
  frame();
  EXPECT_EQ(imu_.state(), ImuState::kWhoAmI) << "starts again";
}

TEST(ImuRules, TheImuFaultsAfterEightBadOrStaleReadsInARowThat_Is20Milliseconds) {
  EXPECT_FALSE(imuReadsFailed(kImuMaxBadReads - 1));
  EXPECT_TRUE(imuReadsFailed(kImuMaxBadReads));
  EXPECT_FALSE(imuFrozen(kImuMaxStaleReads - 1));
  EXPECT_TRUE(imuFrozen(kImuMaxStaleReads));
  EXPECT_LE(kImuMaxBadReads * kFrameUs, 100000u / 4) << "well inside the 100 ms a disarm may take";
}

TEST_F(Imu, AWrongWhoAmIIsAFaultAtOnce) {
  fake::twiRegisters()[0x75] = 0x70;
  EXPECT_EQ(framesUntilRunning(10), 1);
  EXPECT_EQ(imu_.fault(), ImuFault::kWrongId);
  EXPECT_EQ(imu_.whoAmI(), 0x70);
}

}  // namespace
