// Regular expressions for tests that check the text a firmware image or a tool prints.
//
// The tests match console lines (`cyc (\d+)`, CSV rows, status lines) with ECMAScript regular
// expressions, std::regex's default grammar. <regex> is all templates: each test executable that
// included it compiled them again, about 4 CPU s per executable in the checked tree (sanitized),
// ~40 s of every CI run over ten executables. Here they are compiled once, in text_match.cpp, and
// a test includes only this header (docs/testing.md, "Build time of the checked tree").
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace tc::test {

// One match: [0] is the whole matched text, [i] the i-th group ("" when the group took no part),
// `position` where the match starts in the text searched.
struct Groups : std::vector<std::string> {
  std::size_t position = 0;
};

// A compiled ECMAScript regular expression; copies share the compiled form. A pattern that does
// not compile throws std::regex_error's message as std::invalid_argument, naming the pattern.
class Pattern {
 public:
  Pattern(const std::string& ecmascript);  // NOLINT: implicit, so a literal can be passed
  Pattern(const char* ecmascript) : Pattern(std::string(ecmascript)) {}  // NOLINT

  // The whole of `text` matches; `groups` (when given) receives the match.
  bool matches(const std::string& text, Groups* groups = nullptr) const;
  // Some part of `text` matches; `groups` (when given) receives the leftmost match.
  bool foundIn(const std::string& text, Groups* groups = nullptr) const;
  // Every non-overlapping match in `text`, left to right.
  std::vector<Groups> allIn(const std::string& text) const;

  const std::string& text() const { return text_; }

 private:
  struct Compiled;
  std::string text_;
  std::shared_ptr<const Compiled> compiled_;
};

}  // namespace tc::test
