#include "lab/dataset.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>

namespace lab {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kGramsPerNewton = 1000.0 / 9.80665;

std::string trim(const std::string& s) {
  std::size_t a = 0, b = s.size();
  while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
  while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
  return s.substr(a, b - a);
}

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Parses a whole field as a number. `decimal_comma`: ',' is the decimal point.
// Returns false when the field is not a number; `missing` when the field is empty or "nan".
bool parseNumber(const std::string& field, bool decimal_comma, double& value, bool& missing) {
  missing = false;
  std::string t = trim(field);
  if (t.size() >= 2 && t.front() == '"' && t.back() == '"') t = trim(t.substr(1, t.size() - 2));
  if (t.empty() || lower(t) == "nan" || lower(t) == "na") {
    missing = true;
    value = kNaN;
    return true;
  }
  if (decimal_comma) std::replace(t.begin(), t.end(), ',', '.');
  // strtod accepts hex floats and "inf"; a measurement is a plain decimal number.
  for (char c : t) {
    if (!(std::isdigit(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '+' ||
          c == 'e' || c == 'E'))
      return false;
  }
  char* end = nullptr;
  value = std::strtod(t.c_str(), &end);
  if (end != t.c_str() + t.size()) return false;
  return std::isfinite(value);
}

struct Field {
  std::string text;
  std::size_t column;  // 1-based character position in the line
};

std::vector<Field> splitFields(const std::string& line, char delim) {
  std::vector<Field> out;
  std::size_t start = 0;
  bool quoted = false;
  for (std::size_t i = 0; i <= line.size(); ++i) {
    if (i < line.size() && line[i] == '"') quoted = !quoted;
    if (i == line.size() || (line[i] == delim && !quoted)) {
      out.push_back({line.substr(start, i - start), start + 1});
      start = i + 1;
    }
  }
  return out;
}

bool isComment(const std::string& t) { return !t.empty() && t[0] == '#'; }

bool looksNumeric(const std::string& field) {
  double v;
  bool missing;
  return parseNumber(field, false, v, missing) && !missing;
}

// A header: contains the delimiter, every field a non-empty name that is not a number.
bool looksLikeHeader(const std::string& t, char delim) {
  if (t.find(delim) == std::string::npos) return false;
  for (const auto& f : splitFields(t, delim)) {
    const std::string name = trim(f.text);
    if (name.empty() || looksNumeric(name)) return false;
  }
  return true;
}

char delimiterOf(const std::string& header) {
  const auto commas = std::count(header.begin(), header.end(), ',');
  const auto semis = std::count(header.begin(), header.end(), ';');
  const auto tabs = std::count(header.begin(), header.end(), '\t');
  if (semis > commas && semis >= tabs) return ';';
  if (tabs > commas && tabs > semis) return '\t';
  return ',';
}

// Known columns of RCbenchmark / Tyto Flight Stand exports, matched on the sanitized lower-case
// name's start (the micro sign is mangled differently by every spreadsheet).
struct TytoColumn {
  const char* prefix;
  const char* target;
  double scale;
};
const TytoColumn kTytoColumns[] = {
    {"esc_signal", "pwm_us", 1.0},
    {"thrust_n", "force_g", kGramsPerNewton},
    {"thrust_kgf", "force_g", 1000.0},
    {"voltage_v", "vbat_v", 1.0},
    {"current_a", "current_a", 1.0},
    {"motor_electrical_speed_rpm", "rpm", 1.0},
    {"time_s", "t_s", 1.0},
};

}  // namespace

InputError::InputError(const std::string& file, std::size_t line, std::size_t column,
                       const std::string& msg)
    : std::runtime_error(fmt::format("{}:{}:{}: {}", file, line, column, msg)),
      file_(file), line_(line), column_(column) {}

std::string sanitizeName(const std::string& name) {
  std::string out;
  bool underscore = false;
  for (unsigned char c : trim(name)) {
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
}

Dataset Dataset::subset(const std::vector<bool>& keep) const {
  Dataset out;
  out.names = names;
  out.columns.resize(names.size());
  out.notes = notes;
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
                                "': expected TARGET=SOURCE[*K|/K|+K|-K...], e.g. force_g=weight[g]/4");
  ColumnMap m;
  m.target = trim(text.substr(0, eq));
  std::string rhs = trim(text.substr(eq + 1));
  // The source is everything up to a trailing chain of operator-number pairs.
  std::vector<std::pair<char, double>> ops;
  for (;;) {
    std::size_t i = rhs.size();
    while (i > 0 && (std::isdigit(static_cast<unsigned char>(rhs[i - 1])) || rhs[i - 1] == '.' ||
                     rhs[i - 1] == ' '))
      --i;
    if (i == rhs.size() || i == 0) break;
    const char op = rhs[i - 1];
    if (op != '*' && op != '/' && op != '+' && op != '-') break;
    double v;
    bool missing;
    if (!parseNumber(rhs.substr(i), false, v, missing) || missing) break;
    if (op == '/' && v == 0.0)
      throw std::invalid_argument("--map '" + text + "': division by zero");
    ops.insert(ops.begin(), {op, v});
    rhs = trim(rhs.substr(0, i - 1));
  }
  if (rhs.empty()) throw std::invalid_argument("--map '" + text + "': no source column named");
  m.source = rhs;
  m.ops = ops;
  if (sanitizeName(m.target) != m.target)
    throw std::invalid_argument("--map '" + text + "': target '" + m.target +
                                "' must be an identifier (letters, digits, _)");
  return m;
}

Dataset parseText(const std::string& text_in, const std::string& file, const ReadOptions& options) {
  std::string text = text_in;
  if (text.rfind("\xEF\xBB\xBF", 0) == 0) text.erase(0, 3);  // UTF-8 byte order mark
  std::vector<std::string> lines;
  {
    std::size_t start = 0;
    for (std::size_t i = 0; i <= text.size(); ++i) {
      if (i == text.size() || text[i] == '\n') {
        std::string l = text.substr(start, i - start);
        if (!l.empty() && l.back() == '\r') l.pop_back();
        lines.push_back(l);
        start = i + 1;
      }
    }
  }
  // 1. The header: the first line naming columns (outside comments; failing that, a comment
  //    line naming pwm_us, as a log may print its header as "# pwm_us,force_g,...").
  std::size_t header_line = lines.size();
  std::string header;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string t = trim(lines[i]);
    if (t.empty() || isComment(t)) continue;
    const char d = delimiterOf(t);
    if (looksLikeHeader(t, d)) {
      header_line = i;
      header = t;
      break;
    }
    const auto fields = splitFields(t, d);
    if (t.find(d) != std::string::npos && !fields.empty() && looksNumeric(fields[0].text))
      break;  // data before any header
  }
  if (header.empty()) {
    for (std::size_t i = 0; i < lines.size(); ++i) {
      const std::string t = trim(lines[i]);
      if (!isComment(t)) continue;
      const std::string body = trim(t.substr(1));
      if (body.find("pwm_us") != std::string::npos && looksLikeHeader(body, delimiterOf(body))) {
        header_line = i;
        header = body;
        break;
      }
    }
  }
  if (header.empty()) {
    std::size_t first = 0;
    while (first < lines.size() && trim(lines[first]).empty()) ++first;
    throw InputError(file, first < lines.size() ? first + 1 : 1, 1,
                     "expected a header line naming the columns (e.g. pwm_us,force_g,vbat_v) "
                     "before the data; add one, or check the file is a CSV");
  }
  const char delim = delimiterOf(header);
  const bool decimal_comma = delim == ';';
  std::vector<std::string> raw_names;
  for (const auto& f : splitFields(header, delim)) {
    std::string n = trim(f.text);
    if (n.size() >= 2 && n.front() == '"' && n.back() == '"') n = n.substr(1, n.size() - 2);
    raw_names.push_back(n);
  }
  const std::size_t width = raw_names.size();

  // 2. Rows. A line whose first field is a number is data and must be complete; a line equal to
  //    the header starts a new segment; anything else (console prompts, progress) is skipped.
  struct RawRow {
    std::size_t line;
    int segment;
    std::vector<Field> fields;
  };
  std::vector<RawRow> raw;
  int segment = 0;
  std::size_t skipped = 0;
  for (std::size_t i = header_line + 1; i < lines.size(); ++i) {
    const std::string& l = lines[i];
    const std::string t = trim(l);
    if (t.empty() || isComment(t)) continue;
    if (t == header) {
      ++segment;
      continue;
    }
    auto fields = splitFields(l, delim);
    double first_value;
    bool first_missing;
    const bool data = parseNumber(fields[0].text, decimal_comma, first_value, first_missing) &&
                      !first_missing;
    if (!data) {
      ++skipped;
      continue;
    }
    if (fields.size() != width) {
      const std::size_t col = fields.size() > width ? fields[width].column : l.size() + 1;
      throw InputError(file, i + 1, col,
                       fmt::format("expected {} fields like the header on line {}, found {}",
                                   width, header_line + 1, fields.size()));
    }
    raw.push_back({i + 1, segment, std::move(fields)});
  }
  if (raw.empty())
    throw InputError(file, header_line + 1, 1,
                     "expected data rows after the header, found none");

  // 3. Columns: numeric ones are kept; a column whose cells are text in the first data row is
  //    a text column (a date, a comment) and dropped; a number column with a text cell is an error.
  Dataset out;
  std::vector<std::string> used;
  for (std::size_t c = 0; c < width; ++c) {
    double v;
    bool missing;
    const bool numeric_first = parseNumber(raw[0].fields[c].text, decimal_comma, v, missing);
    if (!numeric_first) {
      out.notes.push_back(fmt::format("{}: column '{}' holds text; ignored", file, raw_names[c]));
      continue;
    }
    std::vector<double> values;
    values.reserve(raw.size());
    for (const auto& r : raw) {
      if (!parseNumber(r.fields[c].text, decimal_comma, v, missing))
        throw InputError(file, r.line, r.fields[c].column,
                         fmt::format("expected a number in column '{}', found '{}'", raw_names[c],
                                     trim(r.fields[c].text)));
      values.push_back(v);
    }
    std::string name = sanitizeName(raw_names[c]);
    std::string unique = name;
    for (int k = 2; std::find(used.begin(), used.end(), unique) != used.end(); ++k)
      unique = fmt::format("{}_{}", name, k);
    used.push_back(unique);
    out.names.push_back(unique);
    out.columns.push_back(std::move(values));
  }
  for (const auto& r : raw) out.run.push_back(r.segment);
  (void)out.rows();
  if (skipped > 0)
    out.notes.push_back(fmt::format("{}: skipped {} line(s) that are neither data nor comments "
                                    "(console text)", file, skipped));

  // 4. Thrust-stand exports: RCbenchmark / Tyto names.
  if (!out.has("pwm_us") || !out.has("force_g")) {
    for (std::size_t c = 0; c < out.names.size(); ++c) {
      const std::string key = lower(out.names[c]);
      for (const auto& tc : kTytoColumns) {
        if (key.rfind(tc.prefix, 0) != 0 || out.has(tc.target)) continue;
        std::vector<double> v = out.columns[c];
        for (auto& x : v) x *= tc.scale;
        if (std::string(tc.target) == "force_g") {
          // Sign as logged: a stand mounted the other way logs thrust negative. Use the sign of
          // the larger-magnitude end.
          double lo = 0, hi = 0;
          for (double x : v)
            if (std::isfinite(x)) { lo = std::min(lo, x); hi = std::max(hi, x); }
          if (-lo > hi) {
            for (auto& x : v) x = -x;
            out.notes.push_back(fmt::format("{}: thrust logged negative; sign flipped", file));
          }
        }
        out.names.push_back(tc.target);
        out.columns.push_back(std::move(v));
        break;
      }
    }
  }

  // 5. User mappings.
  for (const auto& m : options.maps) {
    int src = -1;
    for (std::size_t c = 0; c < width && src < 0; ++c) {
      if (raw_names[c] == m.source || sanitizeName(raw_names[c]) == m.source)
        src = out.find(sanitizeName(raw_names[c]));
    }
    if (src < 0) src = out.find(m.source);
    if (src < 0) {
      std::string have;
      for (const auto& n : raw_names) have += (have.empty() ? "" : ", ") + n;
      throw InputError(file, header_line + 1, 1,
                       fmt::format("--map {}=...: no column '{}' in this file; columns are: {}",
                                   m.target, m.source, have));
    }
    std::vector<double> v = out.columns[static_cast<std::size_t>(src)];
    for (auto& x : v) {
      for (const auto& op : m.ops) {
        switch (op.first) {
          case '*': x *= op.second; break;
          case '/': x /= op.second; break;
          case '+': x += op.second; break;
          default: x -= op.second; break;
        }
      }
    }
    out.set(m.target, std::move(v));
    // A mapping to a known column is a renaming: the source must not reappear as a candidate
    // variable (the measured force above all).
    static const std::set<std::string> kKnown = {"t_s", "motor", "pwm_us", "force_g", "vbat_v",
                                                 "current_a", "rpm", "temp_c", "dir"};
    if (kKnown.count(m.target) && out.names[static_cast<std::size_t>(src)] != m.target) {
      out.notes.push_back(fmt::format("{}: column '{}' became {}", file, out.names[static_cast<std::size_t>(src)], m.target));
      out.names.erase(out.names.begin() + src);
      out.columns.erase(out.columns.begin() + src);
    }
  }

  // 6. Required cells present.
  for (const char* req : {"pwm_us", "force_g"}) {
    const int c = out.find(req);
    if (c < 0) continue;  // readFiles reports a missing column with the list of columns
    const auto& v = out.columns[static_cast<std::size_t>(c)];
    for (std::size_t i = 0; i < v.size(); ++i) {
      if (!std::isfinite(v[i])) {
        const int rc = [&] {
          for (std::size_t k = 0; k < width; ++k)
            if (sanitizeName(raw_names[k]) == req) return static_cast<int>(k);
          return 0;
        }();
        throw InputError(file, raw[i].line, raw[i].fields[static_cast<std::size_t>(rc)].column,
                         fmt::format("expected a number for {}, the cell is empty", req));
      }
    }
  }

  // 7. Runs: header segment x `run` column x motor.
  std::map<std::pair<int, long>, int> run_ids;
  const int motor_col = options.split_by_motor ? out.find("motor") : -1;
  const int run_col = out.find("run");
  std::vector<int> runs(out.rows());
  for (std::size_t i = 0; i < out.rows(); ++i) {
    long motor = 0;
    if (motor_col >= 0) {
      const double m = out.columns[static_cast<std::size_t>(motor_col)][i];
      motor = std::isfinite(m) ? std::lround(m) : -1;
    }
    long run_value = 0;
    if (run_col >= 0) {
      const double rv = out.columns[static_cast<std::size_t>(run_col)][i];
      run_value = std::isfinite(rv) ? std::lround(rv) : -1;
    }
    const auto key = std::make_pair(out.run[i] * 100000 + static_cast<int>(run_value % 100000), motor);
    auto it = run_ids.find(key);
    if (it == run_ids.end()) {
      it = run_ids.emplace(key, static_cast<int>(out.run_labels.size())).first;
      std::string label = file;
      if (segment > 0) label += fmt::format(" sweep {}", out.run[i] + 1);
      if (run_col >= 0) label += fmt::format(" run {}", run_value);
      if (motor_col >= 0) label += fmt::format(" motor {}", motor);
      out.run_labels.push_back(label);
    }
    runs[i] = it->second;
  }
  out.run = std::move(runs);
  return out;
}

Dataset readFile(const std::string& path, const ReadOptions& options) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, 0, "cannot open the file; check the path");
  std::stringstream ss;
  ss << in.rdbuf();
  return parseText(ss.str(), path, options);
}

Dataset readFiles(const std::vector<std::string>& paths, const ReadOptions& options) {
  if (paths.empty()) throw std::invalid_argument("no data files given");
  Dataset all;
  for (const auto& p : paths) {
    Dataset d = readFile(p, options);
    for (const char* req : {"pwm_us", "force_g"}) {
      if (!d.has(req)) {
        std::string have;
        for (const auto& n : d.names) have += (have.empty() ? "" : ", ") + n;
        throw InputError(p, 1, 1,
                         fmt::format("expected a column {}; the columns are: {}. Name it in the "
                                     "header or map one, e.g. --map {}={}",
                                     req, have, req,
                                     std::string(req) == "pwm_us" ? "pwm" : "weight[g]/4"));
      }
    }
    all.append(d);
  }
  return all;
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
