// fly's parameters on the host: the table out of fly.hex, parameter files, the docs table, the
// record in an EEPROM image (board/params.hpp).
#include "board/params.hpp"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include <fmt/format.h>

#include "hal/board.hpp"
#include "hex/intel_hex.hpp"
#include "thrustcal/eeprom_image.hpp"
#include "thrustcal/source_tree.hpp"

namespace board {
namespace {

namespace fs = std::filesystem;

uint16_t u16At(const std::vector<uint8_t>& f, std::size_t at) {
  return static_cast<uint16_t>(f[at] | (f[at + 1] << 8));
}
int32_t i32At(const std::vector<uint8_t>& f, std::size_t at) {
  return static_cast<int32_t>(static_cast<uint32_t>(f[at]) | (static_cast<uint32_t>(f[at + 1]) << 8) |
                              (static_cast<uint32_t>(f[at + 2]) << 16) | (static_cast<uint32_t>(f[at + 3]) << 24));
}

// A NUL-terminated text at a flash address (0: none).
const char* flashText(const std::vector<uint8_t>& f, uint16_t at, ParamTableCopy& t, const std::string& what) {
  if (at == 0) return nullptr;
  std::string s;
  for (std::size_t a = at; a < f.size() && f[a] != 0; ++a) {
    if (s.size() > 200 || f[a] < 0x20 || f[a] > 0x7E)
      throw ParamError(fmt::format("{}: the table's {} at flash 0x{:04X} is not text", t.origin, what, at));
    s += static_cast<char>(f[a]);
  }
  t.text.push_back(s);
  return t.text.back().c_str();
}

tc::ParamDef rowAt(const std::vector<uint8_t>& f, std::size_t at, ParamTableCopy& t, uint8_t index) {
  const std::string what = fmt::format("row {}", index);
  tc::ParamDef d{};
  d.name = flashText(f, u16At(f, at + tc::kParamRowAvrName), t, what + "'s name");
  d.unit = flashText(f, u16At(f, at + tc::kParamRowAvrUnit), t, what + "'s unit");
  d.words = flashText(f, u16At(f, at + tc::kParamRowAvrWords), t, what + "'s words");
  d.help = flashText(f, u16At(f, at + tc::kParamRowAvrHelp), t, what + "'s help");
  d.min = i32At(f, at + tc::kParamRowAvrMin);
  d.max = i32At(f, at + tc::kParamRowAvrMax);
  d.def = i32At(f, at + tc::kParamRowAvrDef);
  d.bytes = f[at + tc::kParamRowAvrBytesField];
  d.decimals = f[at + tc::kParamRowAvrDecimals];
  d.flags = f[at + tc::kParamRowAvrFlags];
  d.group = f[at + tc::kParamRowAvrGroup];
  const bool ok = d.name != nullptr && d.unit != nullptr && d.help != nullptr && *d.name != '\0' &&
                  (d.bytes == 1 || d.bytes == 2 || d.bytes == 4) && d.decimals <= 4 && d.min <= d.max &&
                  tc::paramAllowed(d, d.def);
  if (!ok) throw ParamError(fmt::format("{}: {} of the parameter table cannot be right", t.origin, what));
  return d;
}

std::string rangeText(const tc::ParamDef& d) {
  if (d.words != nullptr) return d.words;
  char lo[tc::kParamTextMax], hi[tc::kParamTextMax];
  tc::formatParamValue(d, d.min, lo);
  tc::formatParamValue(d, d.max, hi);
  return fmt::format("{}{}..{}", (d.flags & tc::kParamZeroIsOff) ? "0 (off) or " : "", lo, hi);
}

std::string valueText(const tc::ParamDef& d, int32_t v) {
  char text[tc::kParamTextMax];
  tc::formatParamValue(d, v, text);
  return text;
}

std::string trim(const std::string& s) {
  const auto a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return "";
  return s.substr(a, s.find_last_not_of(" \t\r") + 1 - a);
}

std::string refusal(const tc::ParamDef& d, tc::ParamParse why, const std::string& text) {
  const std::string unit = d.words == nullptr && *d.unit != '\0' ? std::string(" ") + d.unit : "";
  switch (why) {
    case tc::ParamParse::kNotAWord: return fmt::format("{} is one of {}, got \"{}\"", d.name, d.words, text);
    case tc::ParamParse::kNotANumber:
      return d.decimals == 0 ? fmt::format("{} takes a whole number {}{}, got \"{}\"", d.name, rangeText(d), unit, text)
                             : fmt::format("{} takes a number with at most {} decimals, {}{}, got \"{}\"", d.name,
                                           d.decimals, rangeText(d), unit, text);
    default: return fmt::format("{} must be {}{}, got \"{}\"", d.name, rangeText(d), unit, text);
  }
}

}  // namespace

std::vector<int32_t> ParamTableCopy::defaults() const {
  std::vector<int32_t> v(rows.size());
  tc::defaultParams(data(), count(), v.data());
  return v;
}

ParamTableCopy paramTableFromFlash(const std::vector<uint8_t>& f, const std::string& origin) {
  ParamTableCopy t;
  t.origin = origin;
  const std::string magic(tc::kParamMagic, tc::kParamMagicBytes);
  std::vector<std::size_t> hits;
  for (auto it = f.begin(); (it = std::search(it, f.end(), magic.begin(), magic.end())) != f.end(); ++it)
    hits.push_back(static_cast<std::size_t>(it - f.begin()));
  if (hits.empty())
    throw ParamError(fmt::format("{}: holds no parameter table: it is not fly, or a fly from before the "
                                 "saved parameters; pass fly's image (--image build/avr/firmware/fly/fly.hex)",
                                 origin));
  if (hits.size() > 1)
    throw ParamError(fmt::format("{}: holds {} parameter tables; it cannot be a fly image", origin, hits.size()));
  const std::size_t h = hits[0];
  if (h + tc::kParamTableAvrBytes > f.size()) throw ParamError(origin + ": the parameter table is cut short");
  t.layout = f[h + tc::kParamTableAvrLayout];
  const uint8_t rows = f[h + tc::kParamTableAvrRows];
  const uint16_t at = u16At(f, h + tc::kParamTableAvrRow);
  if (f[h + tc::kParamTableAvrRowBytes] != tc::kParamRowAvrBytes || rows == 0 || rows > tc::kParamRowsMax ||
      at + static_cast<std::size_t>(rows) * tc::kParamRowAvrBytes > f.size())
    throw ParamError(fmt::format("{}: its parameter table's header cannot be right (rows {}, row bytes {})", origin,
                                 rows, f[h + tc::kParamTableAvrRowBytes]));
  for (uint8_t i = 0; i < rows; ++i) t.rows.push_back(rowAt(f, at + i * tc::kParamRowAvrBytes, t, i));
  if (tc::paramPayloadBytes(t.data(), t.count()) > tc::kParamPayloadMax)
    throw ParamError(origin + ": its parameters do not fit the EEPROM record");
  t.origin = fmt::format("{} (layout {}, {} parameters)", origin, t.layout, t.rows.size());
  return t;
}

ParamTableCopy readParamTable(const std::string& hex_path) {
  if (!fs::exists(hex_path))
    throw ParamError(fmt::format("{}: no such image; build fly (cmake --preset avr && cmake --build --preset "
                                 "avr) or pass its .hex with --image",
                                 hex_path));
  return paramTableFromFlash(hex::readIntelHexFile(hex_path, hal::kFlashBytes), hex_path);
}

ParamTableCopy copyParamTable(const tc::ParamDef* rows, uint8_t count, uint8_t layout, const std::string& origin) {
  ParamTableCopy t;
  t.layout = layout;
  t.origin = origin;
  auto keep = [&](const char* s) -> const char* {
    if (s == nullptr) return nullptr;
    t.text.emplace_back(s);
    return t.text.back().c_str();
  };
  for (uint8_t i = 0; i < count; ++i) {
    tc::ParamDef d = rows[i];
    d.name = keep(d.name);
    d.unit = keep(d.unit);
    d.words = keep(d.words);
    d.help = keep(d.help);
    t.rows.push_back(d);
  }
  return t;
}

std::string defaultFlyHex() {
  const std::vector<fs::path> dirs = thrustcal::avrBuildDirs();
  for (const auto& d : dirs)
    if (fs::exists(d / "firmware" / "fly" / "fly.hex")) return (d / "firmware" / "fly" / "fly.hex").string();
  return (dirs.back() / "firmware" / "fly" / "fly.hex").string();
}

std::string paramLine(const tc::ParamDef& d, int32_t value) {
  const std::string unit = *d.unit != '\0' ? std::string(d.unit) + ", " : "";
  return fmt::format("{} {}  # {}{}", d.name, valueText(d, value), unit, rangeText(d));
}

std::string formatParamFile(const ParamTableCopy& t, const std::vector<int32_t>& values,
                            const std::vector<std::string>& comment) {
  std::string out;
  for (const auto& c : comment) out += "# " + c + "\n";
  for (uint8_t i = 0; i < t.count(); ++i) out += paramLine(t.rows[i], values[i]) + "\n";
  return out;
}

std::size_t ParamFile::givenCount() const { return static_cast<std::size_t>(std::count(given.begin(), given.end(), true)); }

// long: one pass over the lines collecting every error, then the rules across rows
ParamFile parseParamFile(const ParamTableCopy& t, const std::string& text, const std::string& origin,
                         const std::vector<int32_t>& base) {
  ParamFile f;
  f.values = base;
  f.given.assign(t.rows.size(), false);
  std::vector<int> line_of(t.rows.size(), 0);
  std::vector<std::string> errors;
  std::istringstream in(text);
  int n = 0;
  for (std::string raw; std::getline(in, raw);) {
    ++n;
    const std::string line = trim(raw.substr(0, raw.find('#')));
    if (line.empty()) continue;
    std::istringstream words(line);
    std::string name, value, extra;
    words >> name >> value >> extra;
    if (value.empty() || !extra.empty()) {
      errors.push_back(fmt::format("{}:{}: expected NAME VALUE, got \"{}\"", origin, n, line));
      continue;
    }
    const int8_t i = tc::findParam(t.data(), t.count(), name.c_str());
    if (i < 0) {
      errors.push_back(fmt::format("{}:{}: no parameter \"{}\" in {}", origin, n, name, t.origin));
      continue;
    }
    if (f.given[i]) {
      errors.push_back(fmt::format("{}:{}: {} given again (first on line {})", origin, n, name, line_of[i]));
      continue;
    }
    int32_t v = 0;
    const tc::ParamParse why = tc::parseParamValue(t.rows[i], value.c_str(), v);
    if (why != tc::ParamParse::kOk) {
      errors.push_back(fmt::format("{}:{}: {}", origin, n, refusal(t.rows[i], why, value)));
      continue;
    }
    f.values[i] = v;
    f.given[i] = true;
    line_of[i] = n;
  }
  if (errors.empty()) {
    const tc::ParamCheck c = tc::checkParams(t.data(), t.count(), f.values.data());
    if (c.fault == tc::ParamFault::kNotBelowNext) {
      const tc::ParamDef& lo = t.rows[c.row];
      const tc::ParamDef& hi = t.rows[c.row + 1];
      const int at = line_of[c.row + 1] != 0 ? line_of[c.row + 1] : line_of[c.row];
      errors.push_back(fmt::format("{}:{}: {} {} must be below {} {} unless that is 0{}", origin, at, lo.name,
                                   valueText(lo, f.values[c.row]), hi.name, valueText(hi, f.values[c.row + 1]),
                                   at == 0 ? " (both from the board)" : ""));
    } else if (!c.ok()) {
      errors.push_back(fmt::format("{}: {} {} cannot be flown", origin, t.rows[c.row].name, f.values[c.row]));
    }
  }
  if (!errors.empty()) {
    std::string all;
    for (const auto& e : errors) all += e + "\n";
    throw ParamError(all + fmt::format("{} error{}; nothing written", errors.size(), errors.size() == 1 ? "" : "s"));
  }
  return f;
}

std::string paramDocsTable(const ParamTableCopy& t) {
  const auto cell = [](std::string text) {  // a '|' in a cell would end it
    for (std::size_t at = 0; (at = text.find('|', at)) != std::string::npos; at += 2) text.insert(at, "\\");
    return text;
  };
  std::string out = "| name | range | unit | default | what it does |\n|---|---|---|---|---|\n";
  for (const tc::ParamDef& d : t.rows)
    out += fmt::format("| `{}` | {} | {} | {} | {} |\n", d.name, cell(rangeText(d)), d.unit, valueText(d, d.def),
                       cell(d.help));
  return out;
}

std::string withParamDocsTable(const std::string& doc, const std::string& table, const std::string& path) {
  const std::size_t a = doc.find(kParamDocsBegin);
  const std::size_t b = doc.find(kParamDocsEnd);
  if (a == std::string::npos || b == std::string::npos || b < a)
    throw ParamError(fmt::format("{}: no \"{}\" ... \"{}\" markers to put the table between; add them where it "
                                 "belongs",
                                 path, kParamDocsBegin, kParamDocsEnd));
  const std::size_t from = a + std::string(kParamDocsBegin).size();
  return doc.substr(0, from) + "\n" + table + doc.substr(b);
}

BoardParamState paramsInImage(const ParamTableCopy& t, const std::vector<uint8_t>& eeprom) {
  BoardParamState s;
  s.values = t.defaults();
  {
    const tc::EepromImage::Use use(eeprom);
    s.where = tc::readParams<tc::EepromImage>(s.record);
  }
  using How = BoardParamState::How;
  if (s.where.status != tc::DecodeStatus::kOk) {
    s.how = s.where.hosts == 0 ? How::kNoRoom : How::kNone;
    s.why = s.how == How::kNoRoom ? "none, and no room to save any: all four slots hold thesis (v1) records"
                                  : "none saved: the defaults";
    return s;
  }
  if (s.record.layout != t.layout) {
    s.how = How::kOtherLayout;
    s.why = fmt::format("saved by a fly with parameter layout {} ({} has {})", s.record.layout, t.origin, t.layout);
    return s;
  }
  std::vector<int32_t> v(t.rows.size());
  const tc::ParamCheck c = tc::decodeParams(t.data(), t.count(), s.record.payload, s.record.length, v.data());
  if (!c.ok()) {
    s.how = How::kCannotBeRight;
    s.why = c.fault == tc::ParamFault::kBadLength
                ? "the saved copy cannot be right (its size is not this layout's)"
                : fmt::format("the saved copy cannot be right ({} {})", t.rows[c.row].name, v[c.row]);
    return s;
  }
  s.how = How::kLoaded;
  s.values = v;
  s.why = fmt::format("motor {}'s slot, copy {}, sequence {}", s.where.host, s.where.copy == 0 ? 'A' : 'B',
                      s.where.sequence);
  return s;
}

tc::ParamsWrite storeParamsInImage(const ParamTableCopy& t, const std::vector<int32_t>& values,
                                   std::vector<uint8_t>& eeprom) {
  tc::ParamsRecord rec;
  rec.layout = t.layout;
  rec.length = tc::paramPayloadBytes(t.data(), t.count());
  tc::encodeParams(t.data(), t.count(), values.data(), rec.payload);
  std::vector<uint8_t> copy = eeprom;  // the image changes only when the whole write succeeded
  const tc::EepromImage::Use use(copy);
  const tc::ParamsWrite w = tc::writeParams<tc::EepromImage>(rec);
  if (w.status == tc::ParamsWriteStatus::kWritten) eeprom = copy;
  return w;
}

}  // namespace board
