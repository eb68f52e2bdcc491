// The fake HAL backend: the seam every firmware host test stands on. If the fake lies, every
// firmware test above it lies, so its documented behaviour (fake.hpp, hal.hpp) is pinned here.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "hal/fake.hpp"
#include "hal/hal.hpp"

namespace {

class FakeHal : public ::testing::Test {
 protected:
  void SetUp() override { hal::fake::reset(); }
  void TearDown() override { hal::fake::reset(); }
};

TEST_F(FakeHal, ResetRestoresPowerOnState) {
  // given: every part of the fake touched
  hal::Esc::init(400);
  hal::fake::setAdcCounts(0, 500);
  hal::Eeprom::updateByte(10, 0x12);
  hal::fake::feedInput("x");
  hal::Uart::print("y");
  hal::fake::advanceMs(5);
  hal::fake::setTickHook([](uint32_t) {});
  hal::fake::setTimeLimitMs(3);
  // when
  hal::fake::reset();
  // then
  EXPECT_EQ(hal::fake::nowMs(), 0u);
  EXPECT_EQ(hal::Adc::readCounts(0), 0u);
  EXPECT_EQ(hal::fake::pulseUs(0), 0u);
  EXPECT_EQ(hal::fake::frameRateHz(), 0u);
  EXPECT_EQ(hal::fake::eeprom()[10], 0xFF);
  EXPECT_EQ(hal::fake::eepromWrites(), 0u);
  EXPECT_FALSE(hal::Uart::available());
  EXPECT_EQ(hal::fake::output(), "");
  EXPECT_NO_THROW(hal::Clock::delayMs(10));  // time limit cleared
}

struct MillivoltRow {
  uint16_t mv;
  uint16_t counts;
};

TEST_F(FakeHal, AdcMillivoltsRoundToTheNearestCountOf1023PerFiveVolts) {
  const MillivoltRow rows[] = {
      {0, 0}, {2, 0}, {3, 1}, {2500, 512}, {4995, 1022}, {5000, 1023}, {6000, 1023},
  };
  for (const auto& row : rows) {
    hal::fake::setAdcMillivolts(1, row.mv);
    EXPECT_EQ(hal::Adc::readCounts(1), row.counts) << row.mv << " mV";
  }
}

TEST_F(FakeHal, AdcChannelsAreIndependentAndConversionsAreCounted) {
  // given
  hal::fake::setAdcCounts(0, 100);
  hal::fake::setAdcCounts(1, 900);
  // when
  const uint16_t a0 = hal::Adc::readCounts(0);
  const uint16_t a1 = hal::Adc::readCounts(1);
  // then
  EXPECT_EQ(a0, 100u);
  EXPECT_EQ(a1, 900u);
  EXPECT_EQ(hal::fake::adcConversions(), 2u);
}

TEST_F(FakeHal, AdcSourceIsConsultedOnEveryConversionAndClampedToTenBits) {
  // given
  uint16_t next = 1020;
  hal::fake::setAdcSource([&](uint8_t channel) -> uint16_t { return channel == 0 ? next++ : 7; });
  // when / then
  EXPECT_EQ(hal::Adc::readCounts(0), 1020u);
  EXPECT_EQ(hal::Adc::readCounts(0), 1021u);
  EXPECT_EQ(hal::Adc::readCounts(1), 7u);
  next = 5000;
  EXPECT_EQ(hal::Adc::readCounts(0), 1023u);
  // an empty source falls back to the fixed values
  hal::fake::setAdcCounts(0, 33);
  hal::fake::setAdcSource({});
  EXPECT_EQ(hal::Adc::readCounts(0), 33u);
}

TEST_F(FakeHal, AdcChannelOutsideTheChipThrows) {
  EXPECT_THROW(hal::Adc::readCounts(16), std::out_of_range);
}

TEST_F(FakeHal, EscInitArmsAllFourAtOneThousandMicroseconds) {
  EXPECT_EQ(hal::fake::pulseUs(0), 0u);
  hal::Esc::init();
  for (uint8_t ch = 0; ch < hal::kEscChannels; ++ch) EXPECT_EQ(hal::fake::pulseUs(ch), 1000u);
  EXPECT_EQ(hal::fake::frameRateHz(), 50u);
  EXPECT_EQ(hal::Esc::frameRateHz(), 50u);
}

struct PulseRow {
  uint16_t written_us;
  uint16_t expected_us;
};

TEST_F(FakeHal, EscPulsesAreClampedTo500To2500Microseconds) {
  hal::Esc::init();
  const PulseRow rows[] = {{0, 500}, {499, 500}, {500, 500}, {1234, 1234}, {2500, 2500}, {2501, 2500},
                           {65535, 2500}};
  for (const auto& row : rows) {
    hal::Esc::writePulse(2, row.written_us);
    EXPECT_EQ(hal::fake::pulseUs(2), row.expected_us) << row.written_us;
    EXPECT_EQ(hal::Esc::pulseUs(2), row.expected_us);
  }
  EXPECT_EQ(hal::fake::pulseUs(1), 1000u);  // other channels untouched
}

TEST_F(FakeHal, EscChannelOutsideFourIsIgnored) {
  hal::Esc::init();
  hal::Esc::writePulse(4, 1500);
  EXPECT_EQ(hal::Esc::pulseUs(4), 0u);
  for (uint8_t ch = 0; ch < hal::kEscChannels; ++ch) EXPECT_EQ(hal::fake::pulseUs(ch), 1000u);
}

struct FrameRow {
  uint16_t hz;
  bool accepted;
  uint16_t after_hz;
};

TEST_F(FakeHal, EscFrameRateAccepts50To400HzAndRejectsTheRestUnchanged) {
  hal::Esc::init();
  const FrameRow rows[] = {{49, false, 50}, {400, true, 400}, {401, false, 400}, {0, false, 400},
                           {50, true, 50}, {200, true, 200}};
  for (const auto& row : rows) {
    EXPECT_EQ(hal::Esc::setFrameRate(row.hz), row.accepted) << row.hz;
    EXPECT_EQ(hal::fake::frameRateHz(), row.after_hz) << row.hz;
  }
}

TEST_F(FakeHal, EscInitWithAnInvalidFrameRateFallsBackTo50Hz) {
  hal::Esc::init(1000);
  EXPECT_EQ(hal::fake::frameRateHz(), 50u);
}

TEST_F(FakeHal, EepromStartsErasedAndCountsOnlyPhysicalWrites) {
  // given: erased memory
  EXPECT_EQ(hal::Eeprom::readByte(0), 0xFF);
  EXPECT_EQ(hal::Eeprom::readByte(4095), 0xFF);
  // when: an equal byte, a new byte, the same new byte again
  hal::Eeprom::updateByte(7, 0xFF);
  hal::Eeprom::updateByte(7, 0x42);
  hal::Eeprom::updateByte(7, 0x42);
  // then: one physical write
  EXPECT_EQ(hal::Eeprom::readByte(7), 0x42);
  EXPECT_EQ(hal::fake::eeprom()[7], 0x42);
  EXPECT_EQ(hal::fake::eepromWrites(), 1u);
  hal::fake::resetEepromWrites();
  EXPECT_EQ(hal::fake::eepromWrites(), 0u);
}

TEST_F(FakeHal, EepromBlockWriteSkipsBytesThatAlreadyHoldTheValue) {
  // given
  const uint8_t first[4] = {1, 2, 3, 4};
  hal::Eeprom::updateBlock(1000, first, 4);
  hal::fake::resetEepromWrites();
  // when: two of four bytes change
  const uint8_t second[4] = {1, 9, 3, 8};
  hal::Eeprom::updateBlock(1000, second, 4);
  // then
  EXPECT_EQ(hal::fake::eepromWrites(), 2u);
  uint8_t back[4] = {};
  hal::Eeprom::readBlock(1000, back, 4);
  EXPECT_EQ(std::vector<uint8_t>(back, back + 4), std::vector<uint8_t>(second, second + 4));
}

TEST_F(FakeHal, EepromAccessPastTheEndThrowsInsteadOfWrapping) {
  uint8_t buf[2];
  EXPECT_THROW(hal::Eeprom::readBlock(4095, buf, 2), std::out_of_range);
  EXPECT_THROW(hal::Eeprom::updateByte(4096, 1), std::out_of_range);
  EXPECT_NO_THROW(hal::Eeprom::readBlock(4094, buf, 2));
}

TEST_F(FakeHal, UartDeliversFedInputInOrderThenReportsEmpty) {
  hal::fake::feedInput("ab");
  EXPECT_TRUE(hal::Uart::available());
  EXPECT_EQ(hal::Uart::read(), 'a');
  EXPECT_EQ(hal::Uart::read(), 'b');
  EXPECT_FALSE(hal::Uart::available());
  EXPECT_EQ(hal::Uart::read(), -1);
}

TEST_F(FakeHal, UartOutputCollectsWritesPrintsAndProgmemPrints) {
  hal::Uart::write('x');
  hal::Uart::print("yz");
  hal::Uart::printP("!");  // on the host a flash text is an ordinary string
  EXPECT_EQ(hal::fake::output(), "xyz!");
  EXPECT_EQ(hal::fake::takeOutput(), "xyz!");
  EXPECT_EQ(hal::fake::output(), "");
}

TEST_F(FakeHal, UartBytesAboveSevenBitsSurviveTheRoundTrip) {
  hal::fake::feedInput(std::string(1, static_cast<char>(0xE5)));
  EXPECT_EQ(hal::Uart::read(), 0xE5);
}

TEST_F(FakeHal, DelayAdvancesTimeMillisecondByMillisecondCallingTheTickHook) {
  // given
  std::vector<uint32_t> ticks;
  hal::fake::setTickHook([&](uint32_t now) { ticks.push_back(now); });
  // when
  hal::Clock::delayMs(3);
  hal::Clock::sleepUntilInterrupt();
  hal::fake::advanceMs(2);
  // then
  EXPECT_EQ(ticks, (std::vector<uint32_t>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(hal::Clock::millis(), 6u);
  EXPECT_EQ(hal::fake::nowMs(), 6u);
}

TEST_F(FakeHal, ScheduledInputArrivesWhenTheClockReachesItsTimeBeforeTheTickHookRuns) {
  // given
  hal::fake::feedInputAt(5, "k");
  std::vector<std::pair<uint32_t, bool>> seen;  // (ms, input available in the hook)
  hal::fake::setTickHook([&](uint32_t now) { seen.push_back({now, hal::Uart::available()}); });
  // when
  hal::Clock::delayMs(4);
  const bool before = hal::Uart::available();
  hal::Clock::delayMs(1);
  // then
  EXPECT_FALSE(before);
  EXPECT_TRUE(hal::Uart::available());
  ASSERT_EQ(seen.size(), 5u);
  EXPECT_FALSE(seen[3].second);
  EXPECT_TRUE(seen[4].second);  // at 5 ms the hook already sees the byte
}

TEST_F(FakeHal, ScheduledInputsDueTogetherKeepTheirOrderAndPastTimesArriveAtOnce) {
  hal::fake::advanceMs(10);
  hal::fake::feedInputAt(3, "now");  // already past
  EXPECT_TRUE(hal::Uart::available());
  hal::fake::feedInputAt(12, "1");
  hal::fake::feedInputAt(11, "0");
  hal::fake::feedInputAt(12, "2");
  hal::fake::advanceMs(2);
  std::string got;
  while (hal::Uart::available()) got.push_back(static_cast<char>(hal::Uart::read()));
  EXPECT_EQ(got, "now012");
}

TEST_F(FakeHal, TimeLimitStopsAWaitThatRunsPastIt) {
  // given
  hal::fake::setTimeLimitMs(100);
  // when / then: a wait up to the limit is fine, the next one throws
  EXPECT_NO_THROW(hal::Clock::delayMs(100));
  EXPECT_THROW(hal::Clock::sleepUntilInterrupt(), std::runtime_error);
  EXPECT_EQ(hal::fake::nowMs(), 100u);
}

TEST_F(FakeHal, TimeLimitInterruptsALongDelayPartWay) {
  hal::fake::setTimeLimitMs(50);
  try {
    hal::Clock::delayMs(1000);
    FAIL() << "expected the time limit to throw";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "fake HAL: time limit");
  }
  EXPECT_EQ(hal::fake::nowMs(), 50u);
}

TEST_F(FakeHal, TickHookCanModelAPlantReactingToTheEscPulse) {
  // given: a "plant" whose ADC reading follows the pulse of ESC 0
  hal::Esc::init();
  hal::fake::setTickHook([](uint32_t) {
    hal::fake::setAdcCounts(0, static_cast<uint16_t>((hal::Esc::pulseUs(0) - 1000) / 2));
  });
  // when
  hal::Esc::writePulse(0, 1600);
  hal::Clock::delayMs(1);
  // then
  EXPECT_EQ(hal::Adc::readCounts(0), 300u);
}

}  // namespace

TEST(FakeHalBoard, WriteAllSetsTheFourPulsesClampedLikeWritePulseInOneCall) {
  hal::fake::reset();
  hal::Esc::init(50);
  const uint16_t pulses_us[hal::kEscChannels] = {1000, 1500, 100, 3000};
  hal::Esc::writeAll(pulses_us);
  EXPECT_EQ(hal::fake::escWriteAlls(), 1u);
  EXPECT_EQ(hal::fake::pulseUs(0), 1000);
  EXPECT_EQ(hal::fake::pulseUs(1), 1500);
  EXPECT_EQ(hal::fake::pulseUs(2), hal::kPulseClampMinUs);
  EXPECT_EQ(hal::fake::pulseUs(3), hal::kPulseClampMaxUs);
}

TEST(FakeHalBoard, TheBoardTableIsWhatTheDocsSay) {
  // docs/hardware.md's wiring table; the compile-time checks are in hal/board.hpp.
  static_assert(hal::board::uartDivisor(115200) == 16, "UBRR0 16 with U2X0");
  EXPECT_EQ(hal::board::uartActualBaud(115200), 117647u);
  EXPECT_EQ(hal::board::uartErrorBasisPoints(115200), 212u);  // +2.12 %
  EXPECT_EQ(hal::board::uartErrorBasisPoints(250000), 0u) << "250 kbaud divides 16 MHz exactly";
  EXPECT_EQ(hal::board::escCompareAddress(0), 0xA8);  // OCR4A
  EXPECT_EQ(hal::board::escCompareAddress(3), 0x88);  // OCR1A
  EXPECT_EQ(hal::board::escPortMask('H'), 0x38);      // PH3..PH5
  EXPECT_EQ(hal::board::escPortMask('B'), 0x20);      // PB5
  EXPECT_EQ(hal::board::escCompareBits(4), 0xA8);     // COM4A1 | COM4B1 | COM4C1
  EXPECT_EQ(hal::board::escCompareBits(1), 0x80);     // COM1A1
  EXPECT_EQ(hal::kAdcLoadCell, 0);
  EXPECT_EQ(hal::kAdcBattery, 1);
}
