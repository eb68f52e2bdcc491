// The one translation unit of the tests that compiles <regex> (text_match.hpp says why).
#include "text_match.hpp"

#include <regex>
#include <stdexcept>

namespace tc::test {

struct Pattern::Compiled {
  std::regex re;
};

namespace {

Groups groupsOf(const std::smatch& m) {
  Groups out;
  out.reserve(m.size());
  for (const auto& sub : m) out.push_back(sub.matched ? sub.str() : std::string());
  out.position = static_cast<std::size_t>(m.position(0));
  return out;
}

}  // namespace

Pattern::Pattern(const std::string& ecmascript) : text_(ecmascript) {
  try {
    compiled_ = std::make_shared<const Compiled>(Compiled{std::regex(ecmascript)});
  } catch (const std::regex_error& e) {
    throw std::invalid_argument("test pattern /" + ecmascript + "/ does not compile: " + e.what());
  }
}

bool Pattern::matches(const std::string& text, Groups* groups) const {
  std::smatch m;
  if (!std::regex_match(text, m, compiled_->re)) return false;
  if (groups) *groups = groupsOf(m);
  return true;
}

bool Pattern::foundIn(const std::string& text, Groups* groups) const {
  std::smatch m;
  if (!std::regex_search(text, m, compiled_->re)) return false;
  if (groups) *groups = groupsOf(m);
  return true;
}

std::vector<Groups> Pattern::allIn(const std::string& text) const {
  std::vector<Groups> out;
  for (std::sregex_iterator it(text.begin(), text.end(), compiled_->re), end; it != end; ++it)
    out.push_back(groupsOf(*it));
  return out;
}

}  // namespace tc::test
