// Shared console helpers: line editor, tokenizer, integer parsing, number printing.
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
};

using Events = std::vector<std::pair<fw::LineEvent, std::string>>;
constexpr fw::LineEvent kLine = fw::LineEvent::kLine;
constexpr fw::LineEvent kTooLong = fw::LineEvent::kTooLong;

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
      {"control bytes ignored", "a\x01\x1b" "b\r", {{kLine, "ab"}}},
      {"8-bit bytes ignored", "a\xe5z\r", {{kLine, "az"}}},
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
  // then: one kTooLong with nothing usable in line(), then the next line intact
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].first, kTooLong);
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
  EXPECT_EQ(feedAll(reader, text), (Events{{kTooLong, ""}}));
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
  EXPECT_TRUE(fw::equalsP("sweep", TC_PSTR("sweep")));
  EXPECT_TRUE(fw::equalsP("", TC_PSTR("")));
  EXPECT_FALSE(fw::equalsP("swee", TC_PSTR("sweep")));
  EXPECT_FALSE(fw::equalsP("sweeps", TC_PSTR("sweep")));
  EXPECT_FALSE(fw::equalsP("Sweep", TC_PSTR("sweep")));
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

TEST_F(Console, NewlineIsCrLf) {
  fw::newline();
  EXPECT_EQ(hal::fake::output(), "\r\n");
}

}  // namespace
