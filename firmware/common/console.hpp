// Serial console helpers shared by both firmware images: a line editor over hal::Uart
// (echo, backspace, CR/LF/CRLF, over-long lines rejected whole), a tokenizer, number parsing
// with range checks, and number printing without printf (saves ~1.5 KB flash on the AVR).
#pragma once
#include <stdint.h>

namespace fw {

constexpr uint8_t kLineMax = 48;  // characters per command line, without terminator

enum class LineEvent : uint8_t {
  kNone = 0,   // nothing complete yet
  kLine,       // a complete line is in line()
  kTooLong,    // the line overflowed; it was discarded whole (error already decided by caller)
};

class LineReader {
 public:
  // Consumes received bytes (non-blocking) until a line is complete or nothing is left.
  // Echoes printable characters, handles backspace (0x08, 0x7F) and ends a line on CR, LF or
  // CRLF (the LF of a CRLF is swallowed). A tab counts as a space; other control bytes are
  // ignored. A line longer than kLineMax is discarded whole and reported as kTooLong once
  // its end arrives.
  LineEvent poll();
  // Feeds one byte (what poll() does per received byte); exposed for tests.
  LineEvent feed(uint8_t byte);
  // The last complete line (valid until the next byte is fed). Mutable so it can be
  // tokenized in place.
  const char* line() const { return buffer_; }
  char* line() { return buffer_; }
  // Forgets a partial line (e.g. after a sweep ends, so keys that aborted it do not linger).
  void clear();

 private:
  char buffer_[kLineMax + 1] = {};
  uint8_t length_ = 0;
  bool overflow_ = false;
  bool last_was_cr_ = false;
};

// Splits `line` in place on spaces; returns the number of tokens (at most max_tokens; any
// further tokens are ignored, so pass one slot more than a command takes to detect extras).
uint8_t tokenize(char* line, char** tokens, uint8_t max_tokens);

// Parses a whole token as a decimal integer in [min, max]. False (value untouched) on an
// empty token, a stray character, or out of range.
bool parseInt(const char* token, int32_t min, int32_t max, int32_t& value);

// Case-sensitive string equality (RAM vs PROGMEM literal made with TC_PSTR).
bool equalsP(const char* ram, const char* progmem);

// Printing on hal::Uart.
void printInt(int32_t value);
void printUint(uint32_t value);
// value / 10^decimals with exactly `decimals` digits after the point: printFixed(11350, 3)
// prints "11.350"; printFixed(-5, 1) prints "-0.5".
void printFixed(int32_t value, uint8_t decimals);
void newline();  // "\r\n"

}  // namespace fw
