// The CSV reader, phases 3-7: numeric columns under their identifiers, stand exports' known
// columns in the lab's units, the user's --map, cells that are not finite, rows without a drive
// or a force, and the runs (header segment x `run` column x motor).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "csv_reader.hpp"

namespace lab::csv {

// 3. Columns: numeric ones are kept under their identifier; text and empty columns are
//    set aside with a note.
void StreamParser::numericColumns() {
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
void StreamParser::standColumns() {
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
void StreamParser::standColumn(std::size_t c, const KnownColumn& kc, const std::string& base, const std::string& unit) {
  const std::string uk = unitKey(unit);
  double scale = kNaN;
  for (const auto& us : kc.units)
    if (us.unit == uk) scale = us.scale;
  if (!std::isfinite(scale) && kc.any_unit && uk.find('%') == std::string::npos) scale = 1.0;
  if (!std::isfinite(scale) && uk.empty() && std::string(kc.target) == "t_s") {
    out_.notes.push_back(fmt::format("{}: column '{}' has no unit, so it is not read as the time (t_s): "
                                     "--map t_s={}/1000000 if it counts microseconds (PX4, micros()), "
                                     "--map t_s={}/1000 for milliseconds, --map t_s={} for seconds",
                                     file_, origin_[c], out_.names[c], out_.names[c], out_.names[c]));
    return;
  }
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
  if (uk.empty() && lower(base) == "time")
    out_.notes.push_back(fmt::format("{}: column '{}' has no unit: read as seconds (t_s); if it counts "
                                     "milliseconds, --map t_s=time/1000",
                                     file_, origin_[c]));
  std::string label = fmt::format("{} ({})", base, kc.unit_label);
  if (scale != 1.0) label += fmt::format(", logged in {}", unit);
  if (std::string(kc.target) == "force_g") standThrustSign(c, scale);
  out_.names[c] = kc.target;
  out_.labels[kc.target] = label;
}

// Sign as logged: a stand mounted the other way logs thrust negative. Judged by the
// larger-magnitude end; said, and said how to do it by hand.
void StreamParser::standThrustSign(std::size_t c, double scale) {
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

void StreamParser::userMaps() {
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
int StreamParser::mapSource(const ColumnMap& m) const {
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

std::vector<double> StreamParser::mappedValues(const ColumnMap& m, int src) const {
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

void StreamParser::applyMap(Mapped& mp, std::vector<std::string>& drop) {
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

void StreamParser::dropRenamed(const std::string& name) {
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
void StreamParser::notFiniteCells() {
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
void StreamParser::dropRowsWithoutDriveOrForce() {
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
void StreamParser::labelRuns() {
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

}  // namespace lab::csv
