// fly's saved parameters on the host (`thrustcal board params pull|push|table`):
//
//   the table   read out of the image that flies them (fly.hex): its tc::ParamTable header,
//               found by its magic, points at the rows in flash (thrustcal/param_table.hpp
//               gives the AVR layout), so the host's names, ranges and widths are the image's;
//   a file      NAME VALUE per line, '#' starts a comment, blank lines allowed; the values as
//               `param list` shows them ("39.1", "plus"). Names the file leaves out keep what
//               the board holds. Unknown names, values the row refuses, a name twice and broken
//               rules (a minimum not below its maximum) are errors with their line numbers, all
//               of them at once, and nothing is written;
//   the record  tc::readParams / tc::writeParams on the EEPROM image (the firmware's own codec),
//               so a pushed record is what `param save` would have written.
#pragma once
#include <cstdint>
#include <deque>
#include <stdexcept>
#include <string>
#include <vector>

#include "thrustcal/param_store.hpp"
#include "thrustcal/param_table.hpp"

namespace board {

// A parameter table as the host holds it: rows whose texts point into `text`.
struct ParamTableCopy {
  uint8_t layout = 0;
  std::vector<tc::ParamDef> rows;
  std::deque<std::string> text;  // owns every row's strings (a deque: they never move)
  std::string origin;            // "build/avr/firmware/fly/fly.hex (layout 1, 24 rows)"

  const tc::ParamDef* data() const { return rows.data(); }
  uint8_t count() const { return static_cast<uint8_t>(rows.size()); }
  std::vector<int32_t> defaults() const;
};

// Thrown for a file (a parameter file, an image) that cannot be used; what() says where
// (file:line) and what to do.
class ParamError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The table in an image's flash (Intel HEX). Throws ParamError: no table in it (not fly, or
// a fly from before saved parameters), two tables, rows that do not fit the flash.
ParamTableCopy readParamTable(const std::string& hex_path);
ParamTableCopy paramTableFromFlash(const std::vector<uint8_t>& flash, const std::string& origin);
// A copy of a table compiled into this program (tests: fly's own table built for the host).
ParamTableCopy copyParamTable(const tc::ParamDef* rows, uint8_t count, uint8_t layout, const std::string& origin);
// build/avr/firmware/fly/fly.hex of this source tree ($THRUSTCAL_AVR_BUILD_DIR first).
std::string defaultFlyHex();

// One row as `param list` prints it: "angle_kp 800  # mN m/rad, 0..10000".
std::string paramLine(const tc::ParamDef& d, int32_t value);
// A whole parameter file: `comment` lines (each gets "# "), then one line per row.
std::string formatParamFile(const ParamTableCopy& t, const std::vector<int32_t>& values,
                            const std::vector<std::string>& comment);

struct ParamFile {
  std::vector<int32_t> values;  // the file's, or `base`'s where it says nothing
  std::vector<bool> given;      // the rows the file names
  std::size_t givenCount() const;
};
// Parses `text` (from `origin`) over `base` (the values the board holds). Throws ParamError
// listing every bad line.
ParamFile parseParamFile(const ParamTableCopy& t, const std::string& text, const std::string& origin,
                         const std::vector<int32_t>& base);

// docs/fly.md's table: | name | unit | range | default | what it does |
std::string paramDocsTable(const ParamTableCopy& t);
constexpr const char* kParamDocsBegin = "<!-- params: begin (thrustcal board params table --docs docs/fly.md) -->";
constexpr const char* kParamDocsEnd = "<!-- params: end -->";
// `doc` with the text between the markers replaced by `table`. Throws ParamError naming
// `path` when the markers are missing.
std::string withParamDocsTable(const std::string& doc, const std::string& table, const std::string& path);

// What an EEPROM image holds for a table.
struct BoardParamState {
  tc::ParamsRead where;
  tc::ParamsRecord record;
  enum class How { kLoaded, kNone, kNoRoom, kOtherLayout, kCannotBeRight } how = How::kNone;
  std::vector<int32_t> values;  // kLoaded: the record's; otherwise the table's defaults
  std::string why;              // one line: what fly says about it at start-up
};
BoardParamState paramsInImage(const ParamTableCopy& t, const std::vector<uint8_t>& eeprom);
// `eeprom` with `values` stored as `param save` would store them (tc::writeParams): the
// copy written, or the status (kUnchanged, kNoRoom) with `eeprom` untouched.
tc::ParamsWrite storeParamsInImage(const ParamTableCopy& t, const std::vector<int32_t>& values,
                                   std::vector<uint8_t>& eeprom);

}  // namespace board
