// Shared console helpers: the line protocol (docs/console.md), tokenizer, integer parsing,
// number printing.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "console.hpp"
#include "hal/fake.hpp"
#include "hal/hal.hpp"

namespace {

class Console : public ::testing::Test {
 protected:
  void SetUp() override { hal::fake::reset(); }
  void TearDown() override { hal::fake::reset(); }

  // Feeds `text` byte by byte; returns the events other than kNone with the line at that time.
  std::vector<std::pair<fw::LineEvent, std::string>> feedAll(fw::LineReader& reader,
                                                             const std::string& text) {
    std::vector<std::pair<fw::LineEvent, std::string>> events;
    for (char c : text) {
      const fw::LineEvent ev = reader.feed(static_cast<uint8_t>(c));
      if (ev != fw::LineEvent::kNone) events.push_back({ev, reader.line()});
    }
    return events;
  }
  // Lines of the output that start with "error: ".
  static int errorLines(const std::string& out) {
    int n = 0;
    for (std::size_t pos = 0; (pos = out.find("error: ", pos)) != std::string::npos; ++pos) ++n;
    return n;
  }
};

using Events = std::vector<std::pair<fw::LineEvent, std::string>>;
constexpr fw::LineEvent kLine = fw::LineEvent::kLine;
constexpr fw::LineEvent kRejected = fw::LineEvent::kRejected;

struct LineRow {
  const char* name;
  std::string input;
  Events expected;
};

TEST_F(Console, LineReaderEndsLinesOnCrLfOrCrLfAndHandlesEditing) {
  const LineRow rows[] = {
      {"CR", "help\r", {{kLine, "help"}}},
      {"LF", "help\n", {{kLine, "help"}}},
      {"CRLF is one line end", "a\r\nb\r\n", {{kLine, "a"}, {kLine, "b"}}},
      {"LF CR is two", "a\n\r", {{kLine, "a"}, {kLine, ""}}},
      {"empty line", "\r", {{kLine, ""}}},
      {"backspace", "hx\blp\r", {{kLine, "hlp"}}},
      {"delete key", "ab\x7f\x7f\x7f" "c\r", {{kLine, "c"}}},
      {"tab is a space", "motor\t2\r", {{kLine, "motor 2"}}},
      {"a control byte rejects the line", "a\x01\x1b" "b\r", {{kRejected, ""}}},
      {"an 8-bit byte rejects the line", "f 1 3\xe5" "7\r", {{kRejected, ""}}},
      {"the next line is fine again", "a\x01\rok\r", {{kRejected, ""}, {kLine, "ok"}}},
  };
  for (const auto& row : rows) {
    fw::LineReader reader;
    EXPECT_EQ(feedAll(reader, row.input), row.expected) << row.name;
  }
}

TEST_F(Console, LineReaderAcceptsExactlyKLineMaxCharacters) {
  fw::LineReader reader;
  const std::string longest(fw::kLineMax, 'x');
  EXPECT_EQ(feedAll(reader, longest + "\r"), (Events{{kLine, longest}}));
}

TEST_F(Console, LineReaderRejectsAnOverLongLineWholeAndRecoversOnTheNextLine) {
  // given
  fw::LineReader reader;
  const std::string too_long(fw::kLineMax + 1, 'y');
  // when
  const Events events = feedAll(reader, too_long + "\rtare\r");
  // then: one rejection (too long) with nothing usable in line(), then the next line intact
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].first, kRejected);
  EXPECT_EQ(events[0].second, "");
  EXPECT_EQ(events[1], (std::pair<fw::LineEvent, std::string>{kLine, "tare"}));
}

TEST_F(Console, LineReaderBackspacingUnderTheLimitRecoversTheLine) {
  fw::LineReader reader;
  const std::string text = std::string(fw::kLineMax, 'a') + "bc\b\b\r";
  EXPECT_EQ(feedAll(reader, text), (Events{{kLine, std::string(fw::kLineMax, 'a')}}));
}

TEST_F(Console, LineReaderOverflowPast255TypedCharactersStaysTooLong) {
  fw::LineReader reader;
  std::string text(300, 'z');
  text += std::string(300, '\b');
  text += "\r";
  EXPECT_EQ(feedAll(reader, text), (Events{{kRejected, ""}}));
  EXPECT_EQ(reader.reject(), fw::Reject::kTooLong);
}

TEST_F(Console, LineReaderEchoesTypingBackspaceAndLineEnd) {
  fw::LineReader reader;
  feedAll(reader, "ab\b\r\n");
  EXPECT_EQ(hal::fake::output(), "ab\b \b\r\n");
}

TEST_F(Console, LineReaderBackspaceOnAnEmptyLineEchoesNothing) {
  fw::LineReader reader;
  feedAll(reader, "\b\x7f");
  EXPECT_EQ(hal::fake::output(), "");
}

TEST_F(Console, PollReadsTheUartUpToTheFirstCompleteLineAndLeavesTheRest) {
  // given
  fw::LineReader reader;
  hal::fake::feedInput("motor 1\rtare\r");
  // when / then
  EXPECT_EQ(reader.poll(), kLine);
  EXPECT_STREQ(reader.line(), "motor 1");
  EXPECT_EQ(reader.poll(), kLine);
  EXPECT_STREQ(reader.line(), "tare");
  EXPECT_EQ(reader.poll(), fw::LineEvent::kNone);
}

TEST_F(Console, PollWithAPartialLineReturnsNoneAndKeepsIt) {
  fw::LineReader reader;
  hal::fake::feedInput("sw");
  EXPECT_EQ(reader.poll(), fw::LineEvent::kNone);
  hal::fake::feedInput("eep\n");
  EXPECT_EQ(reader.poll(), kLine);
  EXPECT_STREQ(reader.line(), "sweep");
}

TEST_F(Console, ClearForgetsAPartialLine) {
  fw::LineReader reader;
  feedAll(reader, "xyz");
  reader.clear();
  EXPECT_EQ(feedAll(reader, "ok\r"), (Events{{kLine, "ok"}}));
}

// ---------------------------------------------------------------------------------------------
// The line protocol: damage, checksum, strict mode, aborts

TEST_F(Console, ADamageMarkRejectsItsWholeLineWithOneErrorAndTheNextLineIsFine) {
  // given: "f 1 37" with bytes lost after "f 1" (what the AVR receiver reports on overflow)
  fw::LineReader reader;
  hal::fake::feedInput("f 1");
  hal::fake::feedDamage();
  hal::fake::feedInput("7\rstatus\r");
  // when
  const fw::LineEvent first = reader.poll();
  const std::string out = hal::fake::output();
  const fw::LineEvent second = reader.poll();
  // then
  EXPECT_EQ(first, kRejected);
  EXPECT_EQ(reader.reject(), fw::Reject::kNone);  // the second line was fine
  EXPECT_EQ(second, kLine);
  EXPECT_STREQ(reader.line(), "status");
  EXPECT_EQ(errorLines(out), 1) << out;
  EXPECT_NE(out.find("error: line damaged in transit"), std::string::npos) << out;
  EXPECT_EQ(reader.rejectedLines(), 1u);
}

TEST_F(Console, ADamageMarkBetweenLinesRejectsTheLineAfterIt) {
  // The lost bytes may have held the start of the next line: it is not executed.
  fw::LineReader reader;
  hal::fake::feedInput("a\r");
  hal::fake::feedDamage();
  hal::fake::feedInput("1 37\r");
  EXPECT_EQ(reader.poll(), kLine);
  EXPECT_STREQ(reader.line(), "a");
  EXPECT_EQ(reader.poll(), kRejected);
  EXPECT_EQ(reader.reject(), fw::Reject::kDamaged);
}

struct ChecksumRow {
  const char* name;
  std::string input;
  fw::LineEvent event;
  std::string line;
  bool checked;
  fw::Reject reject;
};

TEST_F(Console, AChecksumSuffixIsVerifiedAndRemoved) {
  // "f 1 37": XOR = 0x66 ^ 0x20 ^ 0x31 ^ 0x20 ^ 0x33 ^ 0x37 = 0x53; "f 9": 0x7F
  const ChecksumRow rows[] = {
      {"good", "f 1 37*53\r", kLine, "f 1 37", true, fw::Reject::kNone},
      {"good, upper case", "f 9*7F\r", kLine, "f 9", true, fw::Reject::kNone},
      {"good, lower case", "f 9*7f\r", kLine, "f 9", true, fw::Reject::kNone},
      {"empty line *00", "*00\r", kLine, "", true, fw::Reject::kNone},
      {"no checksum", "f 1 37\r", kLine, "f 1 37", false, fw::Reject::kNone},
      {"wrong", "f 1 37*54\r", kRejected, "", false, fw::Reject::kBadChecksum},
      {"a digit changed in transit", "f 1 77*53\r", kRejected, "", false, fw::Reject::kBadChecksum},
      {"one digit", "f 1 37*5\r", kRejected, "", false, fw::Reject::kMalformedChecksum},
      {"three digits", "f 1 37*530\r", kRejected, "", false, fw::Reject::kMalformedChecksum},
      {"not hex", "f 1 37*5G\r", kRejected, "", false, fw::Reject::kMalformedChecksum},
      {"star alone", "f*\r", kRejected, "", false, fw::Reject::kMalformedChecksum},
  };
  for (const auto& row : rows) {
    SCOPED_TRACE(row.name);
    hal::fake::takeOutput();
    fw::LineReader reader;
    const Events events = feedAll(reader, row.input);
    ASSERT_EQ(events.size(), 1u);
    EXPECT_EQ(events[0].first, row.event);
    EXPECT_EQ(events[0].second, row.line);
    EXPECT_EQ(reader.checked(), row.checked);
    EXPECT_EQ(reader.reject(), row.reject);
    EXPECT_EQ(errorLines(hal::fake::output()), row.event == kRejected ? 1 : 0) << hal::fake::output();
  }
}

TEST_F(Console, AWrongChecksumSaysWhatTheLineShouldHaveCarried) {
  fw::LineReader reader;
  feedAll(reader, "f 1 37*54\r");
  EXPECT_NE(hal::fake::output().find("error: checksum *54 does not match the line (*53)"),
            std::string::npos)
      << hal::fake::output();
}

TEST_F(Console, StrictCommandSetsTheModeAndSaysWhatItMeans) {
  // given
  fw::LineReader reader;
  // when / then: on, with the reply naming the checksum; a checksummed line says so
  reader.strictCommand(true);
  ASSERT_TRUE(reader.strict());
  EXPECT_NE(hal::fake::takeOutput().find("strict on: commands that spin a motor"),
            std::string::npos);
  feedAll(reader, "f 1 37\r");
  EXPECT_FALSE(reader.checked());
  feedAll(reader, "f 1 37*53\r");
  EXPECT_TRUE(reader.checked());
  // off again
  reader.strictCommand(false);
  EXPECT_FALSE(reader.strict());
  EXPECT_NE(hal::fake::takeOutput().find("strict off: checksums optional"), std::string::npos);
}

TEST_F(Console, AfterAnAbortKeyTheRestOfItsLineIsDiscardedWithOneError) {
  // given: "xerase" arrives while a sweep runs; the sweep consumed the "x" and aborted
  fw::LineReader reader;
  reader.abortLine('x');
  // when
  const Events events = feedAll(reader, "erase\rshow\r");
  // then: "erase" is never a line; the error says what happened; "show" is a line again
  EXPECT_EQ(events, (Events{{kRejected, ""}, {kLine, "show"}}));
  EXPECT_EQ(errorLines(hal::fake::output()), 1);
  EXPECT_NE(hal::fake::output().find("ignored the rest of the line whose first key aborted (5"),
            std::string::npos)
      << hal::fake::output();
}

TEST_F(Console, AnAbortKeyThatEndsItsLineDiscardsNothingMore) {
  const struct {
    int16_t key;
    const char* then;
    Events expected;
  } rows[] = {
      {'\r', "\nshow\r", {{kLine, "show"}}},  // the LF of its CRLF belongs to it
      {'\n', "show\r", {{kLine, "show"}}},
      {'x', "\rshow\r", {{kLine, "show"}}},     // "x" then Enter: nothing to report
  };
  for (const auto& row : rows) {
    fw::LineReader reader;
    reader.abortLine(row.key);
    EXPECT_EQ(feedAll(reader, row.then), row.expected) << row.key;
    EXPECT_EQ(errorLines(hal::fake::output()), 0);
  }
}

TEST_F(Console, PollHandlesAtMostMaxBytesPerCall) {
  fw::LineReader reader;
  hal::fake::feedInput("status\r");
  EXPECT_EQ(reader.poll(4), fw::LineEvent::kNone);  // "stat"
  EXPECT_EQ(reader.poll(4), kLine);                 // "us\r"
  EXPECT_STREQ(reader.line(), "status");
}

TEST_F(Console, ResetCauseNamesEveryFlagSet) {
  const struct {
    uint8_t flags;
    const char* text;
  } rows[] = {
      {hal::Watchdog::kWatchdog, "reset: watchdog (the program hung; motors were stopped)\r\n"},
      {hal::Watchdog::kWatchdog | hal::Watchdog::kWasRunning,
       "reset: watchdog (the program hung; motors were stopped)\r\n"},
      {hal::Watchdog::kWasRunning,
       "reset: watchdog or external while running (a bootloader cleared the reset flags)\r\n"},
      {hal::Watchdog::kBrownOut, "reset: brown-out (the supply dipped; check the 5 V supply)\r\n"},
      {hal::Watchdog::kExternal, "reset: external\r\n"},
      {hal::Watchdog::kPowerOn, "reset: power-on\r\n"},
      {hal::Watchdog::kPowerOn | hal::Watchdog::kBrownOut,
       "reset: brown-out, power-on (the supply dipped; check the 5 V supply)\r\n"},
      {0, "reset: power-on or external (a bootloader cleared the reset flags)\r\n"},
  };
  for (const auto& row : rows) {
    hal::fake::takeOutput();
    hal::fake::setResetFlags(row.flags);
    fw::printResetCause();
    EXPECT_EQ(hal::fake::output(), row.text) << int(row.flags);
  }
}

TEST_F(Console, HealthLineReportsTheStackHeadroomAndTheConsole) {
  fw::LineReader reader;
  feedAll(reader, "a\x01\r");
  hal::fake::takeOutput();
  hal::fake::setStack(2086, 1042);
  fw::printHealth(reader);
  EXPECT_EQ(hal::fake::output(), "stack: 1042 of 2086 bytes never used; strict off; 1 lines rejected\r\n");
}

struct TokenRow {
  std::string line;
  uint8_t max_tokens;
  std::vector<std::string> expected;
};

TEST_F(Console, TokenizeSplitsOnRunsOfSpacesUpToTheLimit) {
  const TokenRow rows[] = {
      {"", 4, {}},
      {"   ", 4, {}},
      {"help", 4, {"help"}},
      {"range 1000 1800", 4, {"range", "1000", "1800"}},
      {"  range   1000  1800  ", 4, {"range", "1000", "1800"}},
      {"a b c d e", 3, {"a", "b", "c"}},
  };
  for (const auto& row : rows) {
    std::string buffer = row.line;
    char* tokens[8] = {};
    const uint8_t n = fw::tokenize(buffer.data(), tokens, row.max_tokens);
    std::vector<std::string> got(tokens, tokens + n);
    EXPECT_EQ(got, row.expected) << "'" << row.line << "'";
  }
}

struct ParseRow {
  const char* token;
  int32_t min;
  int32_t max;
  bool ok;
  int32_t value;
};

TEST_F(Console, ParseIntAcceptsWholeDecimalTokensInRangeOnly) {
  const ParseRow rows[] = {
      {"0", 0, 3, true, 0},
      {"3", 0, 3, true, 3},
      {"4", 0, 3, false, -99},
      {"-1", 0, 3, false, -99},
      {"-1", -5, 5, true, -1},
      {"+7", 0, 10, true, 7},
      {"007", 0, 10, true, 7},
      {"", 0, 10, false, -99},
      {"-", -10, 10, false, -99},
      {"+", -10, 10, false, -99},
      {"12a", 0, 100, false, -99},
      {"1.5", 0, 100, false, -99},
      {" 1", 0, 100, false, -99},
      {"2147483647", -2147483647 - 1, 2147483647, true, 2147483647},
      {"-2147483648", -2147483647 - 1, 2147483647, true, -2147483647 - 1},
      {"2147483648", -2147483647 - 1, 2147483647, false, -99},
      {"-2147483649", -2147483647 - 1, 2147483647, false, -99},
      {"99999999999999999999", 0, 2147483647, false, -99},
  };
  for (const auto& row : rows) {
    int32_t value = -99;
    EXPECT_EQ(fw::parseInt(row.token, row.min, row.max, value), row.ok) << "'" << row.token << "'";
    EXPECT_EQ(value, row.value) << "'" << row.token << "' (untouched on failure)";
  }
}

TEST_F(Console, ParseIntOfNullIsFalse) {
  int32_t value = 5;
  EXPECT_FALSE(fw::parseInt(nullptr, 0, 10, value));
  EXPECT_EQ(value, 5);
}

TEST_F(Console, EqualsPComparesWholeStringsCaseSensitively) {
  EXPECT_TRUE(fw::equalsP("sweep", TC_FLASH_TEXT("sweep")));
  EXPECT_TRUE(fw::equalsP("", TC_FLASH_TEXT("")));
  EXPECT_FALSE(fw::equalsP("swee", TC_FLASH_TEXT("sweep")));
  EXPECT_FALSE(fw::equalsP("sweeps", TC_FLASH_TEXT("sweep")));
  EXPECT_FALSE(fw::equalsP("Sweep", TC_FLASH_TEXT("sweep")));
}

struct IntPrintRow {
  int32_t value;
  const char* text;
};

TEST_F(Console, PrintIntPrintsEveryInt32) {
  const IntPrintRow rows[] = {
      {0, "0"}, {7, "7"}, {-7, "-7"}, {1000, "1000"}, {2147483647, "2147483647"},
      {-2147483647 - 1, "-2147483648"},
  };
  for (const auto& row : rows) {
    hal::fake::takeOutput();
    fw::printInt(row.value);
    EXPECT_EQ(hal::fake::output(), row.text);
  }
}

TEST_F(Console, PrintUintPrintsTheFullRange) {
  fw::printUint(4294967295u);
  hal::Uart::write(' ');
  fw::printUint(0);
  EXPECT_EQ(hal::fake::output(), "4294967295 0");
}

struct FixedRow {
  int32_t value;
  uint8_t decimals;
  const char* text;
};

TEST_F(Console, PrintFixedPrintsExactlyTheRequestedDecimals) {
  const FixedRow rows[] = {
      {11350, 3, "11.350"}, {-5, 1, "-0.5"},  {5, 3, "0.005"},   {0, 2, "0.00"},
      {-1234, 2, "-12.34"}, {42, 0, "42"},    {-42, 0, "-42"},   {1000, 3, "1.000"},
      {-2147483647 - 1, 3, "-2147483.648"},
  };
  for (const auto& row : rows) {
    hal::fake::takeOutput();
    fw::printFixed(row.value, row.decimals);
    EXPECT_EQ(hal::fake::output(), row.text) << row.value << " / 10^" << int(row.decimals);
  }
}

TEST_F(Console, PrintFixed16PrintsWhatPrintFixedPrintsOverTheWholeSixteenBitRange) {
  const FixedRow rows[] = {
      {0, 0, "0"},        {0, 2, "0.00"},         {-5, 1, "-0.5"},       {7, 3, "0.007"},
      {12345, 2, "123.45"}, {-1234, 1, "-123.4"}, {32767, 0, "32767"},   {-32768, 2, "-327.68"},
      {100, 0, "100"},    {10000, 4, "1.0000"},   {-1, 4, "-0.0001"},
  };
  for (const auto& row : rows) {
    hal::fake::takeOutput();
    fw::printFixed16(static_cast<int16_t>(row.value), row.decimals);
    EXPECT_EQ(hal::fake::output(), row.text) << row.value << " / 10^" << int(row.decimals);
  }
  for (int32_t v = -32768; v <= 32767; v += 97) {  // and against printFixed itself
    for (uint8_t d = 0; d <= 4; ++d) {
      hal::fake::takeOutput();
      fw::printFixed(v, d);
      const std::string wide = hal::fake::takeOutput();
      fw::printFixed16(static_cast<int16_t>(v), d);
      ASSERT_EQ(hal::fake::takeOutput(), wide) << v << " / 10^" << int(d);
    }
  }
}

TEST_F(Console, NewlineIsCrLf) {
  fw::newline();
  EXPECT_EQ(hal::fake::output(), "\r\n");
}

}  // namespace

TEST(BoardPins, EachEscPinIsNamedFromTheBoardTable) {
  hal::fake::reset();
  const char* names[] = {"D6 (PH3, OC4A)", "D7 (PH4, OC4B)", "D8 (PH5, OC4C)", "D11 (PB5, OC1A)"};
  for (uint8_t ch = 0; ch < hal::kEscChannels; ++ch) {
    fw::printEscPin(ch);
    EXPECT_EQ(hal::fake::takeOutput(), names[ch]) << int(ch);
    EXPECT_EQ(hal::escArduinoPin(ch), hal::kEscPins[ch].arduino_pin);
  }
  fw::printEscPin(hal::kEscChannels);
  EXPECT_EQ(hal::fake::takeOutput(), "") << "no such channel: nothing";
  EXPECT_EQ(hal::escArduinoPin(hal::kEscChannels), 0xFF);
}
