// Intel HEX codec for EEPROM images (what avrdude -U eeprom:w:FILE:i reads).
#include <gtest/gtest.h>

#include "hex/intel_hex.hpp"

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

namespace {

TEST(IntelHex, FormatsRecordsWithChecksumsAvrdudeAccepts) {
  // given: 4 bytes (a known record from the Intel HEX specification family)
  std::vector<uint8_t> image = {0x01, 0x02, 0x03, 0x04};
  // when
  const std::string text = hex::formatIntelHex(image);
  // then: count 04, address 0000, type 00, data, checksum = -(4+1+2+3+4) = 0xF2
  EXPECT_EQ(text, ":0400000001020304F2\n:00000001FF\n");
}

TEST(IntelHex, RoundTripsAFullEepromImage) {
  std::vector<uint8_t> image(4096);
  for (std::size_t i = 0; i < image.size(); ++i) image[i] = static_cast<uint8_t>(i * 37 + 11);
  const auto back = hex::parseIntelHex(hex::formatIntelHex(image), 4096);
  EXPECT_EQ(back, image);
}

TEST(IntelHex, FillsBytesTheFileDoesNotMentionWithErasedValue) {
  const auto image = hex::parseIntelHex(":0100100042AD\n:00000001FF\n", 32);
  EXPECT_EQ(image[0x10], 0x42);
  EXPECT_EQ(image[0x00], 0xFF);
  EXPECT_EQ(image[0x1F], 0xFF);
}

TEST(IntelHex, AcceptsCrlfLineEndsAndExtendedLinearAddressZero) {
  const auto image =
      hex::parseIntelHex(":020000040000FA\r\n:0100000055AA\r\n:00000001FF\r\n", 4);
  EXPECT_EQ(image[0], 0x55);
}

TEST(IntelHex, BinutilsReadsOurImageBackByteForByte) {
  // GNU objcopy's Intel HEX reader is as strict as avrdude's: same records, same checksums.
  const std::string objcopy = SIM_AVR_OBJCOPY;
  if (objcopy.empty()) GTEST_SKIP() << "avr-objcopy not found";
  // given
  std::vector<uint8_t> image(4096);
  for (std::size_t i = 0; i < image.size(); ++i) image[i] = static_cast<uint8_t>(i ^ (i >> 8));
  const std::string hex = std::string(SIM_TEST_TMP) + "/roundtrip.hex";
  const std::string bin = std::string(SIM_TEST_TMP) + "/roundtrip.bin";
  hex::writeIntelHexFile(hex, image);
  // when
  const std::string cmd = objcopy + " -I ihex -O binary " + hex + " " + bin;
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  // then
  std::ifstream in(bin, std::ios::binary);
  const std::vector<uint8_t> back((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(back, image);
}

struct BadHex {
  const char* text;
  const char* message_part;
};

class IntelHexRejects : public ::testing::TestWithParam<BadHex> {};

TEST_P(IntelHexRejects, MalformedInputWithAMessageNamingTheProblem) {
  try {
    hex::parseIntelHex(GetParam().text, 64, "eeprom.hex");
    FAIL() << "accepted: " << GetParam().text;
  } catch (const hex::HexError& e) {
    EXPECT_NE(std::string(e.what()).find(GetParam().message_part), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("eeprom.hex"), std::string::npos) << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(
    Table, IntelHexRejects,
    ::testing::Values(BadHex{":0100000055AB\n:00000001FF\n", "checksum AB is wrong, the record needs AA"},
                      BadHex{"0100000055AA\n:00000001FF\n", "does not start with ':'"},
                      BadHex{":01000000G5AA\n:00000001FF\n", "not a hex byte"},
                      BadHex{":0200000055A9\n:00000001FF\n", "length byte says 2"},
                      BadHex{":01004000556A\n:00000001FF\n", "beyond the 64-byte image"},
                      BadHex{":0100000055AA\n", "no end-of-file record"},
                      BadHex{":00000001FF\n:0100000055AA\n", "after the end-of-file"},
                      // extended linear address FFFF + offset FFFF: 32-bit wrap (issue 8 segfault)
                      BadHex{":02000004FFFFFC\n:01FFFF0042BF\n:00000001FF\n",
                             "data at 0xFFFFFFFF..0xFFFFFFFF lies beyond the 64-byte image"},
                      BadHex{":02000004FFFFFC\n:10FFF000000102030405060708090A0B0C0D0E0F89\n:00000001FF\n",
                             "lies beyond the 64-byte image"},
                      BadHex{":020000021000EC\n:0100000055AA\n:00000001FF\n", "lies beyond"}));

}  // namespace
