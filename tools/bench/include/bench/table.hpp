// Aligned text tables for the benchmark output: every figure that has a target carries it in
// a "target" column and the verdict in a "met?" column ("yes", "NO", or "-" without a target).
// A table also travels in the --json output (toJson / fromJson), so docs/results.md is made
// from the very cells the bench printed (`thrustcal bench report`).
#pragma once
#include <iosfwd>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace bench {

class Table {
 public:
  Table(std::string title, std::vector<std::string> header);
  void addRow(std::vector<std::string> cells);  // padded or cut to the header's width
  void addNote(std::string note);               // printed under the table
  void print(std::ostream& out) const;
  std::string str() const;
  const std::string& title() const { return title_; }

  nlohmann::json toJson() const;  // {"title", "header", "rows", "notes"}
  // Throws std::runtime_error naming what is missing when `j` is not a table's JSON.
  static Table fromJson(const nlohmann::json& j);
  // A GitHub markdown table (cells with '|' escaped), its notes as a list under it; no title.
  std::string markdown() const;

 private:
  std::string title_;
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
  std::vector<std::string> notes_;
};

std::string fixed(double value, int decimals);
inline std::string verdict(bool met) { return met ? "yes" : "NO"; }

}  // namespace bench
