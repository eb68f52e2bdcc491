// `eeprom crc` and `eeprom dump` (firmware/common/eeprom_console) on the fake HAL: the exact
// line formats of TEAM.md, checked against the host's CRC and Intel HEX parser.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cstring>
#include <string>
#include <vector>

#include "eeprom_console.hpp"
#include "hal/fake.hpp"
#include "hal/hal.hpp"
#include "hex/intel_hex.hpp"
#include "text_match.hpp"
#include "thrustcal/crc16.hpp"

namespace {

class EepromConsole : public ::testing::Test {
 protected:
  void SetUp() override { hal::fake::reset(); }
  void TearDown() override { hal::fake::reset(); }

  // Runs `eeprom crc` or `eeprom dump` (the table rows' handlers); returns what it printed.
  // Argument errors are the shell's (test_shell, and each image's command tests).
  std::string run(const std::string& line) {
    hal::fake::takeOutput();
    if (line == "eeprom crc") {
      fw::eepromCrc();
    } else if (line == "eeprom dump") {
      fw::eepromDump();
    } else {
      ADD_FAILURE() << "not an eeprom command: " << line;
    }
    return hal::fake::takeOutput();
  }

  void fill(uint8_t (*value)(uint16_t)) {
    for (uint16_t a = 0; a < hal::Eeprom::kSize; ++a) hal::fake::eeprom()[a] = value(a);
  }
  std::vector<uint8_t> image() const {
    return std::vector<uint8_t>(hal::fake::eeprom(), hal::fake::eeprom() + hal::Eeprom::kSize);
  }
};

std::string expectedCrcLine(const std::vector<uint8_t>& img) {
  std::string line = "eeprom crc";
  for (int s = 0; s < 4; ++s)
    line += fmt::format(" slot{} {:04X}", s, tc::crc16CcittFalse(img.data() + s * 1024, 1024));
  return line + fmt::format(" all {:04X}\r\n", tc::crc16CcittFalse(img.data(), 4096));
}

TEST_F(EepromConsole, CrcLineGivesEachSlotAndTheWholeImageInUpperCaseHex) {
  // given: erased, then a pattern that differs in every slot
  EXPECT_EQ(run("eeprom crc"), expectedCrcLine(image()));
  fill([](uint16_t a) { return static_cast<uint8_t>(a * 7 + (a >> 10)); });
  // when / then
  const std::string out = run("eeprom crc");
  EXPECT_EQ(out, expectedCrcLine(image()));
  EXPECT_TRUE(tc::test::Pattern("eeprom crc slot0 [0-9A-F]{4} slot1 [0-9A-F]{4} slot2 [0-9A-F]{4} "
                                "slot3 [0-9A-F]{4} all [0-9A-F]{4}\r\n")
                  .matches(out))
      << out;
}

TEST_F(EepromConsole, CrcOfAnErasedSlotIsTheCrcOf1024BytesOf0xFF) {
  const std::vector<uint8_t> ff(1024, 0xFF);
  const std::string slot = fmt::format("slot2 {:04X}", tc::crc16CcittFalse(ff.data(), 1024));
  EXPECT_NE(run("eeprom crc").find(slot), std::string::npos);
}

TEST_F(EepromConsole, DumpIsIntelHexThatParsesBackToEveryByte) {
  // given: every address holds a value that tells it from its neighbours and its double
  fill([](uint16_t a) { return static_cast<uint8_t>((a & 0xFF) ^ ((a >> 8) * 0x1D)); });
  // when
  const std::string out = run("eeprom dump");
  // then: 256 records of 16 bytes and the end record, CRLF line ends, parsed by the host
  EXPECT_EQ(out.substr(0, 9), ":10000000");
  EXPECT_NE(out.find("\r\n:100FF000"), std::string::npos);
  EXPECT_EQ(out.substr(out.size() - 13), ":00000001FF\r\n");
  std::size_t records = 0;
  for (std::size_t at = out.find(':'); at != std::string::npos; at = out.find(':', at + 1)) ++records;
  EXPECT_EQ(records, 257u);
  EXPECT_EQ(hex::parseIntelHex(out, 4096, "dump", 0x00), image());
  EXPECT_EQ(hex::parseIntelHex(out, 4096, "dump", 0xFF), image());  // every byte given
}

TEST_F(EepromConsole, DumpAndCrcOnlyReadTheEeprom) {
  fill([](uint16_t a) { return static_cast<uint8_t>(a); });
  hal::fake::resetEepromWrites();
  run("eeprom dump");
  run("eeprom crc");
  EXPECT_EQ(hal::fake::eepromWrites(), 0u);
}

TEST_F(EepromConsole, BetweenRecordsHookRunsOncePerRecord) {
  static int calls;
  calls = 0;
  fw::eepromDump([] { ++calls; });
  EXPECT_EQ(calls, 256);
}

}  // namespace
