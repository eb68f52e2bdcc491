// The report's page, written once as blocks and rendered twice: Markdown (report.md) and one
// self-contained HTML page with the PNG plots inline (report.html). Private to tools/lab/src.
#pragma once
#include <filesystem>
#include <string>
#include <vector>

namespace lab::report {

// The page, once, for both renderings.
struct Block {
  enum class Kind { kH1, kH2, kPara, kList, kTable, kImage } kind;
  std::string text;                            // heading, paragraph, image caption
  std::vector<std::string> items;              // list items
  std::vector<std::vector<std::string>> rows;  // table, header first
  std::string image;                           // file name (PNG) in DIR
};

std::string toMarkdown(const std::vector<Block>& blocks);
// `images`: embed the PNGs from `dir` (else a line saying the plot was not drawn).
std::string toHtml(const std::vector<Block>& blocks, const std::filesystem::path& dir, bool images);
// Throws std::runtime_error when the file cannot be written.
void writeText(const std::filesystem::path& p, const std::string& text);

}  // namespace lab::report
