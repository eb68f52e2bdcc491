// Aligned text tables for the benchmark output: every figure that has a target carries it in
// a "target" column and the verdict in a "met?" column ("yes", "NO", or "-" without a target).
#pragma once
#include <iosfwd>
#include <string>
#include <vector>

namespace bench {

class Table {
 public:
  Table(std::string title, std::vector<std::string> header);
  void addRow(std::vector<std::string> cells);  // padded or cut to the header's width
  void addNote(std::string note);               // printed under the table
  void print(std::ostream& out) const;
  std::string str() const;

 private:
  std::string title_;
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
  std::vector<std::string> notes_;
};

std::string fixed(double value, int decimals);
inline std::string verdict(bool met) { return met ? "yes" : "NO"; }

}  // namespace bench
