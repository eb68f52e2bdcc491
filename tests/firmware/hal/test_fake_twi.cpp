// The fake HAL's TWI and ESC phase hook (fake.hpp): what fly's host tests stand on, pinned here
// against the datasheet behaviour the AVR backend (hal/avr/twi.cpp, esc.cpp) has on the chip.
#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "hal/fake.hpp"
#include "hal/hal.hpp"

namespace {

namespace fake = hal::fake;
using Result = hal::Twi::Result;

class FakeTwi : public ::testing::Test {
 protected:
  void SetUp() override {
    fake::reset();
    hal::Twi::init(hal::kTwiFastHz);
  }
  void TearDown() override { fake::reset(); }
};

TEST_F(FakeTwi, ARegisterReadReturnsConsecutiveRegistersAndEndsOnTheLastBytesNack) {
  // given: a slave whose registers 0x3B.. hold 1, 2, 3
  fake::twiAttach(0x68);
  fake::twiRegisters()[0x3B] = 1;
  fake::twiRegisters()[0x3C] = 2;
  fake::twiRegisters()[0x3D] = 3;
  // when
  ASSERT_TRUE(hal::Twi::startRead(0x68, 0x3B, 3));
  // then
  EXPECT_EQ(hal::Twi::result(), Result::kDone);
  EXPECT_EQ(hal::Twi::lastStatus(), 0x58);
  uint8_t data[4] = {};
  EXPECT_EQ(hal::Twi::readData(data, 4), 3) << "only what was read";
  EXPECT_EQ(data[0], 1);
  EXPECT_EQ(data[2], 3);
  EXPECT_EQ(fake::twiReads(), 1u);
  EXPECT_EQ(fake::twiSclHz(), 400000u);
}

TEST_F(FakeTwi, ARegisterWriteIsLoggedAndEndsOnTheDataAck) {
  fake::twiAttach(0x68);
  ASSERT_TRUE(hal::Twi::startWrite(0x68, 0x6B, 0x03));
  EXPECT_EQ(hal::Twi::result(), Result::kDone);
  EXPECT_EQ(hal::Twi::lastStatus(), 0x28);
  ASSERT_EQ(fake::twiWrites().size(), 1u);
  EXPECT_EQ(fake::twiWrites()[0].reg, 0x6B);
  EXPECT_EQ(fake::twiWrites()[0].value, 0x03);
  EXPECT_EQ(fake::twiRegisters()[0x6B], 0x03);
}

TEST_F(FakeTwi, AnAbsentOrSilentSlaveIsANackOnItsAddress) {
  ASSERT_TRUE(hal::Twi::startRead(0x68, 0x75, 1));
  EXPECT_EQ(hal::Twi::result(), Result::kNack) << "nothing attached";
  EXPECT_EQ(hal::Twi::lastStatus(), 0x20);
  fake::twiAttach(0x68);
  ASSERT_TRUE(hal::Twi::startRead(0x69, 0x75, 1));
  EXPECT_EQ(hal::Twi::result(), Result::kNack) << "another address";
  fake::twiSetNack(true);
  ASSERT_TRUE(hal::Twi::startRead(0x68, 0x75, 1));
  EXPECT_EQ(hal::Twi::result(), Result::kNack) << "the slave stopped answering";
}

TEST_F(FakeTwi, AClearOnReadRegisterReadsItsValueOnceThenZero) {
  fake::twiAttach(0x68);
  fake::twiClearOnRead(0x3A);
  fake::twiRegisters()[0x3A] = 0x01;
  uint8_t v = 0xFF;
  ASSERT_TRUE(hal::Twi::startRead(0x68, 0x3A, 1));
  hal::Twi::readData(&v, 1);
  EXPECT_EQ(v, 0x01);
  ASSERT_TRUE(hal::Twi::startRead(0x68, 0x3A, 1));
  hal::Twi::readData(&v, 1);
  EXPECT_EQ(v, 0x00);
}

TEST_F(FakeTwi, TheReadHookRefreshesRegistersBeforeTheyAreCopied) {
  fake::twiAttach(0x68);
  int calls = 0;
  fake::setTwiReadHook([&](uint8_t reg, uint8_t length) {
    ++calls;
    fake::twiRegisters()[reg] = static_cast<uint8_t>(length + calls);
  });
  uint8_t v = 0;
  ASSERT_TRUE(hal::Twi::startRead(0x68, 0x10, 2));
  hal::Twi::readData(&v, 1);
  EXPECT_EQ(v, 3);
  EXPECT_EQ(calls, 1);
}

TEST_F(FakeTwi, LengthsOutsideOneToMaxReadAreRefusedWithNothingStarted) {
  fake::twiAttach(0x68);
  EXPECT_FALSE(hal::Twi::startRead(0x68, 0x3B, 0));
  EXPECT_FALSE(hal::Twi::startRead(0x68, 0x3B, hal::Twi::kMaxRead + 1));
  EXPECT_EQ(fake::twiReads(), 0u);
  EXPECT_EQ(hal::Twi::result(), Result::kIdle);
}

TEST_F(FakeTwi, WithSdaHeldLowATransferNeverEndsUntilAbortedAndRefusesANewStart) {
  // given
  fake::twiAttach(0x68);
  fake::twiHoldSdaLow(0);
  // when
  ASSERT_TRUE(hal::Twi::startRead(0x68, 0x3B, 14));
  fake::advanceMs(50);
  // then
  EXPECT_EQ(hal::Twi::result(), Result::kBusy);
  EXPECT_FALSE(hal::Twi::startRead(0x68, 0x3B, 14)) << "one transfer at a time";
  hal::Twi::abort();
  EXPECT_EQ(hal::Twi::result(), Result::kAborted);
  EXPECT_EQ(fake::twiAborts(), 1u);
}

TEST_F(FakeTwi, BusRecoveryFreesASlaveThatLetsGoWithinNineClocksOnly) {
  fake::twiAttach(0x68);
  fake::twiHoldSdaLow(9);
  EXPECT_TRUE(hal::Twi::recoverBus());
  ASSERT_TRUE(hal::Twi::startRead(0x68, 0x75, 1));
  EXPECT_EQ(hal::Twi::result(), Result::kDone) << "the bus works again";

  fake::twiHoldSdaLow(10);
  EXPECT_FALSE(hal::Twi::recoverBus()) << "needs more than one byte's clocks";
  fake::twiHoldSdaLow(0);
  EXPECT_FALSE(hal::Twi::recoverBus()) << "a slave that never lets go";
  EXPECT_EQ(fake::twiRecoveries(), 3u);
}

TEST_F(FakeTwi, ThePhaseHookRunsOncePerFrameAt400HzAndFrameTimeWrapsAtTheFramePeriod) {
  // given
  static int calls = 0;
  calls = 0;
  hal::Esc::init(400);
  hal::Esc::setPhaseHook(1500, [] { ++calls; });
  // when: one simulated second
  fake::advanceMs(1000);
  // then
  EXPECT_EQ(calls, 400);
  EXPECT_EQ(fake::phaseHookCalls(), 400u);
  EXPECT_EQ(hal::Esc::frameTimeUs(), 0) << "1000 ms is a frame boundary";
  fake::advanceMs(1);
  EXPECT_EQ(hal::Esc::frameTimeUs(), 1000);
  fake::advanceMs(2);
  EXPECT_EQ(hal::Esc::frameTimeUs(), 500) << "3000 us into frames of 2500 us";
  hal::Esc::setPhaseHook(0, nullptr);
  fake::advanceMs(100);
  EXPECT_EQ(calls, 401) << "no hook, no calls (the frame from 1000 ms had its call at 1001.5 ms)";
}

TEST(FakeClock, SleepUnlessPassesNoTimeWithWorkPendingAndSleepUntilWaitsForIt) {
  fake::reset();
  static bool pending = false;
  pending = true;
  hal::Clock::sleepUnless([] { return pending; });
  EXPECT_EQ(fake::nowMs(), 0u) << "work pending: back at once";
  pending = false;
  hal::Clock::sleepUnless([] { return pending; });
  EXPECT_EQ(fake::nowMs(), 1u) << "nothing pending: one millisecond asleep";
  fake::setTickHook([](uint32_t now_ms) { pending = now_ms >= 7; });
  hal::Clock::sleepUntil([] { return pending; });
  EXPECT_EQ(fake::nowMs(), 7u);
  fake::setTickHook(nullptr);
  fake::setTimeLimitMs(20);
  pending = false;
  EXPECT_THROW(hal::Clock::sleepUntil([] { return pending; }), std::runtime_error)
      << "the time limit ends it";
  fake::reset();
}

}  // namespace
