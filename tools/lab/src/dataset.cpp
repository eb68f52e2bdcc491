#include "lab/dataset.hpp"

#include <fmt/format.h>
#include <muParser.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <istream>
#include <limits>
#include <memory>
#include <regex>
#include <set>
#include <sstream>
#include <string_view>

namespace lab {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kGramsPerNewton = 1000.0 / 9.80665;

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

enum class Cell { kNumber, kMissing, kText, kNotFinite };

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

struct Field {
  std::string_view text;
  std::size_t column;  // 1-based character position in the line
};

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

// Lines ending in LF, CRLF or a lone CR (old Mac exports), streamed in blocks.
class LineReader {
 public:
  explicit LineReader(std::istream& in) : in_(in) {}
  // False at the end. `terminated`: the line ended with a line break (not cut by the end of file).
  bool next(std::string& line, bool& terminated) {
    line.clear();
    bool any = false;  // characters of this line were read
    for (;;) {
      if (pos_ == len_ && !fill()) {
        terminated = false;
        return any;
      }
      if (skip_lf_) {  // the LF of a CRLF
        skip_lf_ = false;
        if (buf_[pos_] == '\n') {
          ++pos_;
          continue;
        }
      }
      const char* b = buf_.data() + pos_;
      const char* e = buf_.data() + len_;
      const char* p = b;
      while (p < e && *p != '\n' && *p != '\r') ++p;
      line.append(b, p);
      any = any || p > b;
      pos_ += static_cast<std::size_t>(p - b);
      if (p < e) {
        skip_lf_ = *p == '\r';
        ++pos_;
        terminated = true;
        return true;
      }
    }
  }

 private:
  bool fill() {
    buf_.resize(1 << 16);
    in_.read(buf_.data(), static_cast<std::streamsize>(buf_.size()));
    len_ = static_cast<std::size_t>(in_.gcount());
    pos_ = 0;
    return len_ > 0;
  }
  std::istream& in_;
  std::vector<char> buf_;
  std::size_t pos_ = 0, len_ = 0;
  bool skip_lf_ = false;
};

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

// Known columns of RCbenchmark / Tyto exports: the column's name without its unit (compared in
// lower case), what it becomes, and the scale from each unit the software writes.
struct UnitScale {
  const char* unit;  // unitKey form
  double scale;
};
struct KnownColumn {
  const char* base;
  const char* target;
  const char* unit_label;  // the target's unit, for axis labels
  std::vector<UnitScale> units;
  bool any_unit = false;  // the ESC signal is in microseconds whatever a spreadsheet did to the µ
};
const std::vector<KnownColumn>& knownColumns() {
  static const std::vector<KnownColumn> k = {
      {"time", "t_s", "s", {{"s", 1.0}, {"ms", 1e-3}}},
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

// A raw column while the rows are read.
struct RawColumn {
  std::string header;  // as in the file (unquoted, trimmed)
  enum class Kind { kUndecided, kNumeric, kText } kind = Kind::kUndecided;
  std::vector<double> values;
  std::string first_text;
  std::size_t first_text_line = 0;
  std::size_t first_missing_line = 0, first_missing_column = 0;  // an empty cell
  std::size_t not_finite = 0, not_finite_line = 0, not_finite_column = 0;  // inf, 1e400
  std::string not_finite_text;
};

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

// The whole reader: one pass over the lines, then the columns, in seven phases. Each phase is a
// member of this one-shot parser; the state they share is its members.
class StreamParser {
 public:
  StreamParser(std::istream& in, const std::string& file, const ReadOptions& options)
      : reader_(in), file_(file), options_(options) {}

  Dataset parse() {
    readHeader();
    headerColumns();
    readRows();
    numericColumns();
    standColumns();
    userMaps();
    notFiniteCells();
    dropRowsWithoutDriveOrForce();
    labelRuns();
    return std::move(out_);
  }

 private:
  // 1. The header: the first line naming columns (outside comments; failing that, a comment
  //    line naming pwm_us before the data, as a log may print "# pwm_us,force_g,...").
  void readHeader() {
    std::string comment_header;
    std::size_t comment_header_line = 0, first_nonempty = 0;
    bool first = true;
    while (reader_.next(line_, terminated_)) {
      ++line_no_;
      if (first) {
        first = false;
        if (line_.rfind("\xEF\xBB\xBF", 0) == 0) line_.erase(0, 3);  // UTF-8 byte order mark
      }
      const std::string_view t = trimView(line_);
      if (t.empty()) continue;
      if (!first_nonempty) first_nonempty = line_no_;
      if (isComment(t)) {
        const std::string_view body = trimView(t.substr(1));
        if (comment_header.empty() && body.find("pwm_us") != std::string_view::npos &&
            looksLikeHeader(body, delimiterOf(body))) {
          comment_header = std::string(body);
          comment_header_line = line_no_;
        }
        continue;
      }
      const char d = delimiterOf(t);
      if (looksLikeHeader(t, d)) {
        header_ = std::string(t);
        header_line_ = line_no_;
        break;
      }
      splitFields(t, d, fields_);
      if (t.find(d) != std::string_view::npos && !fields_.empty() && looksNumeric(fields_[0].text)) {
        if (!comment_header.empty()) {  // data after a commented header
          have_pending_data_ = true;
          pending_ = line_;
          pending_terminated_ = terminated_;
          pending_line_ = line_no_;
        }
        break;  // data before any header
      }
    }
    if (header_.empty() && !comment_header.empty()) {
      header_ = comment_header;
      header_line_ = comment_header_line;
    }
    if (header_.empty())
      throw InputError(file_, first_nonempty ? first_nonempty : 1, 1,
                       "expected a header line naming the columns (e.g. pwm_us,force_g,vbat_v) "
                       "before the data; add one, or check the file is a CSV");
  }

  // The header's fields: one raw column each; empty names at the end mean every line ends with
  // the delimiter.
  void headerColumns() {
    delim_ = delimiterOf(header_);
    decimal_comma_ = delim_ == ';';
    std::vector<Field> hf;
    splitFields(header_, delim_, hf);
    while (!hf.empty() && unquote(hf.back().text).empty()) {
      hf.pop_back();
      ++trailing_;
    }
    for (const auto& f : hf) {
      RawColumn c;
      c.header = std::string(unquote(f.text));
      for (std::size_t k = 0; k < raw_.size(); ++k)
        if (raw_[k].header == c.header)
          throw InputError(file_, header_line_, f.column,
                           fmt::format("column '{}' appears twice in the header (columns {} and {}); "
                                       "rename one so each variable has one name",
                                       c.header, k + 1, raw_.size() + 1));
      raw_.push_back(std::move(c));
    }
    width_ = raw_.size();
  }

  // 2. Rows. A line whose first field is a number is data; a line equal to the header starts a
  //    new segment; anything else (console prompts, progress) is skipped. The last line of a
  //    file cut short (no line break, fields missing) is dropped with a note.
  void readRows() {
    if (have_pending_data_) handleLine(pending_, pending_terminated_, pending_line_);
    while (reader_.next(line_, terminated_)) handleLine(line_, terminated_, ++line_no_);
    if (segment_of_row_.empty())
      throw InputError(file_, header_line_, 1, "expected data rows after the header, found none");
  }

  void handleLine(const std::string& l, bool term, std::size_t no) {
    const std::string_view t = trimView(l);
    if (t.empty() || isComment(t)) return;
    if (t == header_) {
      ++segment_;
      return;
    }
    splitFields(l, delim_, fields_);
    double first_value;
    if (parseCell(fields_[0].text, decimal_comma_, first_value) != Cell::kNumber) {
      ++skipped_;
      return;
    }
    std::size_t n = fields_.size();
    // the trailing delimiter(s): extra fields that are empty
    while (n > width_ && unquote(fields_[n - 1].text).empty()) --n;
    const bool cut = !term && (n < width_ || (trailing_ > 0 && fields_.size() < width_ + trailing_));
    if (cut) {
      truncated_note_ = fmt::format("{}: line {} (the last) is cut short ({} of {} fields, no line break): "
                                    "dropped", file_, no, n, width_);
      return;
    }
    if (n != width_) {
      const std::size_t col = n > width_ ? fields_[width_].column : l.size() + 1;
      throw InputError(file_, no, col,
                       fmt::format("expected {} fields like the header on line {}, found {}", width_,
                                   header_line_, n));
    }
    for (std::size_t c = 0; c < width_; ++c) cell(raw_[c], fields_[c], no);
    segment_of_row_.push_back(segment_);
    line_of_row_.push_back(no);
  }

  // One cell of a data line into its raw column.
  void cell(RawColumn& rc, const Field& field, std::size_t no) {
    if (rc.kind == RawColumn::Kind::kText) return;
    double v;
    switch (parseCell(field.text, decimal_comma_, v)) {
      case Cell::kNumber:
        rc.kind = RawColumn::Kind::kNumeric;
        break;
      case Cell::kMissing:
        if (!rc.first_missing_line) rc.first_missing_line = no, rc.first_missing_column = field.column;
        break;
      case Cell::kNotFinite:
        // refused if the column is used as the drive or the force, else read as not logged
        if (!rc.not_finite++) {
          rc.not_finite_line = no;
          rc.not_finite_column = field.column;
          rc.not_finite_text = std::string(trimView(field.text));
        }
        v = kNaN;
        break;
      case Cell::kText:
        if (rc.kind == RawColumn::Kind::kNumeric)
          throw InputError(file_, no, field.column,
                           fmt::format("expected a number in column '{}', found '{}'", rc.header,
                                       unquote(field.text)));
        // a text column (a message, a date): kept aside, ignored unless used
        rc.kind = RawColumn::Kind::kText;
        rc.first_text = std::string(unquote(field.text));
        rc.first_text_line = no;
        rc.values.clear();
        rc.values.shrink_to_fit();
        return;
    }
    rc.values.push_back(v);
  }

  // 3. Columns: numeric ones are kept under their identifier; text and empty columns are
  //    set aside with a note.
  void numericColumns() {
    std::vector<std::string> empty;
    for (auto& rc : raw_) {
      if (rc.kind == RawColumn::Kind::kText) {
        out_.notes.push_back(fmt::format("{}: column '{}' holds text ('{}' on line {}); ignored", file_,
                                         rc.header, rc.first_text, rc.first_text_line));
        continue;
      }
      if (rc.kind == RawColumn::Kind::kUndecided) {
        const std::string name = sanitizeName(rc.header);
        if (name == "pwm_us" || name == "force_g")
          throw InputError(file_, rc.first_missing_line, rc.first_missing_column,
                           fmt::format("expected a number for {}, the cell is empty on every data line", name));
        empty.push_back("'" + rc.header + "'");
        continue;
      }
      const std::string name = sanitizeName(rc.header);
      const int clash = out_.find(name);
      if (clash >= 0)
        throw InputError(file_, header_line_, 1,
                         fmt::format("columns '{}' and '{}' both read as {}; rename one so each "
                                     "variable has one name",
                                     origin_[static_cast<std::size_t>(clash)], rc.header, name));
      out_.names.push_back(name);
      out_.columns.push_back(std::move(rc.values));
      origin_.push_back(rc.header);
      source_of_.push_back(&rc);
    }
    if (!empty.empty())
      out_.notes.push_back(fmt::format("{}: {} {} empty; ignored", file_, fmt::join(empty, ", "),
                                       empty.size() == 1 ? "is" : "are"));
    out_.run.assign(segment_of_row_.begin(), segment_of_row_.end());
    if (skipped_ > 0)
      out_.notes.push_back(fmt::format("{}: skipped {} line(s) that are neither data nor comments "
                                       "(console text)", file_, skipped_));
    if (!truncated_note_.empty()) out_.notes.push_back(truncated_note_);
  }

  // 4. Thrust-stand exports (RCbenchmark / Tyto): each known column becomes the lab's name in
  //    the lab's unit, replacing the raw one (one variable, one name); the file's name and unit
  //    stay as the axis label. A --map onto the same name takes over.
  void standColumns() {
    std::set<std::string> mapped_targets;
    for (const auto& m : options_.maps) mapped_targets.insert(m.target);
    for (std::size_t c = 0; c < out_.names.size(); ++c) {
      const auto [base, unit] = splitUnit(origin_[c]);
      const std::string key = lower(base);
      for (const auto& kc : knownColumns()) {
        if (key != kc.base) continue;
        if (mapped_targets.count(kc.target)) break;
        standColumn(c, kc, base, unit);
        break;
      }
    }
  }

  // Column c is the stand's `kc`, logged in `unit`: converted and renamed, or left with a note.
  void standColumn(std::size_t c, const KnownColumn& kc, const std::string& base, const std::string& unit) {
    const std::string uk = unitKey(unit);
    double scale = kNaN;
    for (const auto& us : kc.units)
      if (us.unit == uk) scale = us.scale;
    if (!std::isfinite(scale) && kc.any_unit && uk.find('%') == std::string::npos) scale = 1.0;
    if (!std::isfinite(scale)) {
      out_.notes.push_back(fmt::format("{}: column '{}': unit '{}' is not one the lab converts; kept as {} "
                                       "(map it yourself: --map {}=...)",
                                       file_, origin_[c], unit, out_.names[c], kc.target));
      return;
    }
    const int other = out_.find(kc.target);
    if (other >= 0 && static_cast<std::size_t>(other) != c)
      throw InputError(file_, header_line_, 1,
                       fmt::format("columns '{}' and '{}' are both {}; keep one: --map {}='{}'",
                                   origin_[static_cast<std::size_t>(other)], origin_[c], kc.target,
                                   kc.target, origin_[c]));
    auto& v = out_.columns[c];
    if (scale != 1.0)
      for (auto& x : v) x *= scale;
    std::string label = fmt::format("{} ({})", base, kc.unit_label);
    if (scale != 1.0) label += fmt::format(", logged in {}", unit);
    if (std::string(kc.target) == "force_g") standThrustSign(c, scale);
    out_.names[c] = kc.target;
    out_.labels[kc.target] = label;
  }

  // Sign as logged: a stand mounted the other way logs thrust negative. Judged by the
  // larger-magnitude end; said, and said how to do it by hand.
  void standThrustSign(std::size_t c, double scale) {
    auto& v = out_.columns[c];
    double lo = 0, hi = 0;
    for (double x : v)
      if (std::isfinite(x)) lo = std::min(lo, x), hi = std::max(hi, x);
    if (-lo > hi) {
      for (auto& x : v) x = -x;
      out_.notes.push_back(fmt::format(
          "{}: thrust logged negative (the stand pulls the other way): sign flipped, as "
          "--map 'force_g=-{}{}' would do",
          file_, origin_[c],
          scale != 1.0 ? fmt::format("*{:.6g}", scale) : std::string()));
    }
  }

  // 5. User mappings, all computed from the columns as read, then applied.
  struct Mapped {
    const ColumnMap* map;
    std::vector<double> values;
    int source;
  };

  void userMaps() {
    std::vector<Mapped> mapped;
    for (const auto& m : options_.maps) {
      const int src = mapSource(m);
      mapped.push_back({&m, mappedValues(m, src), src});
    }
    std::vector<std::string> drop;
    for (auto& mp : mapped) applyMap(mp, drop);
    for (const auto& name : drop) dropRenamed(name);
  }

  // The column a mapping reads; throws naming the columns when there is none.
  int mapSource(const ColumnMap& m) const {
    int src = -1;
    for (std::size_t c = 0; c < origin_.size() && src < 0; ++c)
      if (origin_[c] == m.source || sanitizeName(origin_[c]) == m.source) src = static_cast<int>(c);
    if (src < 0) src = out_.find(m.source);
    if (src >= 0) return src;
    for (const auto& rc : raw_)
      if (rc.header == m.source && rc.kind == RawColumn::Kind::kText)
        throw InputError(file_, header_line_, 1,
                         fmt::format("--map {}={}: column '{}' holds text ('{}' on line {}), not numbers",
                                     m.target, m.text, m.source, rc.first_text, rc.first_text_line));
    std::vector<std::string> headers;
    for (const auto& rc : raw_) headers.push_back(rc.header);
    throw InputError(file_, header_line_, 1,
                     fmt::format("--map {}=...: no column '{}' in this file; columns are: {}", m.target,
                                 m.source, joinHeaders(headers)));
  }

  std::vector<double> mappedValues(const ColumnMap& m, int src) const {
    std::vector<double> v = out_.columns[static_cast<std::size_t>(src)];
    for (std::size_t i = 0; i < v.size(); ++i) {
      double& x = v[i];
      if (m.negate) x = -x;
      for (const auto& op : m.ops) {
        switch (op.first) {
          case '*': x *= op.second; break;
          case '/': x /= op.second; break;
          case '+': x += op.second; break;
          default: x -= op.second; break;
        }
      }
      if (std::isinf(x))
        throw InputError(file_, line_of_row_[i], 1,
                         fmt::format("--map {}={} gives a value that is not finite on this line", m.target, m.text));
    }
    return v;
  }

  void applyMap(Mapped& mp, std::vector<std::string>& drop) {
    const ColumnMap& m = *mp.map;
    const std::string src_name = out_.names[static_cast<std::size_t>(mp.source)];
    if (m.target == "force_g") {
      double lo = 0, hi = 0;
      for (double x : mp.values)
        if (std::isfinite(x)) lo = std::min(lo, x), hi = std::max(hi, x);
      if (-lo > hi)
        throw InputError(file_, header_line_, 1,
                         fmt::format("--map force_g={} gives a thrust that is negative at its larger end "
                                     "({:.4g} g against {:.4g} g): the force must grow with the drive. If "
                                     "the stand logs thrust negative, say so: --map 'force_g={}'",
                                     m.text, lo, hi,
                                     m.negate ? m.text.substr(m.text.find('-') + 1) : "-" + m.text));
    }
    const int existing = out_.find(m.target);
    out_.set(m.target, std::move(mp.values));
    if (existing < 0) source_of_.push_back(source_of_[static_cast<std::size_t>(mp.source)]);
    else source_of_[static_cast<std::size_t>(existing)] = source_of_[static_cast<std::size_t>(mp.source)];
    out_.labels[m.target] = m.text;
    // A mapping to a known column is a renaming: the source must not reappear as a candidate
    // variable (the measured force above all).
    if (isKnownName(m.target) && src_name != m.target) drop.push_back(src_name);
  }

  void dropRenamed(const std::string& name) {
    const int c = out_.find(name);
    if (c < 0) return;
    bool target = false;
    for (const auto& m : options_.maps) target = target || m.target == name;
    if (target) return;
    out_.notes.push_back(fmt::format("{}: column '{}' became {}", file_, name, [&] {
      for (const auto& m : options_.maps)
        if (m.source == name || sanitizeName(m.source) == name) return m.target;
      return std::string("a mapped column");
    }()));
    out_.labels.erase(name);
    source_of_.erase(source_of_.begin() + c);
    out_.names.erase(out_.names.begin() + c);
    out_.columns.erase(out_.columns.begin() + c);
  }

  // Numbers that are not finite (inf, 1e400): an error in the drive or the force, else that
  // cell is not logged, with a note.
  void notFiniteCells() {
    std::set<const RawColumn*> noted;
    for (std::size_t c = 0; c < out_.names.size(); ++c) {
      const RawColumn* rc = c < source_of_.size() ? source_of_[c] : nullptr;
      if (!rc || !rc->not_finite) continue;
      if (out_.names[c] == "pwm_us" || out_.names[c] == "force_g")
        throw InputError(file_, rc->not_finite_line, rc->not_finite_column,
                         fmt::format("'{}' in column '{}' is not a finite number; fix the cell or delete the row",
                                     rc->not_finite_text, rc->header));
      if (!noted.insert(rc).second) continue;
      out_.notes.push_back(fmt::format("{}: column '{}' has {} cell(s) that are not finite numbers ('{}' on line {}); "
                                       "read as not logged there",
                                       file_, rc->header, rc->not_finite, rc->not_finite_text, rc->not_finite_line));
    }
  }

  // 6. Rows without a drive or a force: dropped with a note saying which; a file without any is
  //    an error at the first.
  void dropRowsWithoutDriveOrForce() {
    const int pc = out_.find("pwm_us"), fc = out_.find("force_g");
    if (pc < 0 && fc < 0) return;
    std::vector<bool> keep(out_.rows(), true);
    std::vector<std::size_t> lines;
    std::size_t dropped = 0;
    for (std::size_t i = 0; i < out_.rows(); ++i) {
      const bool bad = (pc >= 0 && !std::isfinite(out_.columns[static_cast<std::size_t>(pc)][i])) ||
                       (fc >= 0 && !std::isfinite(out_.columns[static_cast<std::size_t>(fc)][i]));
      if (!bad) continue;
      keep[i] = false;
      ++dropped;
      if (lines.size() < 5) lines.push_back(line_of_row_[i]);
    }
    if (dropped == out_.rows()) {
      const bool pwm = pc >= 0 && !std::isfinite(out_.columns[static_cast<std::size_t>(pc)][0]);
      const int c = pwm ? pc : fc;
      const RawColumn* rc =
          static_cast<std::size_t>(c) < source_of_.size() ? source_of_[static_cast<std::size_t>(c)] : nullptr;
      throw InputError(file_, rc && rc->first_missing_line ? rc->first_missing_line : line_of_row_[0],
                       rc && rc->first_missing_line ? rc->first_missing_column : 1,
                       fmt::format("expected a number for {}, the cell is empty on every data line",
                                   pwm ? "pwm_us" : "force_g"));
    }
    if (dropped == 0) return;
    out_.notes.push_back(fmt::format("{}: dropped {} row(s) with no number for pwm_us or force_g (line {})",
                                     file_, dropped, fmtLines(lines, dropped)));
    // (runs are not labelled yet: filter the columns, the segments and the line numbers)
    auto filter = [&](auto& v) {
      std::size_t k = 0;
      for (std::size_t i = 0; i < keep.size(); ++i)
        if (keep[i]) v[k++] = v[i];
      v.resize(k);
    };
    for (auto& c : out_.columns) filter(c);
    filter(out_.run);
    filter(line_of_row_);
  }

  // 7. Runs: header segment x `run` column x motor.
  void labelRuns() {
    std::map<std::pair<long, long>, int> run_ids;
    const int motor_col = options_.split_by_motor ? out_.find("motor") : -1;
    const int run_col = out_.find("run");
    std::vector<int> runs(out_.rows());
    for (std::size_t i = 0; i < out_.rows(); ++i) {
      long motor = 0;
      if (motor_col >= 0) {
        const double m = out_.columns[static_cast<std::size_t>(motor_col)][i];
        motor = std::isfinite(m) ? std::lround(m) : -1;
      }
      long run_value = 0;
      if (run_col >= 0) {
        const double rv = out_.columns[static_cast<std::size_t>(run_col)][i];
        run_value = std::isfinite(rv) ? std::lround(rv) : -1;
      }
      const auto key = std::make_pair(static_cast<long>(out_.run[i]) * 100000 + run_value % 100000, motor);
      auto it = run_ids.find(key);
      if (it == run_ids.end()) {
        it = run_ids.emplace(key, static_cast<int>(run_ids.size())).first;
        std::string label = file_;
        if (segment_ > 0) label += fmt::format(" sweep {}", out_.run[i] + 1);
        if (run_col >= 0) label += fmt::format(" run {}", run_value);
        if (motor_col >= 0) label += fmt::format(" motor {}", motor);
        out_.run_labels.push_back(label);
      }
      runs[i] = it->second;
    }
    out_.run = std::move(runs);
  }

  LineReader reader_;
  const std::string& file_;
  const ReadOptions& options_;
  // the lines
  std::string line_;
  bool terminated_ = true;
  std::size_t line_no_ = 0;
  std::vector<Field> fields_;
  // the header
  std::string header_;
  std::size_t header_line_ = 0;
  bool have_pending_data_ = false;  // a data line read while looking for the header
  std::string pending_;
  bool pending_terminated_ = true;
  std::size_t pending_line_ = 0;
  char delim_ = ',';
  bool decimal_comma_ = false;
  std::vector<RawColumn> raw_;
  std::size_t trailing_ = 0;  // empty names at the end: every line ends with the delimiter
  std::size_t width_ = 0;
  // the rows
  std::vector<int> segment_of_row_;
  std::vector<std::size_t> line_of_row_;
  int segment_ = 0;
  std::size_t skipped_ = 0;
  std::string truncated_note_;
  // the columns
  Dataset out_;
  std::vector<std::string> origin_;            // header text of each out column
  std::vector<const RawColumn*> source_of_;    // and its raw column
};

Dataset parseStream(std::istream& in, const std::string& file, const ReadOptions& options) {
  return StreamParser(in, file, options).parse();
}

}  // namespace

InputError::InputError(const std::string& file, std::size_t line, std::size_t column,
                       const std::string& msg)
    : std::runtime_error(fmt::format("{}:{}:{}: {}", file, line, column, msg)),
      file_(file), line_(line), column_(column) {}

std::string sanitizeName(const std::string& name) {
  std::string out;
  bool underscore = false;
  const std::string t = trim(name);
  for (std::size_t i = 0; i < t.size(); ++i) {
    unsigned char c = static_cast<unsigned char>(t[i]);
    // micro signs (U+00B5, U+03BC) and a Latin-1 one read as `u`, so `µs` stays microseconds
    if ((c == 0xC2 && i + 1 < t.size() && static_cast<unsigned char>(t[i + 1]) == 0xB5) ||
        (c == 0xCE && i + 1 < t.size() && static_cast<unsigned char>(t[i + 1]) == 0xBC)) {
      ++i;
      c = 'u';
    } else if (c == 0xB5) {
      c = 'u';
    }
    if (std::isalnum(c) || c == '_') {
      out.push_back(static_cast<char>(c));
      underscore = c == '_';
    } else if (c < 0x80 && !underscore && !out.empty()) {
      out.push_back('_');
      underscore = true;
    }
  }
  while (!out.empty() && out.back() == '_') out.pop_back();
  if (out.empty()) out = "col";
  if (std::isdigit(static_cast<unsigned char>(out[0]))) out = "c" + out;
  return out;
}

std::string axisLabel(const Dataset& data, const std::string& column) {
  const auto it = data.labels.find(column);
  if (it != data.labels.end() && !it->second.empty()) return it->second;
  static const std::map<std::string, std::string> kDefaults = {
      {"pwm_us", "PWM (µs)"},
      {"force_g", "force (g)"},
      {"vbat_v", "battery voltage (V)"},
      {"current_a", "current (A)"},
      {"t_s", "time (s)"},
      {"rpm", "speed (rpm)"},
      {"temp_c", "temperature (°C)"},
      {"dir", "sweep direction (+1 up, -1 down)"},
      {"motor", "motor"},
      {"run", "run (file or sweep)"},
      {"dpwm_us", "PWM step from the previous sample (µs)"},
      {"rho_kg_m3", "air density (kg/m³)"},
      {"torque_nm", "torque (N·m)"},
      {"power_w", "electrical power (W)"},
  };
  const auto d = kDefaults.find(column);
  return d != kDefaults.end() ? d->second : column;
}

int Dataset::find(const std::string& name) const {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return static_cast<int>(i);
  return -1;
}

const std::vector<double>& Dataset::col(const std::string& name) const {
  const int i = find(name);
  if (i < 0) throw std::invalid_argument("the data has no column '" + name + "'");
  return columns[static_cast<std::size_t>(i)];
}

void Dataset::set(const std::string& name, std::vector<double> values) {
  if (values.size() != rows())
    throw std::invalid_argument("column '" + name + "' has the wrong number of rows");
  const int i = find(name);
  if (i >= 0) {
    columns[static_cast<std::size_t>(i)] = std::move(values);
  } else {
    names.push_back(name);
    columns.push_back(std::move(values));
  }
}

void Dataset::append(const Dataset& other) {
  const std::size_t n0 = rows(), n1 = other.rows();
  for (std::size_t c = 0; c < names.size(); ++c)
    if (other.find(names[c]) < 0) columns[c].resize(n0 + n1, kNaN);
  for (std::size_t c = 0; c < other.names.size(); ++c) {
    int mine = find(other.names[c]);
    if (mine < 0) {
      names.push_back(other.names[c]);
      columns.emplace_back(n0, kNaN);
      mine = static_cast<int>(names.size()) - 1;
    }
    auto& dst = columns[static_cast<std::size_t>(mine)];
    dst.insert(dst.end(), other.columns[c].begin(), other.columns[c].end());
  }
  const int run0 = static_cast<int>(run_labels.size());
  for (int r : other.run) run.push_back(r + run0);
  run_labels.insert(run_labels.end(), other.run_labels.begin(), other.run_labels.end());
  notes.insert(notes.end(), other.notes.begin(), other.notes.end());
  for (const auto& [k, v] : other.labels) labels.emplace(k, v);
}

Dataset Dataset::subset(const std::vector<bool>& keep) const {
  Dataset out;
  out.names = names;
  out.columns.resize(names.size());
  out.notes = notes;
  out.labels = labels;
  std::size_t n = 0;
  for (std::size_t i = 0; i < rows(); ++i) n += keep[i] ? 1 : 0;
  for (auto& c : out.columns) c.reserve(n);
  out.run.reserve(n);
  std::map<int, int> run_map;
  for (std::size_t i = 0; i < rows(); ++i) {
    if (!keep[i]) continue;
    for (std::size_t c = 0; c < names.size(); ++c) out.columns[c].push_back(columns[c][i]);
    auto it = run_map.find(run[i]);
    if (it == run_map.end()) {
      it = run_map.emplace(run[i], static_cast<int>(out.run_labels.size())).first;
      out.run_labels.push_back(run_labels[static_cast<std::size_t>(run[i])]);
    }
    out.run.push_back(it->second);
  }
  return out;
}

ColumnMap parseColumnMap(const std::string& text) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 >= text.size())
    throw std::invalid_argument("--map '" + text +
                                "': expected TARGET=[-]SOURCE[*K|/K|+K|-K...], e.g. force_g=weight[g]/4 "
                                "or force_g=-Thrust (N)*101.97");
  ColumnMap m;
  m.target = trim(text.substr(0, eq));
  std::string rhs = trim(text.substr(eq + 1));
  m.text = rhs;
  // The source is everything up to a trailing chain of operator-number pairs; a number may
  // carry its own sign (`*-101.97`).
  static const std::regex kTail(R"(^(.*?)\s*([*/+-])\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*$)");
  std::vector<std::pair<char, double>> ops;
  std::smatch mt;
  while (std::regex_match(rhs, mt, kTail) && !trim(mt[1].str()).empty() &&
         trim(mt[1].str()) != "-") {
    const double v = std::strtod(mt[3].str().c_str(), nullptr);
    const char op = mt[2].str()[0];
    if (!std::isfinite(v)) throw std::invalid_argument("--map '" + text + "': " + mt[3].str() + " is not a finite number");
    if (op == '/' && v == 0.0) throw std::invalid_argument("--map '" + text + "': division by zero");
    ops.insert(ops.begin(), {op, v});
    rhs = trim(mt[1].str());
  }
  if (!rhs.empty() && rhs[0] == '-') {  // unary minus: the sign flip, written out
    m.negate = true;
    rhs = trim(rhs.substr(1));
  }
  if (rhs.empty()) throw std::invalid_argument("--map '" + text + "': no source column named");
  m.source = rhs;
  m.ops = ops;
  if (sanitizeName(m.target) != m.target)
    throw std::invalid_argument("--map '" + text + "': target '" + m.target +
                                "' must be an identifier (letters, digits, _)");
  return m;
}

Dataset parseText(const std::string& text, const std::string& file, const ReadOptions& options) {
  std::istringstream in(text);
  return parseStream(in, file, options);
}

Dataset readFile(const std::string& path, const ReadOptions& options) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, 0, "cannot open the file; check the path");
  return parseStream(in, path, options);
}

Dataset readFiles(const std::vector<std::string>& paths, const ReadOptions& options) {
  if (paths.empty()) throw std::invalid_argument("no data files given");
  Dataset all;
  for (const auto& p : paths) {
    Dataset d = readFile(p, options);
    for (const char* req : {"pwm_us", "force_g"}) {
      if (!d.has(req)) {
        throw InputError(p, 1, 1,
                         fmt::format("expected a column {}; the columns are: {}. Name it in the "
                                     "header or map one, e.g. --map {}={}",
                                     req, joinHeaders(d.names), req,
                                     std::string(req) == "pwm_us" ? "pwm" : "weight[g]/4"));
      }
    }
    if (all.rows() == 0 && all.names.empty()) all = std::move(d);
    else all.append(d);
  }
  return all;
}

RowSelection selectRows(Dataset& data, const std::string& expression) {
  // words for the logical operators, as a person writes them
  std::string expr = std::regex_replace(expression, std::regex(R"(\band\b)"), "&&");
  expr = std::regex_replace(expr, std::regex(R"(\bor\b)"), "||");
  mu::Parser parser;
  std::vector<double> slots(data.names.size() + 1, 0.0);
  std::string names;
  try {
    for (std::size_t c = 0; c < data.names.size(); ++c) {
      parser.DefineVar(data.names[c], &slots[c]);
      names += (names.empty() ? "" : ", ") + data.names[c];
    }
    if (!data.has("run")) {
      parser.DefineVar("run", &slots.back());
      names += ", run";
    }
    parser.SetExpr(expr);
    parser.Eval();
  } catch (mu::Parser::exception_type& e) {
    throw std::invalid_argument(fmt::format("--where '{}': {} at position {}; the columns are: {} "
                                            "(e.g. --where 'pwm_us < 1840 and dir > 0')",
                                            expression, e.GetMsg(), e.GetPos() + 1, names));
  }
  RowSelection sel;
  std::vector<bool> keep(data.rows(), false);
  for (std::size_t i = 0; i < data.rows(); ++i) {
    for (std::size_t c = 0; c < data.names.size(); ++c) slots[c] = data.columns[c][i];
    slots.back() = data.run[i];
    double v;
    try {
      v = parser.Eval();
    } catch (mu::Parser::exception_type&) {
      v = kNaN;
    }
    if (!std::isfinite(v)) ++sel.undefined;
    keep[i] = std::isfinite(v) && v != 0.0;
    if (keep[i]) ++sel.kept; else ++sel.dropped;
  }
  if (sel.kept == 0)
    throw std::invalid_argument(fmt::format("--where '{}' keeps none of the {} rows; loosen it", expression,
                                            data.rows()));
  if (sel.dropped > 0) data = data.subset(keep);
  return sel;
}

std::string toCsv(const Dataset& data, const std::vector<std::string>& comments) {
  std::string out;
  for (const auto& c : comments) out += "# " + c + "\n";
  for (std::size_t c = 0; c < data.names.size(); ++c) out += (c ? "," : "") + data.names[c];
  out += "\n";
  for (std::size_t i = 0; i < data.rows(); ++i) {
    for (std::size_t c = 0; c < data.names.size(); ++c) {
      if (c) out += ",";
      const double v = data.columns[c][i];
      if (std::isfinite(v)) out += fmt::format("{:.6g}", v);
    }
    out += "\n";
  }
  return out;
}

}  // namespace lab
