// Generated figures in any markdown file: the text between
//
//   <!-- generated: KIND ARG... -->   and   <!-- generated: end -->
//
// is what KIND renders from the results JSON (docs/results.json, written by tools/results.sh),
// so a figure in the docs is the tool's own number, not a copy that can drift. A block whose
// markers stand on lines of their own is a block (a table); markers within a line make an inline
// figure in a sentence. `thrustcal bench report --docs FILE...` rewrites every block, `--check`
// fails naming the file and line of each block that differs. docs/testing.md ("Generated
// figures") shows how to add one.
//
// Kinds (PATH is a dotted path into the JSON; a `*` step takes every member or element, a step
// `name[key=value,key!=value]` the elements of the array `name` whose members match, a step
// `name{a,b}` the members a and b of the object `name`):
//   measured            README's measured table (report.hpp)
//   table PREFIX        the bench table whose title starts with PREFIX, as markdown
//   value PATH [FMT]    one number (PATH must match exactly one)
//   min|max PATH [FMT]  the smallest / largest of the numbers PATH matches
//   range PATH [FMT]    "lo-hi" of them ("lo" when all equal; "lo..hi" when lo is negative or
//                       FMT shows a sign)
//   maxabs PATH [FMT]   the largest absolute value of them
//   met PATH            "N of M": the elements of the array PATH whose `met` is true
// FMT is a fmt specification without braces (".1f", "+.1f", ".3g"; default ".6g") or "," (a
// whole number with thousands separators: 66,714).
#pragma once
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace bench {

inline constexpr const char* kBlockBegin = "<!-- generated: ";
inline constexpr const char* kBlockEnd = "<!-- generated: end -->";

struct DocBlock {
  std::string kind;               // "table", "value", ...
  std::vector<std::string> args;  // split on blanks; "..." quotes an argument with blanks
  std::size_t content_begin = 0;  // the text between the markers: [content_begin, content_end)
  std::size_t content_end = 0;
  bool inline_form = false;  // markers within a line (a figure in a sentence)
  int line = 0;              // of the begin marker, 1-based
};

// Every block of `text`. Throws std::runtime_error naming file:line for a begin marker without
// its end (or one not closed by `-->`).
std::vector<DocBlock> findBlocks(const std::string& text, const std::string& file);

// What a block holds: for the block form the lines between the markers (ending in a newline),
// inline the figure alone. Throws std::runtime_error naming what is wrong: an unknown kind, a
// path the JSON does not have, a table no title starts with.
std::string renderBlock(const DocBlock& block, const nlohmann::json& results);

// `text` with every block rendered; errors name file:line.
std::string withBlocks(const std::string& text, const std::string& file, const nlohmann::json& results);

// The numbers at PATH (the path rules above), in document order. Throws std::runtime_error naming
// the step the JSON does not have.
std::vector<double> numbersAt(const nlohmann::json& j, const std::string& path);

}  // namespace bench
