// The CSV reader's insides: the text helpers (fields, numbers, units, line ends), the columns
// stand exports have, and the one-shot parser. Private to tools/lab/src: csv_text.cpp (helpers),
// csv_rows.cpp (the lines), csv_columns.cpp (the columns); the interface is lab/dataset.hpp.
#pragma once
#include <istream>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "lab/dataset.hpp"

namespace lab::csv {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

enum class Cell { kNumber, kMissing, kText, kNotFinite };

struct Field {
  std::string_view text;
  std::size_t column;  // 1-based character position in the line
};

// Known columns of RCbenchmark / Tyto exports: the column's name without its unit (compared in
// lower case), what it becomes, and the scale from each unit the software writes.
struct UnitScale {
  const char* unit;  // unitKey form
  double scale;
};
struct KnownColumn {
  const char* base;
  const char* target;
  const char* unit_label;  // the target's unit, for axis labels
  std::vector<UnitScale> units;
  bool any_unit = false;  // the ESC signal is in microseconds whatever a spreadsheet did to the µ
};

// A raw column while the rows are read.
struct RawColumn {
  std::string header;  // as in the file (unquoted, trimmed)
  enum class Kind { kUndecided, kNumeric, kText } kind = Kind::kUndecided;
  std::vector<double> values;
  std::string first_text;
  std::size_t first_text_line = 0;
  std::size_t first_missing_line = 0, first_missing_column = 0;  // an empty cell
  std::size_t not_finite = 0, not_finite_line = 0, not_finite_column = 0;  // inf, 1e400
  std::string not_finite_text;
};

std::string_view trimView(std::string_view s);

std::string trim(const std::string& s);

std::string lower(std::string s);

std::string_view unquote(std::string_view t);

// Parses a whole field as a number. `decimal_comma`: ',' is the decimal point. Empty, "nan" and
// "na" are missing; "inf" and numbers beyond double's range are not finite; hex floats and
// anything with other characters are text.
Cell parseCell(std::string_view field, bool decimal_comma, double& value);

void splitFields(std::string_view line, char delim, std::vector<Field>& out);

bool isComment(std::string_view t);

bool looksNumeric(std::string_view field);

// A header: contains the delimiter; every field a non-empty name that is not a number, except
// empty fields at the end (RCbenchmark ends every line with the delimiter).
bool looksLikeHeader(std::string_view t, char delim);

char delimiterOf(std::string_view header);

// "Thrust (gf)" -> {"Thrust", "gf"}; "vbat[V]" -> {"vbat", "V"}; "pwm" -> {"pwm", ""}.
std::pair<std::string, std::string> splitUnit(const std::string& header);

// A unit compared loosely: lower case, micro signs as `u`, every other non-letter dropped
// (`N·m`, `N*m`, `N.m` -> `nm`; `ozf·in` -> `ozfin`; `rad/s` -> `rads`).
std::string unitKey(const std::string& unit);

const std::vector<KnownColumn>& knownColumns();

// The columns the lab knows by name; a mapping onto one of them renames its source.
bool isKnownName(const std::string& n);

std::string joinHeaders(const std::vector<std::string>& names);

std::string fmtLines(const std::vector<std::size_t>& lines, std::size_t total);

// Lines ending in LF, CRLF or a lone CR (old Mac exports), streamed in blocks.
class LineReader {
 public:
  explicit LineReader(std::istream& in) : in_(in) {}
  // False at the end. `terminated`: the line ended with a line break (not cut by the end of file).
  bool next(std::string& line, bool& terminated) {
    line.clear();
    bool any = false;  // characters of this line were read
    for (;;) {
      if (pos_ == len_ && !fill()) {
        terminated = false;
        return any;
      }
      if (skip_lf_) {  // the LF of a CRLF
        skip_lf_ = false;
        if (buf_[pos_] == '\n') {
          ++pos_;
          continue;
        }
      }
      const char* b = buf_.data() + pos_;
      const char* e = buf_.data() + len_;
      const char* p = b;
      while (p < e && *p != '\n' && *p != '\r') ++p;
      line.append(b, p);
      any = any || p > b;
      pos_ += static_cast<std::size_t>(p - b);
      if (p < e) {
        skip_lf_ = *p == '\r';
        ++pos_;
        terminated = true;
        return true;
      }
    }
  }

 private:
  bool fill() {
    buf_.resize(1 << 16);
    in_.read(buf_.data(), static_cast<std::streamsize>(buf_.size()));
    len_ = static_cast<std::size_t>(in_.gcount());
    pos_ = 0;
    return len_ > 0;
  }
  std::istream& in_;
  std::vector<char> buf_;
  std::size_t pos_ = 0, len_ = 0;
  bool skip_lf_ = false;
};

// The whole reader: one pass over the lines, then the columns, in seven phases. Each phase is a
// member of this one-shot parser; the state they share is its members. Phases 1-2 (the lines)
// are csv_rows.cpp, 3-7 (the columns) csv_columns.cpp.
class StreamParser {
 public:
  StreamParser(std::istream& in, const std::string& file, const ReadOptions& options)
      : reader_(in), file_(file), options_(options) {}

  Dataset parse() {
    readHeader();
    headerColumns();
    readRows();
    numericColumns();
    standColumns();
    userMaps();
    notFiniteCells();
    dropRowsWithoutDriveOrForce();
    labelRuns();
    return std::move(out_);
  }

 private:
  // 1. The header: the first line naming columns (outside comments; failing that, a comment
  //    line naming pwm_us before the data, as a log may print "# pwm_us,force_g,...").
  void readHeader();

  // The header's fields: one raw column each; empty names at the end mean every line ends with
  // the delimiter.
  void headerColumns();

  // 2. Rows. A line whose first field is a number is data; a line equal to the header starts a
  //    new segment; anything else (console prompts, progress) is skipped. The last line of a
  //    file cut short (no line break, fields missing) is dropped with a note.
  void readRows();

  void handleLine(const std::string& l, bool term, std::size_t no);

  // One cell of a data line into its raw column.
  void cell(RawColumn& rc, const Field& field, std::size_t no);

  // 3. Columns: numeric ones are kept under their identifier; text and empty columns are
  //    set aside with a note.
  void numericColumns();

  // 4. Thrust-stand exports (RCbenchmark / Tyto): each known column becomes the lab's name in
  //    the lab's unit, replacing the raw one (one variable, one name); the file's name and unit
  //    stay as the axis label. A --map onto the same name takes over.
  void standColumns();

  // Column c is the stand's `kc`, logged in `unit`: converted and renamed, or left with a note.
  void standColumn(std::size_t c, const KnownColumn& kc, const std::string& base, const std::string& unit);

  // Sign as logged: a stand mounted the other way logs thrust negative. Judged by the
  // larger-magnitude end; said, and said how to do it by hand.
  void standThrustSign(std::size_t c, double scale);

  // 5. User mappings, all computed from the columns as read, then applied.
  struct Mapped {
    const ColumnMap* map;
    std::vector<double> values;
    int source;
  };

  void userMaps();

  // The column a mapping reads; throws naming the columns when there is none.
  int mapSource(const ColumnMap& m) const;

  std::vector<double> mappedValues(const ColumnMap& m, int src) const;

  void applyMap(Mapped& mp, std::vector<std::string>& drop);

  void dropRenamed(const std::string& name);

  // Numbers that are not finite (inf, 1e400): an error in the drive or the force, else that
  // cell is not logged, with a note.
  void notFiniteCells();

  // 6. Rows without a drive or a force: dropped with a note saying which; a file without any is
  //    an error at the first.
  void dropRowsWithoutDriveOrForce();

  // 7. Runs: header segment x `run` column x motor.
  void labelRuns();

  LineReader reader_;
  const std::string& file_;
  const ReadOptions& options_;
  // the lines
  std::string line_;
  bool terminated_ = true;
  std::size_t line_no_ = 0;
  std::vector<Field> fields_;
  // the header
  std::string header_;
  std::size_t header_line_ = 0;
  bool have_pending_data_ = false;  // a data line read while looking for the header
  std::string pending_;
  bool pending_terminated_ = true;
  std::size_t pending_line_ = 0;
  char delim_ = ',';
  bool decimal_comma_ = false;
  std::vector<RawColumn> raw_;
  std::size_t trailing_ = 0;  // empty names at the end: every line ends with the delimiter
  std::size_t width_ = 0;
  // the rows
  std::vector<int> segment_of_row_;
  std::vector<std::size_t> line_of_row_;
  int segment_ = 0;
  std::size_t skipped_ = 0;
  std::string truncated_note_;
  // the columns
  Dataset out_;
  std::vector<std::string> origin_;            // header text of each out column
  std::vector<const RawColumn*> source_of_;    // and its raw column
};

// Reads a whole stream (`file` names it in errors). Throws InputError.
Dataset parseStream(std::istream& in, const std::string& file, const ReadOptions& options);

}  // namespace lab::csv
