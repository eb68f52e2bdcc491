// Measurements as the lab sees them: named numeric columns, one row per sample, each row in a run
// (a run is one file, split further by the `motor` column and by repeated header lines in a
// gather_store log). Readers for the project's CSV, gather_store's streamed sweep log,
// RCbenchmark / Tyto Flight Stand exports as they come, and any CSV through a column mapping.
#pragma once
#include <cstddef>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace lab {

// A problem in an input file. what() reads "FILE:LINE:COLUMN: what was wrong; what to do".
class InputError : public std::runtime_error {
 public:
  InputError(const std::string& file, std::size_t line, std::size_t column, const std::string& msg);
  const std::string& file() const { return file_; }
  std::size_t line() const { return line_; }
  std::size_t column() const { return column_; }

 private:
  std::string file_;
  std::size_t line_;
  std::size_t column_;
};

struct Dataset {
  std::vector<std::string> names;            // column names (identifiers), each variable once
  std::vector<std::vector<double>> columns;  // columns[c][row]; NaN = not logged
  std::vector<int> run;                      // run index per row
  std::vector<std::string> run_labels;       // "file.csv" or "file.csv motor 2" ...
  std::vector<std::string> notes;            // what the readers did (skipped lines, sign flips)
  // Axis label of a column as the file had it, with its unit ("ESC signal (µs)", "Thrust (N),
  // in g"); columns without one get axisLabel()'s default.
  std::map<std::string, std::string> labels;

  std::size_t rows() const { return run.size(); }
  std::size_t runs() const { return run_labels.size(); }
  int find(const std::string& name) const;  // -1 when absent
  bool has(const std::string& name) const { return find(name) >= 0; }
  // The column; throws std::invalid_argument naming the missing column.
  const std::vector<double>& col(const std::string& name) const;
  // Adds or replaces a column (size must be rows()).
  void set(const std::string& name, std::vector<double> values);
  // Appends all rows of `other`; columns missing on either side are filled with NaN.
  void append(const Dataset& other);
  // Keeps the rows where keep[i] is true.
  Dataset subset(const std::vector<bool>& keep) const;
};

// The label for a plot axis: the file's own name and unit when the reader kept one, else a
// plain-words label for the project's known columns ("PWM (µs)", "force (g)"), else the name.
std::string axisLabel(const Dataset& data, const std::string& column);

// `TARGET=[-]SOURCE[OP NUMBER]...` with OP one of * / + - and NUMBER possibly signed, applied
// left to right, e.g. `force_g=weight[g]/4`, `pwm_us=pwm`, `force_g=-Thrust (N)*101.97`,
// `force_g=Thrust (N)*-101.97`.
struct ColumnMap {
  std::string target;
  std::string source;
  bool negate = false;  // a leading unary minus on the source
  std::vector<std::pair<char, double>> ops;
  std::string text;  // as the user wrote the right-hand side (labels, messages)
};
// Throws std::invalid_argument with what was expected.
ColumnMap parseColumnMap(const std::string& text);

struct ReadOptions {
  std::vector<ColumnMap> maps;
  bool split_by_motor = true;  // a run per motor value within a file
};

// Reads text already in memory (`file` names it in errors). Throws InputError.
Dataset parseText(const std::string& text, const std::string& file, const ReadOptions& options);
// Reads one file (format detected from its header), streaming. Throws InputError.
Dataset readFile(const std::string& path, const ReadOptions& options);
// Reads files, one or more runs per file, and checks pwm_us and force_g are there.
Dataset readFiles(const std::vector<std::string>& paths, const ReadOptions& options);

// `--where EXPR`: keeps the rows where EXPR (muParser syntax over the column names, plus `run`,
// the run index; `and`, `or` may be written as words) is true. Rows where it cannot be
// evaluated (a column not logged there) are dropped too and counted. Throws
// std::invalid_argument for a bad expression (with its position and the columns).
struct RowSelection {
  std::size_t kept = 0;
  std::size_t dropped = 0;
  std::size_t undefined = 0;  // of the dropped: the expression was not a number there
};
RowSelection selectRows(Dataset& data, const std::string& expression);

// Identifier form of a column name: `vbat[V]` -> `vbat_V`, `Thrust (N)` -> `Thrust_N`,
// `ESC signal (µs)` -> `ESC_signal_us` (a micro sign is `u`).
std::string sanitizeName(const std::string& name);

// Writes the project's measurement CSV (header, then rows; `comments` become '# ' lines).
std::string toCsv(const Dataset& data, const std::vector<std::string>& comments);

}  // namespace lab
