// Measurements as the lab sees them: named numeric columns, one row per sample, each row in a run
// (a run is one file, split further by the `motor` column and by repeated header lines in a
// gather_store log). Readers for the project's CSV, gather_store's streamed sweep log,
// RCbenchmark / Tyto Flight Stand exports, and any CSV through a column mapping.
#pragma once
#include <cstddef>
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
  std::vector<std::string> names;            // column names (identifiers)
  std::vector<std::vector<double>> columns;  // columns[c][row]; NaN = not logged
  std::vector<int> run;                      // run index per row
  std::vector<std::string> run_labels;       // "file.csv" or "file.csv motor 2" ...
  std::vector<std::string> notes;            // what the readers did (skipped lines, sign flips)

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

// `TARGET=SOURCE[OP NUMBER]...` with OP one of * / + -, applied left to right, e.g.
// `force_g=weight[g]/4`, `pwm_us=pwm`, `force_g=Thrust_N*101.97`.
struct ColumnMap {
  std::string target;
  std::string source;
  std::vector<std::pair<char, double>> ops;
};
// Throws std::invalid_argument with what was expected.
ColumnMap parseColumnMap(const std::string& text);

struct ReadOptions {
  std::vector<ColumnMap> maps;
  bool split_by_motor = true;  // a run per motor value within a file
};

// Reads text already in memory (`file` names it in errors). Throws InputError.
Dataset parseText(const std::string& text, const std::string& file, const ReadOptions& options);
// Reads one file (format detected from its header). Throws InputError.
Dataset readFile(const std::string& path, const ReadOptions& options);
// Reads files, one or more runs per file, and checks pwm_us and force_g are there.
Dataset readFiles(const std::vector<std::string>& paths, const ReadOptions& options);

// Identifier form of a column name: `vbat[V]` -> `vbat_V`, `Thrust (N)` -> `Thrust_N`.
std::string sanitizeName(const std::string& name);

// Writes the project's measurement CSV (header, then rows; `comments` become '# ' lines).
std::string toCsv(const Dataset& data, const std::vector<std::string>& comments);

}  // namespace lab
