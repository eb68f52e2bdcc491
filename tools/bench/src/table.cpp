#include "bench/table.hpp"

#include <algorithm>
#include <ostream>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>

namespace bench {

Table::Table(std::string title, std::vector<std::string> header)
    : title_(std::move(title)), header_(std::move(header)) {}

void Table::addRow(std::vector<std::string> cells) {
  cells.resize(header_.size());
  rows_.push_back(std::move(cells));
}

void Table::addNote(std::string note) { notes_.push_back(std::move(note)); }

void Table::print(std::ostream& out) const {
  std::vector<size_t> width(header_.size());
  for (size_t c = 0; c < header_.size(); ++c) {
    width[c] = header_[c].size();
    for (const auto& r : rows_) width[c] = std::max(width[c], r[c].size());
  }
  auto line = [&](const std::vector<std::string>& cells) {
    std::string s;
    for (size_t c = 0; c < cells.size(); ++c) {
      // first column left-aligned (names), the rest right-aligned (figures)
      s += c == 0 ? fmt::format("{:<{}}", cells[c], width[c]) : fmt::format("{:>{}}", cells[c], width[c]);
      if (c + 1 < cells.size()) s += "  ";
    }
    while (!s.empty() && s.back() == ' ') s.pop_back();
    out << s << '\n';
  };
  out << title_ << '\n';
  line(header_);
  size_t total = 0;
  for (size_t w : width) total += w + 2;
  out << std::string(total > 2 ? total - 2 : 0, '-') << '\n';
  for (const auto& r : rows_) line(r);
  for (const auto& n : notes_) out << "  " << n << '\n';
  out << '\n';
}

std::string Table::str() const {
  std::ostringstream s;
  print(s);
  return s.str();
}

nlohmann::json Table::toJson() const {
  return {{"title", title_}, {"header", header_}, {"rows", rows_}, {"notes", notes_}};
}

Table Table::fromJson(const nlohmann::json& j) {
  for (const char* key : {"title", "header", "rows", "notes"})
    if (!j.contains(key))
      throw std::runtime_error(fmt::format("a bench table in the JSON has no \"{}\": write the JSON with "
                                           "this version's `thrustcal bench all --json`",
                                           key));
  Table t(j.at("title").get<std::string>(), j.at("header").get<std::vector<std::string>>());
  for (const auto& row : j.at("rows")) t.addRow(row.get<std::vector<std::string>>());
  for (const auto& note : j.at("notes")) t.addNote(note.get<std::string>());
  return t;
}

namespace {

std::string markdownCell(const std::string& text) {
  std::string out;
  for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

std::string markdownRow(const std::vector<std::string>& cells) {
  std::string s = "|";
  for (const auto& c : cells) s += " " + markdownCell(c) + " |";
  return s + "\n";
}

}  // namespace

std::string Table::markdown() const {
  std::string s = markdownRow(header_);
  s += "|";
  for (size_t c = 0; c < header_.size(); ++c) s += c == 0 ? "---|" : "---:|";
  s += "\n";
  for (const auto& r : rows_) s += markdownRow(r);
  if (!notes_.empty()) s += "\n";
  for (const auto& n : notes_) s += "- " + n + "\n";
  return s;
}

std::string fixed(double value, int decimals) { return fmt::format("{:.{}f}", value, decimals); }

}  // namespace bench
