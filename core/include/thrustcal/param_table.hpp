// A table of saved parameters (after ArduPilot's @Range/@Units metadata and Betaflight's
// versioned parameter groups): each row names one integer value, its unit, its range, its
// default and how many bytes it takes in the EEPROM record (param_store.hpp). An image keeps
// its table in flash (TC_FLASH, one row read at a time: no SRAM); the console's `param`
// commands, the record's payload and the host's tools (`thrustcal board params`, the generated
// docs table) all work from the rows, so a parameter cannot be typed, stored or documented
// differently. fly's table: firmware/fly/params_table.cpp.
//
// Values are integers; `decimals` says where the point goes when they are shown and typed
// (a level trim of 391 with 1 decimal is "39.1" mg). A row with `words` takes one of the
// '|'-separated words instead ("plus|x|seesaw": plus = 0, x = 1, seesaw = 2).
//
// The payload (what the record stores): every row's value in table order, `bytes` bytes each
// (1, 2 or 4), little endian, two's complement (signed when min < 0). A table that changes its
// rows, their order or their widths must raise its layout version: a record of another layout
// is not read (the image flies its defaults and says so).
//
// The host tools read the table out of the image's flash (the .hex): a ParamTable header,
// found by its magic, points at the rows. kParamRowAvrBytes and the offsets below are the
// AVR's layout of the two structs (avr-gcc packs them, pointers are 16-bit flash addresses),
// checked by static_assert when core builds for the AVR.
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "thrustcal/flash_text.hpp"

namespace tc {

enum ParamFlag : uint8_t {
  kParamZeroIsOff = 1u << 0,  // 0 is allowed besides min..max and means "off" / "not given"
  kParamBelowNext = 1u << 1,  // must be below the next row's value unless that one is 0 (off)
  kParamLive = 1u << 2,       // may change while armed: it cannot make a motor jump
};

struct ParamDef {
  const char* name;   // TC_FLASH, at most kParamNameMax characters: [a-z0-9_]
  const char* unit;   // TC_FLASH, "" for a plain number or a word
  const char* words;  // TC_FLASH '|'-separated words for 0, 1, ...; nullptr: a number
  const char* help;   // TC_FLASH, one line: what it does
  int32_t min;
  int32_t max;
  int32_t def;
  uint8_t bytes;     // stored width: 1, 2 or 4
  uint8_t decimals;  // 0..4
  uint8_t flags;     // ParamFlag bits
  uint8_t group;     // the image's own grouping (what applying the row touches)
};

// The header the host tools find the table by (the image keeps one, in flash).
constexpr uint8_t kParamMagicBytes = 8;
constexpr char kParamMagic[kParamMagicBytes + 1] = "tcPARAMS";
struct ParamTable {
  char magic[kParamMagicBytes];  // kParamMagic, without its terminator
  uint8_t layout;                // the record layout version of this table
  uint8_t rows;
  uint8_t row_bytes;             // sizeof(ParamDef) in the image
  uint8_t reserved;              // 0
  const ParamDef* row;           // TC_FLASH
};

constexpr uint8_t kParamNameMax = 24;
constexpr uint8_t kParamTextMax = 24;   // a value as text: "-2147483648", a word; + '\0'
constexpr uint8_t kParamPayloadMax = 120;  // the record's room (param_store.hpp)
constexpr uint8_t kParamRowsMax = 64;

// The AVR's layout (the host tools decode the rows from the image's bytes with these).
constexpr uint8_t kParamRowAvrBytes = 24;
constexpr uint8_t kParamRowAvrName = 0, kParamRowAvrUnit = 2, kParamRowAvrWords = 4, kParamRowAvrHelp = 6;
constexpr uint8_t kParamRowAvrMin = 8, kParamRowAvrMax = 12, kParamRowAvrDef = 16;
constexpr uint8_t kParamRowAvrBytesField = 20, kParamRowAvrDecimals = 21, kParamRowAvrFlags = 22,
                  kParamRowAvrGroup = 23;
constexpr uint8_t kParamTableAvrBytes = 14;
constexpr uint8_t kParamTableAvrLayout = 8, kParamTableAvrRows = 9, kParamTableAvrRowBytes = 10,
                  kParamTableAvrRow = 12;
#if defined(__AVR__)
static_assert(sizeof(ParamDef) == kParamRowAvrBytes, "the host tools decode 24-byte rows");
static_assert(offsetof(ParamDef, unit) == kParamRowAvrUnit && offsetof(ParamDef, words) == kParamRowAvrWords &&
                  offsetof(ParamDef, help) == kParamRowAvrHelp && offsetof(ParamDef, min) == kParamRowAvrMin &&
                  offsetof(ParamDef, max) == kParamRowAvrMax && offsetof(ParamDef, def) == kParamRowAvrDef &&
                  offsetof(ParamDef, bytes) == kParamRowAvrBytesField &&
                  offsetof(ParamDef, decimals) == kParamRowAvrDecimals &&
                  offsetof(ParamDef, flags) == kParamRowAvrFlags && offsetof(ParamDef, group) == kParamRowAvrGroup,
              "ParamDef's AVR layout is what the host tools decode");
static_assert(sizeof(ParamTable) == kParamTableAvrBytes && offsetof(ParamTable, layout) == kParamTableAvrLayout &&
                  offsetof(ParamTable, rows) == kParamTableAvrRows &&
                  offsetof(ParamTable, row_bytes) == kParamTableAvrRowBytes &&
                  offsetof(ParamTable, row) == kParamTableAvrRow,
              "ParamTable's AVR layout is what the host tools decode");
#endif

// Row `index` of a table in flash, copied to RAM (its texts stay in flash).
inline ParamDef paramRow(const ParamDef* table, uint8_t index) {
  ParamDef d;
  flashCopy(&d, &table[index], sizeof d);
  return d;
}

// Why values cannot be taken; `row` names the first row at fault.
enum class ParamFault : uint8_t {
  kNone = 0,
  kOutOfRange,    // the row's value outside its range (and not 0 where 0 is off)
  kNotBelowNext,  // a kParamBelowNext row not below the next row (which is not 0)
  kBadLength,     // a payload whose length is not the table's
};
struct ParamCheck {
  ParamFault fault = ParamFault::kNone;
  uint8_t row = 0;
  bool ok() const { return fault == ParamFault::kNone; }
};

// Whether `value` is allowed for the row on its own (its range, 0 where 0 is off, a word).
bool paramAllowed(const ParamDef& d, int32_t value);
// Every row allowed and every kParamBelowNext rule kept.
ParamCheck checkParams(const ParamDef* table, uint8_t rows, const int32_t* values);
// The rows' defaults into `values`.
void defaultParams(const ParamDef* table, uint8_t rows, int32_t* values);

// The payload's size for the table (the sum of the widths).
uint8_t paramPayloadBytes(const ParamDef* table, uint8_t rows);
// `values` -> payload (paramPayloadBytes bytes). Cannot fail; values must fit their widths.
void encodeParams(const ParamDef* table, uint8_t rows, const int32_t* values, uint8_t* payload);
// Payload -> `values`, then checkParams. kBadLength when `length` is not the table's; `values`
// holds what was read either way (defaults on kBadLength).
ParamCheck decodeParams(const ParamDef* table, uint8_t rows, const uint8_t* payload, uint8_t length,
                        int32_t* values);

// The row whose name is `name` (RAM text), or -1.
int8_t findParam(const ParamDef* table, uint8_t rows, const char* name);

// A value as text, the way `param list` shows it and a parameter file holds it: the word, or
// the number with `decimals` decimals ("-39.1", "0.6500"). `out` has kParamTextMax bytes.
// Returns the length.
uint8_t formatParamValue(const ParamDef& d, int32_t value, char* out);

enum class ParamParse : uint8_t {
  kOk = 0,
  kNotAWord,      // a row of words, and the text is none of them
  kNotANumber,    // not [-]digits[.digits] with at most `decimals` decimals
  kNotAllowed,    // a number, outside what paramAllowed takes
};
// Text -> value for the row (the inverse of formatParamValue; "39" is 39.0 with 1 decimal).
// `value` is meaningful only on kOk.
ParamParse parseParamValue(const ParamDef& d, const char* text, int32_t& value);

}  // namespace tc
