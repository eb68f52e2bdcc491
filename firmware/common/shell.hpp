// A table-driven command shell shared by both firmware images (after Betaflight's cli.c
// command table): each command is one row in flash (name, argument specs with ranges,
// flags, handler, help line). Parsing, range checks, error messages and `help` all come
// from the table, so an image cannot accept an argument its help does not describe, and
// the manual's command lists can be generated from the same rows (a test compares them).
//
// A command name may have several rows with different argument lists (`f G` and `f N G`):
// the first row whose argument count and values fit runs. Errors, one line each:
//   error: unknown command "x"; type help for the list
//   error: usage: f G | f N G                       (no row takes that many arguments)
//   error: G must be a whole number 0..5000, got "9000"  (the only row with that count refused it)
//   error: expected on|off, got "x"                 (a row of words)
//   error: strict mode: "f" needs a checksum: end the line with *hh (XOR of its bytes)
// (tests/firmware/common/test_shell.cpp pins each wording.)
//
// Everything in a table lives in flash (TC_FLASH) on the AVR; rows are copied to the
// stack one at a time (tc::flashCopy), so a table costs no SRAM.
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "hal/hal.hpp"
#include "thrustcal/flash_text.hpp"

namespace fw {

constexpr uint8_t kShellMaxArgs = 4;

// One argument: an integer in [min, max], or (words != nullptr) one of the '|'-separated
// words, whose index becomes the value ("on|off": on = 0, off = 1), or (words == kArgText)
// any one token, which the handler reads from ArgValues::text (a parameter's name or value:
// the handler checks it against its own table).
extern const char kArgText[];  // TC_FLASH; compared by address only
struct ArgSpec {
  const char* name;   // TC_FLASH, shown in usage and errors ("G", "MS")
  const char* words;  // TC_FLASH or nullptr
  int32_t min;
  int32_t max;
};

struct ArgValues {
  int32_t value[kShellMaxArgs] = {};
  const char* text[kShellMaxArgs] = {};  // each argument as typed (valid while the handler runs)
  uint8_t count = 0;
  int32_t operator[](uint8_t index) const { return value[index]; }
  bool has(uint8_t index) const { return index < count; }
};

enum CommandFlag : uint8_t {
  // Can spin a motor or write the EEPROM: with strict mode on, the line must carry a valid
  // checksum (console protocol, docs/console.md).
  kCmdGuarded = 1u << 0,
  // Hidden from `help`: aliases kept for old scripts, rows another row's help names (the
  // help text stays only the usage line).
  kCmdHidden = 1u << 1,
  // With kCmdGuarded: a last argument of 0 is a stop (`f 0`, `f 2 0`), which never needs a
  // checksum; any other value is guarded.
  kCmdZeroIsStop = 1u << 2,
};

// The part of a row the shell reads; Command<App> adds the typed handler after it.
struct CommandSpec {
  const char* name;      // TC_FLASH
  const ArgSpec* args;   // TC_FLASH array of max_args specs (nullptr when max_args == 0)
  uint8_t min_args;      // required arguments
  uint8_t max_args;      // required + optional (optional ones print as [NAME])
  uint8_t flags;         // CommandFlag bits
  const char* help;      // TC_FLASH; '\n' continues on an indented line
};

template <class App>
struct Command {
  CommandSpec spec;
  void (*run)(App& app, const ArgValues& args);
};

// How the line arrived (from the line reader) and the console's mode.
struct LineContext {
  bool checksummed = false;  // the line carried a valid *hh checksum (already stripped)
  bool strict = false;       // strict mode: guarded commands need checksummed lines
};

enum class ShellResult : uint8_t {
  kEmpty,     // nothing but spaces: no command (read_run counts it as a keep-alive)
  kRan,       // a row matched and its handler ran
  kRejected,  // one error line was printed; nothing ran
};

namespace detail {
// Finds the row for `line` (tokenized in place) in a table of `rows` rows `stride` bytes
// apart, parses its arguments into `args`; prints the error and returns -1 when none fits,
// -2 for an empty line.
int8_t matchCommand(const void* table, uint8_t rows, size_t stride, char* line,
                    const LineContext& context, ArgValues& args);
void printHelp(const void* table, uint8_t rows, size_t stride);
void readSpec(const void* row, CommandSpec& spec);
void readBytes(void* dst, const void* progmem_src, size_t length);
}  // namespace detail

// Parses `line` against `table` and runs the matching handler on `app`.
template <class App, uint8_t N>
ShellResult dispatch(App& app, const Command<App> (&table)[N], char* line,
                     const LineContext& context) {
  ArgValues args;
  const int8_t row = detail::matchCommand(table, N, sizeof(Command<App>), line, context, args);
  if (row == -2) return ShellResult::kEmpty;
  if (row < 0) return ShellResult::kRejected;
  Command<App> command;
  detail::readBytes(&command, &table[row], sizeof command);
  command.run(app, args);
  return ShellResult::kRan;
}

// `help`: one line per visible row, "usage  help text (ranges)", generated from the table.
template <class App, uint8_t N>
void printHelp(const Command<App> (&table)[N]) {
  detail::printHelp(table, N, sizeof(Command<App>));
}

}  // namespace fw
