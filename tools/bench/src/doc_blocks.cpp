// Generated figures in markdown files (bench/doc_blocks.hpp).
#include "bench/doc_blocks.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "bench/report.hpp"
#include "bench/table.hpp"

namespace bench {

namespace {

// "a b \"c d\"" -> {a, b, c d}.
std::vector<std::string> splitArgs(const std::string& s, const std::string& where) {
  std::vector<std::string> out;
  std::size_t i = 0;
  while (i < s.size()) {
    if (s[i] == ' ') {
      ++i;
      continue;
    }
    if (s[i] == '"') {
      const std::size_t close = s.find('"', i + 1);
      if (close == std::string::npos) throw std::runtime_error(where + ": a quote is not closed");
      out.push_back(s.substr(i + 1, close - i - 1));
      i = close + 1;
    } else {
      const std::size_t blank = std::min(s.find(' ', i), s.size());
      out.push_back(s.substr(i, blank - i));
      i = blank;
    }
  }
  return out;
}

// The steps of a path: split on '.' outside brackets ("runs[part=kv1100_9x4.7].itae").
std::vector<std::string> steps(const std::string& path) {
  std::vector<std::string> out(1);
  int depth = 0;
  for (char c : path) {
    depth += c == '[' || c == '{';
    depth -= c == ']' || c == '}';
    if (c == '.' && depth == 0)
      out.emplace_back();
    else
      out.back() += c;
  }
  return out;
}

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::size_t from = 0;
  while (from <= s.size()) {
    const std::size_t comma = std::min(s.find(',', from), s.size());
    out.push_back(s.substr(from, comma - from));
    from = comma + 1;
  }
  return out;
}

// Does every "key=value" (or "key!=value") of `filter` hold for the object `e` (strings and
// numbers compared as text, so `seed=1` matches 1)?
bool matches(const nlohmann::json& e, const std::string& filter) {
  if (!e.is_object()) return false;
  std::size_t from = 0;
  while (from < filter.size()) {
    const std::size_t comma = std::min(filter.find(',', from), filter.size());
    const std::string cond = filter.substr(from, comma - from);
    const std::size_t eq = cond.find('=');
    if (eq == std::string::npos || eq == 0)
      throw std::runtime_error("a filter condition needs key=value or key!=value, got \"" + cond + "\"");
    const bool negated = cond[eq - 1] == '!';
    const std::string key = cond.substr(0, negated ? eq - 1 : eq), want = cond.substr(eq + 1);
    if (!e.contains(key)) return false;
    const nlohmann::json& v = e.at(key);
    const std::string got = v.is_string() ? v.get<std::string>() : v.dump();
    if ((got == want) == negated) return false;
    from = comma + 1;
  }
  return true;
}

// One step from every node in `nodes`.
std::vector<const nlohmann::json*> stepFrom(const std::vector<const nlohmann::json*>& nodes, const std::string& step,
                                            const std::string& path) {
  std::vector<const nlohmann::json*> next;
  const std::size_t brace = step.find('{');
  if (brace != std::string::npos) {  // name{a,b}: those members of the object `name`
    if (step.back() != '}') throw std::runtime_error(step + ": a {member list} needs its closing }");
    const std::vector<std::string> members = splitList(step.substr(brace + 1, step.size() - brace - 2));
    for (const nlohmann::json* n : stepFrom(nodes, step.substr(0, brace), path))
      for (const std::string& m : members) {
        if (!n->is_object() || !n->contains(m))
          throw std::runtime_error(fmt::format("the results JSON has no \"{}\" (in {}): run tools/results.sh, or "
                                               "fix the block's path",
                                               m, path));
        next.push_back(&n->at(m));
      }
    return next;
  }
  const std::size_t bracket = step.find('[');
  const std::string name = step.substr(0, bracket);
  for (const nlohmann::json* n : nodes) {
    if (name == "*") {
      for (const auto& child : *n) next.push_back(&child);
      continue;
    }
    if (!n->is_object() || !n->contains(name))
      throw std::runtime_error(fmt::format("the results JSON has no \"{}\" (in {}): run tools/results.sh, or "
                                           "fix the block's path",
                                           name, path));
    const nlohmann::json& child = n->at(name);
    if (bracket == std::string::npos) {
      next.push_back(&child);
      continue;
    }
    if (!child.is_array() || step.back() != ']')
      throw std::runtime_error(fmt::format("{}: a [filter] needs an array, and a closing ]", step));
    const std::string filter = step.substr(bracket + 1, step.size() - bracket - 2);
    for (const auto& e : child)
      if (matches(e, filter)) next.push_back(&e);
  }
  return next;
}

std::vector<const nlohmann::json*> nodesAt(const nlohmann::json& j, const std::string& path) {
  std::vector<const nlohmann::json*> nodes = {&j};
  for (const std::string& s : steps(path)) nodes = stepFrom(nodes, s, path);
  return nodes;
}

std::string formatted(double v, const std::string& spec) {
  if (spec == ",") {
    std::string digits = fmt::format("{:.0f}", std::fabs(v));
    for (int k = static_cast<int>(digits.size()) - 3; k > 0; k -= 3) digits.insert(static_cast<std::size_t>(k), ",");
    return (v < 0 && digits != "0" ? "-" : "") + digits;
  }
  return fmt::format(fmt::runtime("{:" + spec + "}"), v);
}

std::string fmtArg(const DocBlock& b) { return b.args.size() > 1 ? b.args[1] : std::string(".6g"); }

std::string renderNumbers(const DocBlock& b, const nlohmann::json& results) {
  if (b.args.empty() || b.args.size() > 2) throw std::runtime_error(b.kind + " takes PATH [FMT]");
  const std::vector<double> v = numbersAt(results, b.args[0]);
  if (v.empty()) throw std::runtime_error(fmt::format("{} matches no number in the results JSON", b.args[0]));
  const std::string spec = fmtArg(b);
  if (b.kind == "value") {
    if (v.size() != 1)
      throw std::runtime_error(fmt::format("value {} matches {} numbers: use min, max or range", b.args[0], v.size()));
    return formatted(v[0], spec);
  }
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  if (b.kind == "maxabs")
    return formatted(std::fabs(*std::max_element(v.begin(), v.end(), [](double a, double z) {
                       return std::fabs(a) < std::fabs(z);
                     })),
                     spec);
  if (b.kind == "min") return formatted(*lo, spec);
  if (b.kind == "max") return formatted(*hi, spec);
  const std::string a = formatted(*lo, spec), z = formatted(*hi, spec);
  return a == z ? a : a + (*lo < 0 || spec.front() == '+' ? ".." : "-") + z;
}

std::string renderMet(const DocBlock& b, const nlohmann::json& results) {
  if (b.args.size() != 1) throw std::runtime_error("met takes PATH (an array of targets)");
  int met = 0, all = 0;
  for (const nlohmann::json* n : nodesAt(results, b.args[0])) {
    const auto count = [&](const nlohmann::json& t) {
      ++all;
      met += t.is_object() && t.value("met", false);
    };
    if (n->is_array())
      for (const auto& t : *n) count(t);
    else
      count(*n);
  }
  if (all == 0) throw std::runtime_error(fmt::format("met {}: no targets there", b.args[0]));
  return fmt::format("{} of {}", met, all);
}

std::string renderTable(const DocBlock& b, const nlohmann::json& results) {
  if (b.args.size() != 1) throw std::runtime_error("table takes one PREFIX of a bench table's title");
  if (!results.contains("tables")) throw std::runtime_error("the results JSON has no \"tables\"");
  for (const auto& t : results.at("tables"))
    if (t.value("title", std::string()).rfind(b.args[0], 0) == 0) return Table::fromJson(t).markdown();
  throw std::runtime_error(fmt::format("no bench table's title starts with \"{}\"", b.args[0]));
}

}  // namespace

std::vector<double> numbersAt(const nlohmann::json& j, const std::string& path) {
  std::vector<double> out;
  for (const nlohmann::json* n : nodesAt(j, path)) {
    if (n->is_number())
      out.push_back(n->get<double>());
    else if (!n->is_null())
      throw std::runtime_error(fmt::format("{} reaches a {} where a number was expected", path, n->type_name()));
  }
  return out;
}

// Whether a line starts a block of its own, where an open code span cannot continue: a blank
// line, a list item (`- `, `* `, `1. `), a table row, a heading, a fence.
bool startsBlock(const std::string& text, std::size_t line, std::size_t line_end) {
  std::size_t i = line;
  while (i < line_end && text[i] == ' ') ++i;
  if (i == line_end) return true;  // blank
  const char c = text[i];
  if (c == '|' || c == '#' || text.compare(i, 3, "```") == 0) return true;
  if ((c == '-' || c == '*' || c == '+') && i + 1 < line_end && text[i + 1] == ' ') return true;
  std::size_t d = i;
  while (d < line_end && text[d] >= '0' && text[d] <= '9') ++d;
  return d > i && d + 1 < line_end && text[d] == '.' && text[d + 1] == ' ';
}

// Whether `at` is inside a code example: a fenced block (between lines starting with ```) or a
// code span (an odd number of backticks before it in its paragraph, list item or table row: a
// span may be broken across lines, as Markdown allows, so "`stream\n  on` ..." closes on the
// second line and a marker after it is rewritten). Markers there are shown, not rewritten
// (docs/testing.md explains the markers with such examples).
bool inCodeExample(const std::string& text, std::size_t at) {
  bool fenced = false;
  std::size_t line = 0, block = 0;
  while (line <= at) {
    std::size_t next = text.find('\n', line);
    if (next == std::string::npos) next = text.size();
    if (text.compare(line, 3, "```") == 0) fenced = !fenced;
    if (startsBlock(text, line, next)) block = line;
    if (next >= at) break;
    line = next + 1;
  }
  if (fenced) return true;
  return std::count(text.begin() + static_cast<long>(block), text.begin() + static_cast<long>(at), '`') % 2 == 1;
}

std::vector<DocBlock> findBlocks(const std::string& text, const std::string& file) {
  std::vector<DocBlock> blocks;
  const std::string begin = kBlockBegin, end = kBlockEnd;
  std::size_t at = 0;
  while ((at = text.find(begin, at)) != std::string::npos) {
    if (inCodeExample(text, at)) {
      at += begin.size();
      continue;
    }
    const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
    const std::string where = fmt::format("{}:{}", file, line);
    if (text.compare(at, end.size(), end) == 0)
      throw std::runtime_error(where + ": an end marker without a begin marker before it");
    const std::size_t close = text.find("-->", at);
    if (close == std::string::npos || text.find('\n', at) < close)
      throw std::runtime_error(where + ": the begin marker is not closed by --> on its line");
    DocBlock b;
    b.line = line;
    b.args = splitArgs(text.substr(at + begin.size(), close - at - begin.size()), where);
    if (b.args.empty()) throw std::runtime_error(where + ": the begin marker names no kind");
    b.kind = b.args.front();
    b.args.erase(b.args.begin());
    b.content_begin = close + 3;
    b.content_end = text.find(end, b.content_begin);
    if (b.content_end == std::string::npos)
      throw std::runtime_error(fmt::format("{}: no \"{}\" after this block", where, end));
    const std::size_t nested = text.find(begin, b.content_begin);
    if (nested < b.content_end && text.compare(nested, end.size(), end) != 0)
      throw std::runtime_error(where + ": a block begins inside this one; close it first");
    const bool begin_ends_line = b.content_begin < text.size() && text[b.content_begin] == '\n';
    const bool end_starts_line = b.content_end > 0 && text[b.content_end - 1] == '\n';
    b.inline_form = !(begin_ends_line && end_starts_line);
    if (!b.inline_form) ++b.content_begin;  // the lines after the begin marker's own
    blocks.push_back(b);
    at = b.content_end + end.size();
  }
  return blocks;
}

std::string renderBlock(const DocBlock& b, const nlohmann::json& results) {
  std::string out;
  if (b.kind == "measured")
    out = measuredTable(results);
  else if (b.kind == "table")
    out = renderTable(b, results);
  else if (b.kind == "value" || b.kind == "min" || b.kind == "max" || b.kind == "maxabs" || b.kind == "range")
    out = renderNumbers(b, results);
  else if (b.kind == "met")
    out = renderMet(b, results);
  else
    throw std::runtime_error("unknown kind \"" + b.kind + "\" (measured, table, value, min, max, maxabs, range, met)");
  if (!b.inline_form && (out.empty() || out.back() != '\n')) out += '\n';
  if (b.inline_form && out.find('\n') != std::string::npos)
    throw std::runtime_error("\"" + b.kind + "\" gives several lines: put its markers on lines of their own");
  return out;
}

std::string withBlocks(const std::string& text, const std::string& file, const nlohmann::json& results) {
  std::string out;
  std::size_t copied = 0;
  for (const DocBlock& b : findBlocks(text, file)) {
    out += text.substr(copied, b.content_begin - copied);
    try {
      out += renderBlock(b, results);
    } catch (const std::exception& e) {
      throw std::runtime_error(fmt::format("{}:{}: {}", file, b.line, e.what()));
    }
    copied = b.content_end;
  }
  return out + text.substr(copied);
}

}  // namespace bench
