// `--rc` and `--rc-script`: see sim/rc_input.hpp.
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string_view>

#include "hal/board.hpp"
#include "sim/pin_names.hpp"
#include "sim/rc_input.hpp"

namespace sim {

const char* const kRcSpecSyntax =
    "ppm:PIN (a PPM sum on one pin, e.g. ppm:D49) or pwm:PIN,PIN,... (one pin per channel, 1..8, "
    "e.g. pwm:A8,A9,A10,A11,A12,A13,A14,A15)";

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// What else a pin carries on this board, or "".
std::string pinTaken(const hal::MegaPin& pin, const std::array<hal::MegaPin, hal::kEscChannels>* esc_pins) {
  if (pin.arduino == 0 || pin.arduino == 1) return "UART0 (the console)";
  if (pin.arduino == hal::kTwiPins.sda_arduino_pin || pin.arduino == hal::kTwiPins.scl_arduino_pin)
    return "the TWI (the IMU's bus)";
  for (std::size_t i = 0; esc_pins && i < esc_pins->size(); ++i)
    if ((*esc_pins)[i].port == pin.port && (*esc_pins)[i].bit == pin.bit) return fmt::format("ESC {}", i);
  return "";
}

// "A8,A9,PK2": 1..8 header pins, none named twice.
std::vector<hal::MegaPin> parseRcPins(const std::string& spec, const std::string& list) {
  std::vector<hal::MegaPin> pins;
  std::size_t start = 0;
  while (start <= list.size()) {
    const std::size_t comma = std::min(list.find(',', start), list.size());
    hal::MegaPin pin{};
    try {
      pin = parseMegaPin(std::string(trim(std::string_view(list).substr(start, comma - start))));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(fmt::format("--rc {}: {}", spec, e.what()));
    }
    start = comma + 1;
    if (pin.arduino == hal::kNotOnHeader)
      throw std::invalid_argument(fmt::format("--rc {}: {} is not on the Mega's headers; a receiver is wired to a "
                                              "header pin", spec, megaPinName(pin)));
    for (const hal::MegaPin& p : pins)
      if (p.port == pin.port && p.bit == pin.bit)
        throw std::invalid_argument(fmt::format("--rc {}: {} is named twice; each channel needs its own pin", spec,
                                                megaPinName(pin)));
    pins.push_back(pin);
  }
  return pins;
}

struct Field {
  std::string_view text;  // trimmed
  int column;             // 1-based, where the field starts in the line
};

std::vector<Field> splitFields(std::string_view line) {
  std::vector<Field> out;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= line.size(); ++i)
    if (i == line.size() || line[i] == ',') {
      std::string_view raw = line.substr(start, i - start);
      std::size_t lead = 0;
      while (lead < raw.size() && std::isspace(static_cast<unsigned char>(raw[lead]))) ++lead;
      out.push_back({trim(raw), static_cast<int>(start + lead + 1)});
      start = i + 1;
    }
  return out;
}

bool parseNumber(std::string_view t, double& v) {
  if (t.empty() || t.front() == '+') return false;
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  return r.ec == std::errc() && r.ptr == t.data() + t.size() && std::isfinite(v);
}

class ScriptError {
 public:
  ScriptError(const std::string& name, int line) : name_(name), line_(line) {}
  [[noreturn]] void fail(int column, const std::string& what) const {
    throw std::invalid_argument(fmt::format("{}:{}:{}: {}", name_, line_, column, what));
  }

 private:
  const std::string& name_;
  int line_;
};

// "t_s,ch1,...,chN": N.
int parseHeader(const std::vector<Field>& f, const ScriptError& err) {
  const std::string expected = "write the header t_s,ch1,ch2,...,chN (N 1..8 channels, in that order)";
  if (lower(f[0].text) != "t_s") err.fail(f[0].column, fmt::format("the first column is '{}'; {}", f[0].text, expected));
  if (f.size() < 2 || f.size() > kRcChannels + 1)
    err.fail(1, fmt::format("{} channel columns; {}", f.size() - 1, expected));
  for (std::size_t i = 1; i < f.size(); ++i)
    if (lower(f[i].text) != fmt::format("ch{}", i))
      err.fail(f[i].column, fmt::format("column {} is '{}', expected ch{}; {}", i + 1, f[i].text, i, expected));
  return static_cast<int>(f.size()) - 1;
}

RcScriptRow parseRow(const std::vector<Field>& f, int channels, double last_t, const ScriptError& err) {
  RcScriptRow row;
  if (!parseNumber(f[0].text, row.t_s) || row.t_s < 0)
    err.fail(f[0].column, fmt::format("time '{}' is not a number of simulated seconds >= 0", f[0].text));
  if (row.t_s < last_t)
    err.fail(f[0].column, fmt::format("time {} s is before the previous row's {} s; rows go in time order", row.t_s, last_t));
  if (f.size() == 2 && lower(f[1].text) == "loss") {
    row.loss = true;
    return row;
  }
  if (static_cast<int>(f.size()) != channels + 1)
    err.fail(1, fmt::format("{} values, the header has {} channels; write T,V1,...,V{} or T,loss",
                            f.size() - 1, channels, channels));
  row.count = channels;
  for (int i = 0; i < channels; ++i) {
    const Field& x = f[i + 1];
    double v = 0;
    if (!parseNumber(x.text, v))
      err.fail(x.column, fmt::format("ch{} '{}' is not a number of microseconds (or write T,loss)", i + 1, x.text));
    if (v < kRcChannelMinUs || v > kRcChannelMaxUs)
      err.fail(x.column, fmt::format("ch{} {} us is outside {:.0f}..{:.0f} us", i + 1, x.text, kRcChannelMinUs,
                                     kRcChannelMaxUs));
    row.us[i] = v;
  }
  return row;
}

}  // namespace

RcSpec parseRcSpec(const std::string& spec, const std::array<hal::MegaPin, hal::kEscChannels>* esc_pins) {
  RcSpec r;
  r.text = spec;
  const std::size_t colon = spec.find(':');
  const std::string kind = lower(trim(std::string_view(spec).substr(0, colon)));
  if (colon == std::string::npos || (kind != "ppm" && kind != "pwm"))
    throw std::invalid_argument(fmt::format("--rc {}: write {}", spec, kRcSpecSyntax));
  r.signal = kind == "ppm" ? RcSignal::kPpm : RcSignal::kPwm;
  r.pins = parseRcPins(spec, spec.substr(colon + 1));
  if (r.signal == RcSignal::kPpm && r.pins.size() != 1)
    throw std::invalid_argument(fmt::format("--rc {}: a PPM sum is one pin; write {}", spec, kRcSpecSyntax));
  if (r.pins.size() > static_cast<std::size_t>(kRcChannels))
    throw std::invalid_argument(fmt::format("--rc {}: {} pins, a receiver has at most {} channels", spec,
                                            r.pins.size(), kRcChannels));
  for (const hal::MegaPin& p : r.pins) {
    const std::string taken = pinTaken(p, esc_pins);
    if (!taken.empty())
      throw std::invalid_argument(fmt::format("--rc {}: {} carries {} on this board; choose another pin "
                                              "(A8..A15 are free and have pin-change interrupts)",
                                              spec, megaPinName(p), taken));
  }
  return r;
}

std::vector<RcScriptRow> parseRcScript(const std::string& text, const std::string& name) {
  std::vector<RcScriptRow> rows;
  std::istringstream in(text);
  std::string raw;
  int line_no = 0, channels = 0;
  double last_t = 0;
  while (std::getline(in, raw)) {
    ++line_no;
    const std::string_view line = trim(raw);
    if (line.empty() || line.front() == '#') continue;
    const ScriptError err(name, line_no);
    const std::vector<Field> f = splitFields(line);
    if (channels == 0) {
      channels = parseHeader(f, err);
      continue;
    }
    RcScriptRow row = parseRow(f, channels, last_t, err);
    row.line = line_no;
    last_t = row.t_s;
    rows.push_back(row);
  }
  if (channels == 0)
    throw std::invalid_argument(fmt::format("{}: no header; the first line that is not a '#' comment is "
                                            "t_s,ch1,...,chN", name));
  if (rows.empty())
    throw std::invalid_argument(fmt::format("{}:{}: no rows after the header; add T,V1,...,V{} or T,loss rows",
                                            name, line_no, channels));
  return rows;
}

std::vector<RcScriptRow> readRcScript(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument(fmt::format("--rc-script {}: cannot read it; check the path", path));
  std::ostringstream text;
  text << in.rdbuf();
  return parseRcScript(text.str(), path);
}

}  // namespace sim
