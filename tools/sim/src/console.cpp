#include "sim/console.hpp"

#include <fmt/format.h>

#include <regex>

namespace sim {

Console::Console(Board& board, std::string prompt) : board_(board), prompt_(std::move(prompt)) {
  consumed_ = scanned_ = board_.output().size();
  board_.addOutputListener([this](uint8_t byte) { onByte(byte); });
}

void Console::onByte(uint8_t byte) {
  if (byte == '\n') {
    if (!current_line_.empty() && current_line_.back() == '\r') current_line_.pop_back();
    for (auto& listener : line_listeners_) listener(current_line_);
    current_line_.clear();
  } else {
    current_line_.push_back(static_cast<char>(byte));
  }
}

void Console::send(const std::string& line) { board_.sendText(line + "\r"); }

void Console::setKeepAlive(double period_s, std::string line) {
  keepalive_period_s_ = period_s;
  keepalive_line_ = std::move(line);
  next_keepalive_s_ = board_.timeS() + period_s;
}

void Console::keepAlive() {
  if (keepalive_period_s_ <= 0 || board_.timeS() < next_keepalive_s_) return;
  send(keepalive_line_);
  next_keepalive_s_ = board_.timeS() + keepalive_period_s_;
}

struct Console::Pattern {
  std::regex re;
};

bool Console::findIn(const Pattern* re, const std::string* literal,
                     std::vector<std::string>& groups) {
  const std::string& out = board_.output();
  std::size_t pos = scanned_;
  while (pos <= out.size()) {
    const std::size_t nl = out.find('\n', pos);
    std::size_t end = nl == std::string::npos ? out.size() : nl;
    const std::size_t begin = pos < consumed_ ? consumed_ : pos;
    if (end > begin && out[end - 1] == '\r') --end;
    // A regex is tried on complete lines only ("ms 25" is not yet "ms 250"); a literal also
    // on the unfinished last line (prompts end without a newline).
    if (begin <= end && (nl != std::string::npos || !re)) {
      const char* b = out.data() + begin;
      const char* e = out.data() + end;
      if (re) {
        std::cmatch m;
        if (std::regex_search(b, e, m, re->re)) {
          groups.clear();
          for (const auto& g : m) groups.emplace_back(g.first, g.second);
          match_begin_ = begin + static_cast<std::size_t>(m.position(0));
          consumed_ = match_begin_ + static_cast<std::size_t>(m.length(0));
          scanned_ = consumed_;
          return true;
        }
      } else {
        const std::string_view line(b, static_cast<std::size_t>(e - b));
        const std::size_t at = line.find(*literal);
        if (at != std::string_view::npos) {
          groups.assign(1, *literal);
          match_begin_ = begin + at;
          consumed_ = match_begin_ + literal->size();
          scanned_ = consumed_;
          return true;
        }
      }
    }
    if (nl == std::string::npos) break;  // the unfinished line is tested again later
    pos = nl + 1;
    scanned_ = pos;
  }
  return false;
}

std::vector<std::string> Console::expect(const std::string& regex, double budget_s) {
  Pattern re;
  try {
    re.re = std::regex(regex, std::regex::ECMAScript);
  } catch (const std::regex_error& e) {
    throw std::invalid_argument(fmt::format("expect: '{}' is not a valid regex: {}", regex, e.what()));
  }
  std::vector<std::string> groups;
  scanned_ = consumed_;
  const double t0 = board_.timeS();
  if (!board_.runUntil([&] { keepAlive(); return findIn(&re, nullptr, groups); },
                       secondsToCycles(budget_s)))
    throw ExpectTimeout(fmt::format(
        "the board did not print a line matching /{}/ within {:g} s (simulated, from t = {:.3f} s)"
        "; last lines of the console:\n{}",
        regex, budget_s, t0, tail()));
  return groups;
}

void Console::expectText(const std::string& text, double budget_s) {
  std::vector<std::string> groups;
  scanned_ = consumed_;
  const double t0 = board_.timeS();
  if (!board_.runUntil([&] { keepAlive(); return findIn(nullptr, &text, groups); },
                       secondsToCycles(budget_s)))
    throw ExpectTimeout(fmt::format(
        "the board did not print \"{}\" within {:g} s (simulated, from t = {:.3f} s); last lines "
        "of the console:\n{}",
        text, budget_s, t0, tail()));
}

std::vector<std::string> Console::waitPrompt(double budget_s) {
  const std::size_t from = consumed_;
  expectText(prompt_, budget_s);
  return linesBetween(from, match_begin_);
}

std::vector<std::string> Console::command(const std::string& line, double budget_s) {
  const std::size_t from = consumed_;
  send(line);
  std::vector<std::string> groups;
  scanned_ = consumed_;
  const double t0 = board_.timeS();
  if (!board_.runUntil([&] { keepAlive(); return findIn(nullptr, &prompt_, groups); },
                       secondsToCycles(budget_s)))
    throw ExpectTimeout(fmt::format(
        "command \"{}\": no prompt \"{}\" within {:g} s (simulated, from t = {:.3f} s); last "
        "lines of the console:\n{}",
        line, prompt_, budget_s, t0, tail()));
  std::vector<std::string> lines = linesBetween(from, match_begin_);
  if (!lines.empty() && lines.front().size() >= line.size() &&
      lines.front().compare(lines.front().size() - line.size(), line.size(), line) == 0)
    lines.erase(lines.begin());
  return lines;
}

std::vector<std::string> Console::linesBetween(std::size_t from, std::size_t to) const {
  const std::string& out = board_.output();
  std::vector<std::string> lines;
  std::size_t pos = from;
  while (pos < to) {
    std::size_t nl = out.find('\n', pos);
    const bool last = nl == std::string::npos || nl >= to;
    std::size_t end = last ? to : nl;
    std::string line = out.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (!(last && line.empty())) lines.push_back(line);
    if (last) break;
    pos = nl + 1;
  }
  return lines;
}

std::string Console::tail(std::size_t n) const {
  const std::string& out = board_.output();
  std::size_t pos = out.size();
  std::size_t count = 0;
  while (pos > 0 && count <= n) {
    pos = out.rfind('\n', pos - 1);
    if (pos == std::string::npos) {
      pos = 0;
      break;
    }
    ++count;
  }
  std::string t = out.substr(pos == 0 ? 0 : pos + 1);
  std::string clean;
  for (char c : t)
    if (c != '\r') clean.push_back(c);
  if (clean.empty()) return "  (the board printed nothing)";
  std::string indented = "  | ";
  for (char c : clean) {
    indented.push_back(c);
    if (c == '\n') indented += "  | ";
  }
  return indented;
}

std::string Console::unconsumed() const { return board_.output().substr(consumed_); }

}  // namespace sim
