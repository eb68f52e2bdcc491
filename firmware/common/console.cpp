// Serial console helpers shared by gather_store and read_run (see console.hpp).
#include "console.hpp"

#include "hal/hal.hpp"

#ifdef __AVR__
#include <avr/pgmspace.h>
#define TC_READ_PROGMEM_BYTE(p) pgm_read_byte(p)
#else
#define TC_READ_PROGMEM_BYTE(p) (*(p))
#endif

namespace fw {

namespace {
constexpr uint8_t kBackspace = 0x08;
constexpr uint8_t kDelete = 0x7F;
constexpr uint8_t kLengthCap = 255;  // typed-length counter saturates here (sticky overflow)
// avr-libc hides INT32_MIN from C++ unless __STDC_LIMIT_MACROS is set before stdint.h.
constexpr int32_t kInt32Min = -2147483647 - 1;
}  // namespace

// length_ counts what the user typed (minus backspaces), even past kLineMax; only the first
// kLineMax characters are stored. Backspacing back under the limit therefore recovers a valid
// line exactly: the characters beyond the buffer were the ones deleted first.
LineEvent LineReader::feed(uint8_t byte) {
  const bool after_cr = last_was_cr_;
  last_was_cr_ = (byte == '\r');
  if (byte == '\r' || byte == '\n') {
    if (byte == '\n' && after_cr) return LineEvent::kNone;  // LF of a CRLF
    newline();
    const bool too_long = overflow_ || length_ > kLineMax;
    buffer_[too_long ? 0 : length_] = '\0';
    length_ = 0;
    overflow_ = false;
    return too_long ? LineEvent::kTooLong : LineEvent::kLine;
  }
  if (byte == kBackspace || byte == kDelete) {
    if (length_ > 0 && !overflow_) {
      --length_;
      if (length_ < kLineMax) buffer_[length_] = '\0';
      hal::Uart::write(kBackspace);
      hal::Uart::write(' ');
      hal::Uart::write(kBackspace);
    }
    return LineEvent::kNone;
  }
  if (byte == '\t') byte = ' ';
  if (byte < 0x20 || byte > 0x7E) return LineEvent::kNone;  // other control or 8-bit bytes
  if (length_ == kLengthCap) {
    overflow_ = true;  // beyond any recovery by backspace
    return LineEvent::kNone;
  }
  if (length_ < kLineMax) {
    buffer_[length_] = static_cast<char>(byte);
    buffer_[length_ + 1] = '\0';
  }
  ++length_;
  hal::Uart::write(byte);
  return LineEvent::kNone;
}

LineEvent LineReader::poll() {
  while (hal::Uart::available()) {
    const int16_t byte = hal::Uart::read();
    if (byte < 0) break;
    const LineEvent event = feed(static_cast<uint8_t>(byte));
    if (event != LineEvent::kNone) return event;
  }
  return LineEvent::kNone;
}

void LineReader::clear() {
  buffer_[0] = '\0';
  length_ = 0;
  overflow_ = false;
  last_was_cr_ = false;
}

uint8_t tokenize(char* line, char** tokens, uint8_t max_tokens) {
  uint8_t count = 0;
  char* p = line;
  while (*p != '\0' && count < max_tokens) {
    while (*p == ' ') ++p;
    if (*p == '\0') break;
    tokens[count++] = p;
    while (*p != '\0' && *p != ' ') ++p;
    if (*p == ' ') *p++ = '\0';
  }
  return count;
}

bool parseInt(const char* token, int32_t min, int32_t max, int32_t& value) {
  if (token == nullptr) return false;
  const char* p = token;
  bool negative = false;
  if (*p == '-' || *p == '+') {
    negative = (*p == '-');
    ++p;
  }
  if (*p == '\0') return false;
  // Accumulate as a negative number: its range includes kInt32Min.
  int32_t acc = 0;
  for (; *p != '\0'; ++p) {
    if (*p < '0' || *p > '9') return false;
    const int32_t digit = *p - '0';
    if (acc < (kInt32Min + digit) / 10) return false;  // would overflow int32
    acc = acc * 10 - digit;
  }
  int32_t result;
  if (negative) {
    result = acc;
  } else {
    if (acc == kInt32Min) return false;
    result = -acc;
  }
  if (result < min || result > max) return false;
  value = result;
  return true;
}

bool equalsP(const char* ram, const char* progmem) {
  for (;; ++ram, ++progmem) {
    const char expected = static_cast<char>(TC_READ_PROGMEM_BYTE(progmem));
    if (*ram != expected) return false;
    if (expected == '\0') return true;
  }
}

void printUint(uint32_t value) {
  char digits[10];
  uint8_t n = 0;
  do {
    digits[n++] = static_cast<char>('0' + value % 10);
    value /= 10;
  } while (value != 0);
  while (n > 0) hal::Uart::write(static_cast<uint8_t>(digits[--n]));
}

void printInt(int32_t value) {
  if (value < 0) {
    hal::Uart::write('-');
    printUint(static_cast<uint32_t>(-(value + 1)) + 1u);  // safe for kInt32Min
  } else {
    printUint(static_cast<uint32_t>(value));
  }
}

void printFixed(int32_t value, uint8_t decimals) {
  uint32_t magnitude =
      value < 0 ? static_cast<uint32_t>(-(value + 1)) + 1u : static_cast<uint32_t>(value);
  if (value < 0) hal::Uart::write('-');
  if (decimals > 9) decimals = 9;
  uint32_t scale = 1;
  for (uint8_t i = 0; i < decimals; ++i) scale *= 10;
  printUint(magnitude / scale);
  if (decimals == 0) return;
  hal::Uart::write('.');
  uint32_t fraction = magnitude % scale;
  for (uint32_t div = scale / 10; div > 0; div /= 10) {
    hal::Uart::write(static_cast<uint8_t>('0' + (fraction / div) % 10));
  }
}

void newline() {
  hal::Uart::write('\r');
  hal::Uart::write('\n');
}

}  // namespace fw
