#include <gtest/gtest.h>

#include <cstring>

#include "thrustcal/crc16.hpp"

namespace {

// Bit-by-bit reference straight from the definition (poly 0x1021, MSB first).
uint16_t referenceCrc(uint16_t crc, uint8_t byte) {
  crc = static_cast<uint16_t>(crc ^ (static_cast<uint16_t>(byte) << 8));
  for (int bit = 0; bit < 8; ++bit)
    crc = static_cast<uint16_t>((crc & 0x8000) ? (crc << 1) ^ 0x1021 : (crc << 1));
  return crc;
}

TEST(Crc16, MatchesPublishedCheckValueOf123456789) {
  // given
  const char* text = "123456789";
  // when
  const uint16_t crc = tc::crc16CcittFalse(reinterpret_cast<const uint8_t*>(text), 9);
  // then
  EXPECT_EQ(crc, 0x29B1);
}

TEST(Crc16, EmptyBufferLeavesInitialValue) {
  EXPECT_EQ(tc::crc16CcittFalse(nullptr, 0), 0xFFFF);
  EXPECT_EQ(tc::crc16CcittFalse(nullptr, 0, 0x1234), 0x1234);
}

TEST(Crc16, ContinuingARunningCrcEqualsOneShot) {
  // given
  const uint8_t data[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  for (uint16_t split = 0; split <= sizeof data; ++split) {
    // when
    const uint16_t head = tc::crc16CcittFalse(data, split);
    const uint16_t both = tc::crc16CcittFalse(data + split, static_cast<uint16_t>(sizeof data - split), head);
    // then
    EXPECT_EQ(both, 0x29B1) << "split at " << split;
  }
}

TEST(Crc16, ByteUpdateEqualsBitwiseDefinitionForEveryByteAndManyStates) {
  for (uint32_t crc = 0; crc <= 0xFFFF; crc += 257) {
    for (uint32_t byte = 0; byte < 256; ++byte) {
      ASSERT_EQ(tc::crc16Update(static_cast<uint16_t>(crc), static_cast<uint8_t>(byte)),
                referenceCrc(static_cast<uint16_t>(crc), static_cast<uint8_t>(byte)))
          << "crc " << crc << " byte " << byte;
    }
  }
}

}  // namespace
