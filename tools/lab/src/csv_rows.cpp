// The CSV reader, phases 1-2: the header (outside comments, or a commented one before the data)
// and the rows (data lines, repeated headers starting a new segment, console text skipped, a last
// line cut short dropped), each cell into its raw column.
#include <fmt/format.h>

#include "csv_reader.hpp"

namespace lab::csv {

// 1. The header: the first line naming columns (outside comments; failing that, a comment
//    line naming pwm_us before the data, as a log may print "# pwm_us,force_g,...").
void StreamParser::readHeader() {
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
void StreamParser::headerColumns() {
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
void StreamParser::readRows() {
  if (have_pending_data_) handleLine(pending_, pending_terminated_, pending_line_);
  while (reader_.next(line_, terminated_)) handleLine(line_, terminated_, ++line_no_);
  if (segment_of_row_.empty())
    throw InputError(file_, header_line_, 1, "expected data rows after the header, found none");
}

void StreamParser::handleLine(const std::string& l, bool term, std::size_t no) {
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
void StreamParser::cell(RawColumn& rc, const Field& field, std::size_t no) {
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

Dataset parseStream(std::istream& in, const std::string& file, const ReadOptions& options) {
  return StreamParser(in, file, options).parse();
}

}  // namespace lab::csv
