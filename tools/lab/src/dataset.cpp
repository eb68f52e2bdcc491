// Data sets: the Dataset's own operations, names and labels, --map and --where, reading files
// (the CSV reader itself is csv_*.cpp), and writing the project's CSV.
#include "lab/dataset.hpp"

#include <fmt/format.h>
#include <muParser.h>

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include "csv_reader.hpp"

namespace lab {

using csv::joinHeaders;
using csv::kNaN;
using csv::parseStream;
using csv::trim;

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
