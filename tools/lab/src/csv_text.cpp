// The CSV reader's text helpers: trimming, quoted fields, numbers (a decimal comma, inf and nan
// as the files write them), header and delimiter detection, units, and the columns stand exports
// have (RCbenchmark / Tyto) with their scales to the lab's units.
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <set>

#include "csv_reader.hpp"

namespace lab::csv {

namespace {

constexpr double kGramsPerNewton = 1000.0 / 9.80665;

}  // namespace

std::string_view trimView(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}
std::string trim(const std::string& s) { return std::string(trimView(s)); }

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string_view unquote(std::string_view t) {
  t = trimView(t);
  if (t.size() >= 2 && t.front() == '"' && t.back() == '"') t = trimView(t.substr(1, t.size() - 2));
  return t;
}

// Parses a whole field as a number. `decimal_comma`: ',' is the decimal point. Empty, "nan" and
// "na" are missing; "inf" and numbers beyond double's range are not finite; hex floats and
// anything with other characters are text.
Cell parseCell(std::string_view field, bool decimal_comma, double& value) {
  std::string_view t = unquote(field);
  value = kNaN;
  if (t.empty()) return Cell::kMissing;
  // the common case: a plain decimal number, parsed in place
  if (!decimal_comma && t.front() != '+' && (std::isdigit(static_cast<unsigned char>(t.front())) || t.front() == '-' ||
                                             t.front() == '.')) {
    const auto r = std::from_chars(t.data(), t.data() + t.size(), value);
    if (r.ec == std::errc() && r.ptr == t.data() + t.size()) {
      if (std::isfinite(value)) return Cell::kNumber;
      value = kNaN;
    }
  }
  auto is = [&](const char* word) {
    const std::size_t n = std::char_traits<char>::length(word);
    if (t.size() != n) return false;
    for (std::size_t i = 0; i < n; ++i)
      if (std::tolower(static_cast<unsigned char>(t[i])) != word[i]) return false;
    return true;
  };
  if (is("nan") || is("-nan") || is("na")) return Cell::kMissing;
  char buf[64];
  if (t.size() >= sizeof(buf)) return Cell::kText;
  std::size_t n = 0;
  bool inf = false;
  for (char c : t) {
    if (decimal_comma && c == ',') c = '.';
    if (!(std::isdigit(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '+' || c == 'e' ||
          c == 'E')) {
      const char l = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      inf = inf || l == 'i' || l == 'n' || l == 'f';
      if (!inf) return Cell::kText;
    }
    buf[n++] = c;
  }
  if (inf) return (is("inf") || is("-inf") || is("+inf") || is("infinity") || is("-infinity")) ? Cell::kNotFinite
                                                                                                : Cell::kText;
  buf[n] = '\0';
  const char* begin = buf;
  if (*begin == '+') ++begin;
  const auto r = std::from_chars(begin, buf + n, value);
  if (r.ec == std::errc::result_out_of_range) return Cell::kNotFinite;
  if (r.ec != std::errc() || r.ptr != buf + n) return Cell::kText;
  return std::isfinite(value) ? Cell::kNumber : Cell::kNotFinite;
}

void splitFields(std::string_view line, char delim, std::vector<Field>& out) {
  out.clear();
  std::size_t start = 0;
  bool quoted = false;
  for (std::size_t i = 0; i <= line.size(); ++i) {
    if (i < line.size() && line[i] == '"') quoted = !quoted;
    if (i == line.size() || (line[i] == delim && !quoted)) {
      out.push_back({line.substr(start, i - start), start + 1});
      start = i + 1;
    }
  }
}

bool isComment(std::string_view t) { return !t.empty() && t[0] == '#'; }

bool looksNumeric(std::string_view field) {
  double v;
  return parseCell(field, false, v) == Cell::kNumber;
}

// A header: contains the delimiter; every field a non-empty name that is not a number, except
// empty fields at the end (RCbenchmark ends every line with the delimiter).
bool looksLikeHeader(std::string_view t, char delim) {
  if (t.find(delim) == std::string_view::npos) return false;
  std::vector<Field> f;
  splitFields(t, delim, f);
  while (!f.empty() && unquote(f.back().text).empty()) f.pop_back();
  if (f.size() < 2) return false;
  for (const auto& x : f) {
    const std::string_view name = unquote(x.text);
    if (name.empty() || looksNumeric(name)) return false;
  }
  return true;
}

char delimiterOf(std::string_view header) {
  const auto commas = std::count(header.begin(), header.end(), ',');
  const auto semis = std::count(header.begin(), header.end(), ';');
  const auto tabs = std::count(header.begin(), header.end(), '\t');
  if (semis > commas && semis >= tabs) return ';';
  if (tabs > commas && tabs > semis) return '\t';
  return ',';
}

// "Thrust (gf)" -> {"Thrust", "gf"}; "vbat[V]" -> {"vbat", "V"}; "pwm" -> {"pwm", ""}.
std::pair<std::string, std::string> splitUnit(const std::string& header) {
  const std::string t = trim(header);
  if (t.size() >= 3 && (t.back() == ')' || t.back() == ']')) {
    const char open = t.back() == ')' ? '(' : '[';
    const auto at = t.rfind(open);
    if (at != std::string::npos && at > 0)
      return {trim(t.substr(0, at)), trim(t.substr(at + 1, t.size() - at - 2))};
  }
  return {t, ""};
}

// A unit compared loosely: lower case, micro signs as `u`, every other non-letter dropped
// (`N·m`, `N*m`, `N.m` -> `nm`; `ozf·in` -> `ozfin`; `rad/s` -> `rads`).
std::string unitKey(const std::string& unit) {
  std::string out;
  for (std::size_t i = 0; i < unit.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(unit[i]);
    if ((c == 0xC2 && i + 1 < unit.size() && static_cast<unsigned char>(unit[i + 1]) == 0xB5) ||
        (c == 0xCE && i + 1 < unit.size() && static_cast<unsigned char>(unit[i + 1]) == 0xBC)) {
      out.push_back('u');
      ++i;
    } else if (c == 0xB5) {
      out.push_back('u');  // a Latin-1 micro sign
    } else if (c == '%') {
      out.push_back('%');
    } else if (std::isalnum(c)) {
      out.push_back(static_cast<char>(std::tolower(c)));
    }
  }
  return out;
}

const std::vector<KnownColumn>& knownColumns() {
  static const std::vector<KnownColumn> k = {
      // a time column under any of its usual names: seconds unless its name or unit says
      // milliseconds or microseconds (a logger's micros(), PX4's timestamps). A bare `time` is
      // taken as seconds, with a note; a bare `timestamp` is not taken at all (loggers count it in
      // seconds, milliseconds or microseconds alike): a note says how to map it.
      {"time", "t_s", "s", {{"s", 1.0}, {"ms", 1e-3}, {"us", 1e-6}, {"", 1.0}}},
      {"time_s", "t_s", "s", {{"", 1.0}}},
      {"time_ms", "t_s", "s", {{"", 1e-3}}},
      {"t_ms", "t_s", "s", {{"", 1e-3}}},
      {"time_us", "t_s", "s", {{"", 1e-6}}},
      {"t_us", "t_s", "s", {{"", 1e-6}}},
      {"timestamp", "t_s", "s", {{"s", 1.0}, {"ms", 1e-3}, {"us", 1e-6}}},
      {"timestamp_s", "t_s", "s", {{"", 1.0}}},
      {"timestamp_ms", "t_s", "s", {{"", 1e-3}}},
      {"timestamp_us", "t_s", "s", {{"", 1e-6}}},
      {"esc signal", "pwm_us", "µs", {{"us", 1.0}, {"ms", 1000.0}}, true},
      {"thrust", "force_g", "g",
       {{"n", kGramsPerNewton}, {"kgf", 1000.0}, {"gf", 1.0}, {"g", 1.0}, {"kg", 1000.0},
        {"lbf", 453.59237}, {"ozf", 28.349523125}, {"mn", kGramsPerNewton / 1000.0}}},
      {"torque", "torque_nm", "N·m",
       {{"nm", 1.0}, {"ozfin", 0.0070615518}, {"lbfin", 0.1129848290}, {"lbfft", 1.3558179483},
        {"kgfm", 9.80665}, {"nmm", 1e-3}, {"mnm", 1e-3}}},
      {"voltage", "vbat_v", "V", {{"v", 1.0}, {"mv", 1e-3}}},
      {"current", "current_a", "A", {{"a", 1.0}, {"ma", 1e-3}}},
      {"motor electrical speed", "rpm", "rpm", {{"rpm", 1.0}, {"rads", 60.0 / (2 * M_PI)}}},
      {"motor optical speed", "rpm_optical", "rpm", {{"rpm", 1.0}, {"rads", 60.0 / (2 * M_PI)}}},
      {"electrical power", "power_w", "W", {{"w", 1.0}}},
      {"mechanical power", "mech_power_w", "W", {{"w", 1.0}}},
      {"vibration", "vibration_g", "g (acceleration)", {{"g", 1.0}}},
  };
  return k;
}

// The columns the lab knows by name; a mapping onto one of them renames its source.
bool isKnownName(const std::string& n) {
  static const std::set<std::string> k = {"t_s",     "motor",     "pwm_us",     "force_g",
                                          "vbat_v",  "current_a", "rpm",        "temp_c",
                                          "dir",     "torque_nm", "power_w",    "rpm_optical",
                                          "mech_power_w", "vibration_g"};
  return k.count(n) > 0;
}

std::string joinHeaders(const std::vector<std::string>& names) {
  std::string have;
  for (const auto& n : names) have += (have.empty() ? "" : ", ") + n;
  return have;
}

std::string fmtLines(const std::vector<std::size_t>& lines, std::size_t total) {
  std::string s;
  for (std::size_t i = 0; i < lines.size() && i < 5; ++i) s += (i ? ", " : "") + std::to_string(lines[i]);
  if (total > 5) s += ", ...";
  return s;
}

}  // namespace lab::csv
