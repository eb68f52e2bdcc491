// The table-driven command shell (see shell.hpp).
#include "shell.hpp"

#include <string.h>

#include "console.hpp"

namespace fw {

const char kArgText[] TC_FLASH = "";

namespace detail {

namespace {

constexpr uint8_t kHelpColumn = 15;  // help text starts here ("f N G" + spaces)

uint8_t lengthP(const char* p) {
  uint8_t n = 0;
  while (tc::flashByte(p + n) != 0) ++n;
  return n;
}

void spaces(uint8_t n) {
  while (n-- > 0) hal::Uart::write(' ');
}

void readArg(const CommandSpec& spec, uint8_t index, ArgSpec& arg) {
  readBytes(&arg, &spec.args[index], sizeof arg);
}

bool parseArg(const ArgSpec& arg, const char* token, int32_t& value) {
  if (arg.words == kArgText) {
    value = 0;
    return true;
  }
  if (arg.words != nullptr) {
    const int8_t index = tc::flashWordIndex(arg.words, token);
    if (index < 0) return false;
    value = index;
    return true;
  }
  return parseInt(token, arg.min, arg.max, value);
}

// "G must be a whole number 0..5000, got "9000"" or "expected on|off, got "x"".
void sayArgError(const ArgSpec& arg, const char* token) {
  hal::Uart::printP(TC_FLASH_TEXT("error: "));
  if (arg.words != nullptr) {
    hal::Uart::printP(TC_FLASH_TEXT("expected "));
    hal::Uart::printP(arg.words);
  } else {
    hal::Uart::printP(arg.name);
    hal::Uart::printP(TC_FLASH_TEXT(" must be a whole number "));
    printInt(arg.min);
    hal::Uart::printP(TC_FLASH_TEXT(".."));
    printInt(arg.max);
  }
  hal::Uart::printP(TC_FLASH_TEXT(", got \""));
  hal::Uart::print(token);
  hal::Uart::write('"');
  newline();
}

// "f N G" / "liftoff G [RAMP_MS] [HOLD_MS]"; returns the characters printed.
uint8_t printUsage(const CommandSpec& spec) {
  hal::Uart::printP(spec.name);
  uint8_t width = lengthP(spec.name);
  for (uint8_t i = 0; i < spec.max_args; ++i) {
    ArgSpec arg;
    readArg(spec, i, arg);
    const bool optional = i >= spec.min_args;
    const char* label = arg.words != nullptr && arg.words != kArgText ? arg.words : arg.name;
    hal::Uart::write(' ');
    if (optional) hal::Uart::write('[');
    hal::Uart::printP(label);
    if (optional) hal::Uart::write(']');
    width = static_cast<uint8_t>(width + 1 + lengthP(label) + (optional ? 2 : 0));
  }
  return width;
}

void sayUsage(const void* table, uint8_t rows, size_t stride, const char* name) {
  hal::Uart::printP(TC_FLASH_TEXT("error: usage: "));
  bool first = true;
  for (uint8_t r = 0; r < rows; ++r) {
    CommandSpec spec;
    readSpec(static_cast<const char*>(table) + r * stride, spec);
    if (!equalsP(name, spec.name)) continue;
    if (!first) hal::Uart::printP(TC_FLASH_TEXT(" | "));
    first = false;
    printUsage(spec);
  }
  newline();
}

}  // namespace

void readBytes(void* dst, const void* progmem_src, size_t length) {
  tc::flashCopy(dst, progmem_src, length);
}

void readSpec(const void* row, CommandSpec& spec) { readBytes(&spec, row, sizeof spec); }

int8_t matchCommand(const void* table, uint8_t rows, size_t stride, char* line,
                    const LineContext& context, ArgValues& args) {
  char* tokens[kShellMaxArgs + 2];
  const uint8_t count = tokenize(line, tokens, kShellMaxArgs + 2);
  if (count == 0) return -2;
  const uint8_t given = static_cast<uint8_t>(count - 1);

  bool known = false;
  uint8_t candidates = 0;
  int8_t only_candidate = -1;
  for (uint8_t r = 0; r < rows; ++r) {
    CommandSpec spec;
    readSpec(static_cast<const char*>(table) + r * stride, spec);
    if (!equalsP(tokens[0], spec.name)) continue;
    known = true;
    if (given < spec.min_args || given > spec.max_args) continue;
    ++candidates;
    only_candidate = static_cast<int8_t>(r);
    ArgValues parsed;
    bool ok = true;
    for (uint8_t i = 0; i < given && ok; ++i) {
      ArgSpec arg;
      readArg(spec, i, arg);
      ok = parseArg(arg, tokens[i + 1], parsed.value[i]);
      parsed.text[i] = tokens[i + 1];
    }
    if (!ok) continue;
    parsed.count = given;
    const bool stop = (spec.flags & kCmdZeroIsStop) && given > 0 && parsed.value[given - 1] == 0;
    if ((spec.flags & kCmdGuarded) && !stop && context.strict && !context.checksummed) {
      hal::Uart::printP(TC_FLASH_TEXT("error: strict mode: \""));
      hal::Uart::print(tokens[0]);
      hal::Uart::printP(TC_FLASH_TEXT("\" needs a checksum: end the line with *hh (XOR of its bytes)"));
      newline();
      return -1;
    }
    args = parsed;
    return static_cast<int8_t>(r);
  }

  if (!known) {
    hal::Uart::printP(TC_FLASH_TEXT("error: unknown command \""));
    hal::Uart::print(tokens[0]);
    hal::Uart::printP(TC_FLASH_TEXT("\"; type help for the list"));
    newline();
    return -1;
  }
  if (candidates == 1) {
    // The one row that takes this many arguments refused one: say which and why.
    CommandSpec spec;
    readSpec(static_cast<const char*>(table) + only_candidate * stride, spec);
    for (uint8_t i = 0; i < given; ++i) {
      ArgSpec arg;
      readArg(spec, i, arg);
      int32_t value;
      if (!parseArg(arg, tokens[i + 1], value)) {
        sayArgError(arg, tokens[i + 1]);
        return -1;
      }
    }
  }
  sayUsage(table, rows, stride, tokens[0]);
  return -1;
}

void printHelp(const void* table, uint8_t rows, size_t stride) {
  for (uint8_t r = 0; r < rows; ++r) {
    CommandSpec spec;
    readSpec(static_cast<const char*>(table) + r * stride, spec);
    if (spec.flags & kCmdHidden) continue;
    const uint8_t width = printUsage(spec);
    spaces(width + 2 <= kHelpColumn ? static_cast<uint8_t>(kHelpColumn - width) : 2);
    for (const char* p = spec.help; tc::flashByte(p) != 0; ++p) {
      const uint8_t c = tc::flashByte(p);
      if (c == '\n') {
        newline();
        spaces(kHelpColumn);
      } else {
        hal::Uart::write(c);
      }
    }
    // Integer ranges, from the same specs the parser checks.
    bool first = true;
    for (uint8_t i = 0; i < spec.max_args; ++i) {
      ArgSpec arg;
      readArg(spec, i, arg);
      if (arg.words != nullptr) continue;  // words and text: no range
      hal::Uart::printP(first ? TC_FLASH_TEXT(" (") : TC_FLASH_TEXT(", "));
      first = false;
      hal::Uart::printP(arg.name);
      hal::Uart::write(' ');
      printInt(arg.min);
      hal::Uart::printP(TC_FLASH_TEXT(".."));
      printInt(arg.max);
    }
    if (!first) hal::Uart::write(')');
    newline();
  }
}

}  // namespace detail
}  // namespace fw
