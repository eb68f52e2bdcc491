// `--report DIR`: plots (PNG and SVG through gnuplot), a Markdown page and one self-contained
// HTML page (the plots inline) that a browser opens from disk.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "lab/analysis.hpp"
#include "lab/dataset.hpp"

namespace lab {

struct ReportFiles {
  std::string page;                 // DIR/report.md
  std::string html;                 // DIR/report.html (plots inline)
  std::vector<std::string> images;  // every PNG and SVG written
  std::vector<std::string> warnings;
  std::size_t plotted_rows = 0;     // samples drawn in the plots (all up to 5,000, then thinned)
  std::uintmax_t bytes = 0;         // everything written into DIR
};

constexpr std::size_t kMaxPlotRows = 5000;

// Writes the report for a ladder (a diagnosis is a ladder of one step). Creates DIR. `notes`:
// what the reader did and warnings about the data, repeated on the page. Large data are thinned
// for the plots and data.tsv (every k-th sample plus each step's largest errors), so a report
// stays small (well under 20 MB). Throws std::runtime_error when DIR cannot be written.
ReportFiles writeReport(const std::string& dir, const Dataset& data, const std::vector<LadderStep>& steps,
                        const std::string& command_line, const std::vector<std::string>& notes = {});

}  // namespace lab
