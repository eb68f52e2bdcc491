// `--report DIR`: plots (PNG and SVG through gnuplot) and a Markdown page tying them together.
#pragma once
#include <string>
#include <vector>

#include "lab/analysis.hpp"
#include "lab/dataset.hpp"

namespace lab {

struct ReportFiles {
  std::string page;                 // DIR/report.md
  std::vector<std::string> images;  // every PNG and SVG written
  std::vector<std::string> warnings;
};

// Writes the report for a ladder (a diagnosis is a ladder of one step). Creates DIR.
// Throws std::runtime_error when DIR cannot be written.
ReportFiles writeReport(const std::string& dir, const Dataset& data,
                        const std::vector<LadderStep>& steps, const std::string& command_line);

}  // namespace lab
