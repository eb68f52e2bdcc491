// Serial console helpers shared by both firmware images: the line protocol (docs/console.md)
// over hal::Uart, a tokenizer, number parsing with range checks, and number printing without
// printf (saves ~1.5 KB flash on the AVR).
//
// The line protocol, enforced by LineReader:
//  - a line ends with CR, LF or CRLF; at most kLineMax characters before the line end;
//  - optional checksum suffix *HH: two hex digits (either case), the XOR of every character of
//    the line before the '*' (NMEA 0183 style without the '$'); it is removed before the line
//    is handed on, and checked() says the line carried a good one;
//  - a line is rejected whole, with exactly one "error: " line, when bytes of it were lost or
//    garbled on the way (receive overflow, framing/parity error: hal::Uart::kRxDamaged), it
//    holds a byte that is not text (a control or 8-bit byte: a corrupted character), it is too
//    long, or its checksum is wrong or malformed;
//  - after an abort key (abortLine()) everything up to the next line end is discarded; if that
//    was more than nothing, one error line says so;
//  - strict mode (strict on|off): commands that can spin a motor or write the EEPROM are
//    refused unless their line carried a valid checksum (checked(); the shell's kCmdGuarded
//    rows, shell.hpp).
#pragma once
#include <stdint.h>

#include "thrustcal/flash_text.hpp"

namespace fw {

constexpr uint8_t kLineMax = 48;  // characters per command line, without terminator

enum class LineEvent : uint8_t {
  kNone = 0,  // nothing complete yet
  kLine,      // a complete, intact line is in line() (checksum suffix removed)
  kRejected,  // a line was rejected whole; its one error line is printed (reject() says why)
};

enum class Reject : uint8_t {
  kNone = 0,
  kDamaged,       // bytes lost or garbled in transit (overflow, overrun, framing, parity)
  kNotText,       // a control or 8-bit byte in the line
  kTooLong,       // more than kLineMax characters
  kBadChecksum,   // *HH present but does not match
  kMalformedChecksum,  // '*' not followed by exactly two hex digits at the end
  kAbortedRest,   // the rest of a line whose first key aborted a sweep or lift-off
};

class LineReader {
 public:
  // Consumes received bytes (non-blocking) until a line is complete, nothing is left, or
  // max_bytes were consumed (bounds the work of one main-loop pass).
  LineEvent poll(uint8_t max_bytes = 255);
  // Feeds one received item (a byte, or hal::Uart::kRxDamaged); what poll() does per item.
  // Echoes printable characters, handles backspace (0x08, 0x7F); a tab counts as a space.
  LineEvent feed(int16_t item);
  // The last complete line (valid until the next byte is fed). Mutable so it can be
  // tokenized in place.
  const char* line() const { return buffer_; }
  char* line() { return buffer_; }
  // Whether the last line carried a valid checksum, and why the last line was rejected.
  bool checked() const { return (flags_ & kChecked) != 0; }
  Reject reject() const { return reject_; }
  // Forgets a partial line (and any discard in progress).
  void clear();
  // `key` (a received item) aborted a sweep or lift-off: forget the partial line and discard
  // everything up to the next line end (nothing more if `key` was itself a line end).
  void abortLine(int16_t key);
  bool discarding() const { return (flags_ & kDiscarding) != 0; }

  // Strict mode.
  bool strict() const { return (flags_ & kStrict) != 0; }
  void setStrict(bool on);
  // `strict on` / `strict off` already parsed: sets the mode and prints the reply line.
  void strictCommand(bool on);

  // Lines rejected since start-up (status).
  uint16_t rejectedLines() const { return rejected_; }

 private:
  static constexpr uint8_t kOverflow = 0x01;    // beyond recovery by backspace
  static constexpr uint8_t kLastWasCr = 0x02;
  static constexpr uint8_t kDamagedLine = 0x04;
  static constexpr uint8_t kNotTextLine = 0x08;
  static constexpr uint8_t kDiscarding = 0x10;
  static constexpr uint8_t kChecked = 0x20;
  static constexpr uint8_t kStrict = 0x40;

  LineEvent endLine();
  LineEvent rejectLine(Reject why);
  Reject checkChecksum();  // strips a good suffix, sets kChecked

  char buffer_[kLineMax + 1] = {};
  uint8_t length_ = 0;      // typed characters (saturates at 255)
  uint8_t flags_ = 0;
  uint8_t bad_byte_ = 0;    // the first non-text byte of the line, and its column
  uint8_t bad_column_ = 0;
  uint8_t given_sum_ = 0;   // kBadChecksum: what the line said and what it should have said
  uint8_t wanted_sum_ = 0;
  Reject reject_ = Reject::kNone;
  uint16_t rejected_ = 0;
};

// Splits `line` in place on spaces; returns the number of tokens (at most max_tokens; any
// further tokens are ignored, so pass one slot more than a command takes to detect extras).
uint8_t tokenize(char* line, char** tokens, uint8_t max_tokens);

// Parses a whole token as a decimal integer in [min, max]. False (value untouched) on an
// empty token, a stray character, or out of range.
bool parseInt(const char* token, int32_t min, int32_t max, int32_t& value);

// Case-sensitive string equality (RAM vs flash text made with TC_FLASH_TEXT).
bool equalsP(const char* ram, const char* progmem);

// Printing on hal::Uart.
void printInt(int32_t value);
void printUint(uint32_t value);
// value / 10^decimals with exactly `decimals` digits after the point: printFixed(11350, 3)
// prints "11.350"; printFixed(-5, 1) prints "-0.5".
void printFixed(int32_t value, uint8_t decimals);
// printFixed for a 16-bit value, with no 32-bit division (a few hundred cycles instead of
// thousands on the AVR: fly prints 50 stream rows a second beside a 400 Hz loop).
void printFixed16(int16_t value, uint8_t decimals);
// printFixed16's text into `out` (at least kFixed16Chars + 1 bytes), '\0'-terminated; returns
// the terminator's address, so a row of numbers is built in one buffer and printed at once.
constexpr uint8_t kFixed16Chars = 7;  // "-3.2768", "-32768"
char* formatFixed16(char* out, int16_t value, uint8_t decimals);
void printHex2(uint8_t value);  // two upper-case hex digits
void newline();  // "\r\n"
// The print helpers both apps' console views use (one copy, here).
void say(const char* progmem_text);      // a flash text (TC_FLASH_TEXT), no line end
void sayLine(const char* progmem_text);  // the same and "\r\n"
void sayVolts(uint16_t mv);              // 11350 -> "11.350 V"
void sayCopy(uint8_t copy);              // 0 -> "copy A", 1 -> "copy B" (v2 record copies)

// Boot and status lines shared by both images (docs/safety.md):
//   "reset: watchdog" (power-on, external, brown-out, JTAG; several comma-separated)
void printResetCause();
//   "stack: 1234 of 2086 bytes never used; strict off; 0 lines rejected"
// `yield` is passed to hal::Stack::untouchedBytes (its scan takes about 1.5 ms).
void printHealth(const LineReader& reader, void (*yield)() = nullptr);
//   "D6 (PH3, OC4A)": where ESC `channel` is wired, from the board table (hal/board.hpp)
void printEscPin(uint8_t channel);

}  // namespace fw
