// Serial console helpers shared by gather_store and read_run (see console.hpp).
#include "console.hpp"

#include "hal/hal.hpp"


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
LineEvent LineReader::feed(int16_t item) {
  if (item == hal::Uart::kRxDamaged) {
    flags_ = static_cast<uint8_t>((flags_ | kDamagedLine) & ~kLastWasCr);
    return LineEvent::kNone;
  }
  uint8_t byte = static_cast<uint8_t>(item);
  const bool after_cr = (flags_ & kLastWasCr) != 0;
  flags_ = static_cast<uint8_t>(byte == '\r' ? (flags_ | kLastWasCr) : (flags_ & ~kLastWasCr));
  if (byte == '\r' || byte == '\n') {
    if (byte == '\n' && after_cr) return LineEvent::kNone;  // LF of a CRLF
    return endLine();
  }
  if (flags_ & kDiscarding) {
    if (length_ != kLengthCap) ++length_;  // counted, not echoed, not kept
    return LineEvent::kNone;
  }
  if (byte == kBackspace || byte == kDelete) {
    if (length_ > 0 && !(flags_ & kOverflow)) {
      --length_;
      if (length_ < kLineMax) buffer_[length_] = '\0';
      hal::Uart::write(kBackspace);
      hal::Uart::write(' ');
      hal::Uart::write(kBackspace);
    }
    return LineEvent::kNone;
  }
  if (byte == '\t') byte = ' ';
  if (byte < 0x20 || byte > 0x7E) {  // a control or 8-bit byte: a corrupted character
    if (!(flags_ & kNotTextLine)) {
      flags_ |= kNotTextLine;
      bad_byte_ = byte;
      bad_column_ = static_cast<uint8_t>(length_ == kLengthCap ? kLengthCap : length_ + 1);
    }
    return LineEvent::kNone;
  }
  if (length_ == kLengthCap) {
    flags_ |= kOverflow;  // beyond any recovery by backspace
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

LineEvent LineReader::endLine() {
  const uint8_t length = length_;
  const uint8_t flags = flags_;
  length_ = 0;
  flags_ = static_cast<uint8_t>(flags_ & (kStrict | kLastWasCr));  // per-line state cleared
  reject_ = Reject::kNone;
  if (flags & kDiscarding) {
    buffer_[0] = '\0';
    if (length == 0) return LineEvent::kNone;  // the abort key was the last of its line
    newline();
    length_ = length;  // for the message
    return rejectLine(Reject::kAbortedRest);
  }
  newline();
  const bool too_long = (flags & kOverflow) || length > kLineMax;
  buffer_[too_long ? 0 : length] = '\0';
  if (flags & kDamagedLine) return rejectLine(Reject::kDamaged);
  if (flags & kNotTextLine) return rejectLine(Reject::kNotText);
  if (too_long) return rejectLine(Reject::kTooLong);
  const Reject sum = checkChecksum();
  if (sum != Reject::kNone) return rejectLine(sum);
  return LineEvent::kLine;
}

LineEvent LineReader::rejectLine(Reject why) {
  reject_ = why;
  if (rejected_ != 0xFFFF) ++rejected_;
  hal::Uart::printP(TC_FLASH_TEXT("error: "));
  switch (why) {
    case Reject::kDamaged:
      hal::Uart::printP(TC_FLASH_TEXT("line damaged in transit (bytes lost or garbled: receive "
                                "overflow, framing or parity error)"));
      break;
    case Reject::kNotText:
      hal::Uart::printP(TC_FLASH_TEXT("byte 0x"));
      printHex2(bad_byte_);
      hal::Uart::printP(TC_FLASH_TEXT(" at column "));
      printUint(bad_column_);
      hal::Uart::printP(TC_FLASH_TEXT(" is not text (noise on the line?)"));
      break;
    case Reject::kTooLong:
      hal::Uart::printP(TC_FLASH_TEXT("line longer than "));
      printUint(kLineMax);
      hal::Uart::printP(TC_FLASH_TEXT(" characters"));
      break;
    case Reject::kBadChecksum:
      hal::Uart::printP(TC_FLASH_TEXT("checksum *"));
      printHex2(given_sum_);
      hal::Uart::printP(TC_FLASH_TEXT(" does not match the line (*"));
      printHex2(wanted_sum_);
      hal::Uart::write(')');
      break;
    case Reject::kMalformedChecksum:
      hal::Uart::printP(TC_FLASH_TEXT("'*' must end the line with two hex digits (checksum *HH)"));
      break;
    case Reject::kAbortedRest:
      hal::Uart::printP(TC_FLASH_TEXT("ignored the rest of the line whose first key aborted ("));
      printUint(length_);
      hal::Uart::printP(TC_FLASH_TEXT(" characters)"));
      length_ = 0;
      break;
    case Reject::kNone:
      break;
  }
  hal::Uart::printP(TC_FLASH_TEXT(", ignored; nothing changed"));
  newline();
  buffer_[0] = '\0';
  return LineEvent::kRejected;
}

namespace {
int8_t hexValue(char c) {
  if (c >= '0' && c <= '9') return static_cast<int8_t>(c - '0');
  if (c >= 'A' && c <= 'F') return static_cast<int8_t>(c - 'A' + 10);
  if (c >= 'a' && c <= 'f') return static_cast<int8_t>(c - 'a' + 10);
  return -1;
}
}  // namespace

Reject LineReader::checkChecksum() {
  uint8_t star = 0;
  uint8_t sum = 0;
  while (buffer_[star] != '\0' && buffer_[star] != '*') sum ^= static_cast<uint8_t>(buffer_[star++]);
  if (buffer_[star] == '\0') return Reject::kNone;  // no checksum: fine unless strict requires one
  const int8_t hi = hexValue(buffer_[star + 1]);
  const int8_t lo = hi < 0 ? -1 : hexValue(buffer_[star + 2]);
  if (hi < 0 || lo < 0 || buffer_[star + 3] != '\0') return Reject::kMalformedChecksum;
  given_sum_ = static_cast<uint8_t>((hi << 4) | lo);
  wanted_sum_ = sum;
  if (given_sum_ != sum) return Reject::kBadChecksum;
  buffer_[star] = '\0';
  flags_ |= kChecked;
  return Reject::kNone;
}

LineEvent LineReader::poll(uint8_t max_bytes) {
  for (uint8_t n = 0; n < max_bytes && hal::Uart::available(); ++n) {
    const int16_t item = hal::Uart::read();
    if (item < 0) break;
    const LineEvent event = feed(item);
    if (event != LineEvent::kNone) return event;
  }
  return LineEvent::kNone;
}

void LineReader::clear() {
  buffer_[0] = '\0';
  length_ = 0;
  flags_ = static_cast<uint8_t>(flags_ & kStrict);
}

void LineReader::abortLine(int16_t key) {
  clear();
  if (key == '\r') {
    flags_ |= kLastWasCr;  // its LF, if one follows, belongs to it
  } else if (key != '\n') {
    flags_ |= kDiscarding;
  }
}

void LineReader::setStrict(bool on) {
  flags_ = static_cast<uint8_t>(on ? (flags_ | kStrict) : (flags_ & ~kStrict));
}

void LineReader::strictCommand(bool on) {
  setStrict(on);
  hal::Uart::printP(on ? TC_FLASH_TEXT("strict on: commands that spin a motor or write the EEPROM need "
                                 "a checksum (*HH)")
                       : TC_FLASH_TEXT("strict off: checksums optional"));
  newline();
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
    const char expected = static_cast<char>(tc::flashByte(progmem));
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

namespace {
// One digit of formatFixed16 at a constant power of ten (inlined: five straight-line steps, no
// loop over the powers): the digit by subtraction (at most 9, the first at most 3), printed
// unless it is a leading zero before the point; the point after the digit at `point`.
__attribute__((always_inline)) inline char* fixedDigit(char* out, uint16_t& magnitude, uint16_t power, uint8_t k,
                                                        uint8_t point, bool& leading) {
  char digit = '0';
  while (magnitude >= power) {
    magnitude = static_cast<uint16_t>(magnitude - power);
    ++digit;
  }
  if (digit != '0' || k >= point) leading = false;
  if (!leading) *out++ = digit;
  if (k == point && k != 4) *out++ = '.';
  return out;
}
}  // namespace

// No division and no table: each of the five digits by subtraction.
char* formatFixed16(char* out, int16_t value, uint8_t decimals) {
  uint16_t magnitude = value < 0 ? static_cast<uint16_t>(-static_cast<int32_t>(value)) : static_cast<uint16_t>(value);
  if (value < 0) *out++ = '-';
  if (decimals > 4) decimals = 4;
  const uint8_t point = static_cast<uint8_t>(4 - decimals);  // the digit before the point
  bool leading = true;
  out = fixedDigit(out, magnitude, 10000, 0, point, leading);
  out = fixedDigit(out, magnitude, 1000, 1, point, leading);
  out = fixedDigit(out, magnitude, 100, 2, point, leading);
  out = fixedDigit(out, magnitude, 10, 3, point, leading);
  out = fixedDigit(out, magnitude, 1, 4, point, leading);
  *out = '\0';
  return out;
}

void printFixed16(int16_t value, uint8_t decimals) {
  char text[kFixed16Chars + 1];
  formatFixed16(text, value, decimals);
  hal::Uart::print(text);
}

void printHex2(uint8_t value) {
  for (uint8_t shift = 4;; shift = 0) {
    const uint8_t d = static_cast<uint8_t>((value >> shift) & 0x0F);
    hal::Uart::write(static_cast<uint8_t>(d < 10 ? '0' + d : 'A' + d - 10));
    if (shift == 0) return;
  }
}

void printResetCause() {
  const uint8_t flags = hal::Watchdog::resetFlags();
  hal::Uart::printP(TC_FLASH_TEXT("reset: "));
  if ((flags & 0x1F) == 0) {  // a bootloader cleared MCUSR
    hal::Uart::printP((flags & hal::Watchdog::kWasRunning)
                          ? TC_FLASH_TEXT("watchdog or external while running (a bootloader cleared "
                                    "the reset flags)")
                          : TC_FLASH_TEXT("power-on or external (a bootloader cleared the reset flags)"));
    newline();
    return;
  }
  bool first = true;
  auto word = [&](uint8_t bit, const char* text) {
    if ((flags & bit) == 0) return;
    if (!first) hal::Uart::printP(TC_FLASH_TEXT(", "));
    hal::Uart::printP(text);
    first = false;
  };
  word(hal::Watchdog::kWatchdog, TC_FLASH_TEXT("watchdog"));
  word(hal::Watchdog::kBrownOut, TC_FLASH_TEXT("brown-out"));
  word(hal::Watchdog::kExternal, TC_FLASH_TEXT("external"));
  word(hal::Watchdog::kPowerOn, TC_FLASH_TEXT("power-on"));
  word(hal::Watchdog::kJtag, TC_FLASH_TEXT("JTAG"));
  if (flags & hal::Watchdog::kWatchdog) {
    hal::Uart::printP(TC_FLASH_TEXT(" (the program hung; motors were stopped)"));
  } else if (flags & hal::Watchdog::kBrownOut) {
    hal::Uart::printP(TC_FLASH_TEXT(" (the supply dipped; check the 5 V supply)"));
  }
  newline();
}

void printHealth(const LineReader& reader, void (*yield)()) {
  hal::Uart::printP(TC_FLASH_TEXT("stack: "));
  printUint(hal::Stack::untouchedBytes(yield));
  hal::Uart::printP(TC_FLASH_TEXT(" of "));
  printUint(hal::Stack::sizeBytes());
  hal::Uart::printP(reader.strict() ? TC_FLASH_TEXT(" bytes never used; strict on; ")
                                    : TC_FLASH_TEXT(" bytes never used; strict off; "));
  printUint(reader.rejectedLines());
  hal::Uart::printP(TC_FLASH_TEXT(" lines rejected"));
  newline();
}

void newline() {
  hal::Uart::write('\r');
  hal::Uart::write('\n');
}

void say(const char* progmem_text) { hal::Uart::printP(progmem_text); }

void sayLine(const char* progmem_text) {
  hal::Uart::printP(progmem_text);
  newline();
}

void sayVolts(uint16_t mv) {
  printFixed(mv, 3);
  say(TC_FLASH_TEXT(" V"));
}

void sayCopy(uint8_t copy) { say(copy == 0 ? TC_FLASH_TEXT("copy A") : TC_FLASH_TEXT("copy B")); }

// A flash copy of the board's ESC table (indexing hal::kEscPins at run time would put it in
// SRAM on the AVR).
static_assert(hal::kEscChannels == 4, "one entry per ESC channel");
const hal::EscPin kEscPinsFlash[] TC_FLASH = {hal::kEscPins[0], hal::kEscPins[1], hal::kEscPins[2],
                                              hal::kEscPins[3]};

void printEscPin(uint8_t channel) {
  if (channel >= hal::kEscChannels) return;
  hal::EscPin pin;
  tc::flashCopy(&pin, &kEscPinsFlash[channel], sizeof pin);
  hal::Uart::write('D');
  printUint(pin.arduino_pin);
  hal::Uart::printP(TC_FLASH_TEXT(" (P"));
  hal::Uart::write(static_cast<uint8_t>(pin.port));
  hal::Uart::write(static_cast<uint8_t>('0' + pin.bit));
  hal::Uart::printP(TC_FLASH_TEXT(", OC"));
  hal::Uart::write(static_cast<uint8_t>('0' + pin.timer));
  hal::Uart::write(static_cast<uint8_t>(pin.compare));
  hal::Uart::write(')');
}

}  // namespace fw
