// A scripted session on the simulated board's UART0, the way a person uses the real one:
// send a line, wait for a pattern or the prompt, read what came back.
//
// Output is examined line by line (a line ends at '\n'; a trailing '\r' is dropped). A regex
// (ECMAScript) is matched inside one complete line, so "ms 25" never matches /ms (\d+)$/ while
// "ms 250" is still arriving; a literal text is also found in the unfinished last line, so
// prompts without a newline ("gs> ") are seen as soon as they are printed. Budgets are simulated
// seconds; when a pattern does not come in time, ExpectTimeout says what was awaited, for how
// long, and shows the last lines of the console.
#pragma once
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "sim/board.hpp"

namespace sim {

class ExpectTimeout : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Console {
 public:
  // `prompt` is what command() waits for after each line ("gs> ", "rr> ").
  Console(Board& board, std::string prompt);

  // Queues `line` plus "\r" (what a terminal sends on Enter).
  void send(const std::string& line);
  // Waits until a line (or the unfinished last line) of output not yet consumed matches
  // `regex`; consumes output through the end of the match and returns the match groups
  // (group 0 = whole match). Throws ExpectTimeout after `budget_s` simulated seconds.
  std::vector<std::string> expect(const std::string& regex, double budget_s);
  // Waits for the literal `text` (no regex); same rules.
  void expectText(const std::string& text, double budget_s);
  // Sends `line`, waits for the next prompt, returns the output in between, with the echoed
  // command line removed, as lines.
  std::vector<std::string> command(const std::string& line, double budget_s = 5.0);
  // Waits for the prompt; returns the lines before it.
  std::vector<std::string> waitPrompt(double budget_s);
  // While expect()/command()/waitPrompt() wait, sends `line` + "\r" every `period_s` simulated
  // seconds (read_run's keep-alive: an empty line; a lift-off needs one at least every
  // 500 ms). period_s <= 0 turns it off (the default).
  void setKeepAlive(double period_s, std::string line = "");

  // Every complete output line, as it arrives (progress display, CSV capture).
  void onLine(std::function<void(const std::string&)> listener) {
    line_listeners_.push_back(std::move(listener));
  }
  // Removes every line listener (call before the state a listener captured goes away).
  void clearLineListeners() { line_listeners_.clear(); }
  // The last `n` lines of output (the unfinished one included), for error messages.
  std::string tail(std::size_t n = 20) const;
  // Output not yet consumed by expect()/command().
  std::string unconsumed() const;

  Board& board() { return board_; }
  const std::string& prompt() const { return prompt_; }

 private:
  struct Pattern;  // a compiled regex (console.cpp: <regex> stays out of this header)
  bool findIn(const Pattern* re, const std::string* literal, std::vector<std::string>& groups);
  void keepAlive();
  std::vector<std::string> linesBetween(std::size_t from, std::size_t to) const;
  void onByte(uint8_t byte);

  Board& board_;
  std::string prompt_;
  std::size_t consumed_ = 0;   // output offset: everything before is consumed
  std::size_t scanned_ = 0;    // start of the first line not yet fully tested
  std::size_t match_begin_ = 0;  // output offset where the last match began
  std::vector<std::function<void(const std::string&)>> line_listeners_;
  std::string current_line_;
  double keepalive_period_s_ = 0;
  double next_keepalive_s_ = 0;
  std::string keepalive_line_;
};

}  // namespace sim
