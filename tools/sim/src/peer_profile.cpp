// A peer's profile for the swap experiment: see sim/peer_profile.hpp.
#include "sim/peer_profile.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

#include "sim/air_cli.hpp"
#include "sim/pin_names.hpp"

namespace sim {

namespace {

namespace fs = std::filesystem;

const std::vector<std::string>& stickNames() {
  static const std::vector<std::string> names = {"throttle", "roll", "pitch", "yaw",
                                                 "aux1",     "aux2", "aux3",  "aux4"};
  return names;
}

std::string trim(const std::string& s) {
  const std::size_t a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return "";
  return s.substr(a, s.find_last_not_of(" \t\r") - a + 1);
}

std::vector<std::string> splitComma(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');) out.push_back(trim(item));
  return out;
}

double number(const std::string& text, const std::string& what) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size()) throw std::invalid_argument(fmt::format("{} '{}' is not a number", what, text));
  return v;
}

// "throttle=1000,yaw=2000": stick -> us, each a known stick within 500..2500 us.
std::map<std::string, double> sticks(const std::string& text) {
  std::map<std::string, double> out;
  for (const std::string& item : splitComma(text)) {
    const std::size_t eq = item.find('=');
    const std::string name = trim(item.substr(0, eq));
    if (eq == std::string::npos || std::find(stickNames().begin(), stickNames().end(), name) == stickNames().end())
      throw std::invalid_argument(fmt::format("'{}' is not STICK=US (sticks: throttle, roll, pitch, yaw, aux1..aux4), "
                                              "e.g. throttle=1000,yaw=2000", item));
    const double us = number(trim(item.substr(eq + 1)), name);
    if (us < kRcChannelMinUs || us > kRcChannelMaxUs)
      throw std::invalid_argument(fmt::format("{}={} is outside {:.0f}..{:.0f} us", name, us, kRcChannelMinUs,
                                              kRcChannelMaxUs));
    out[name] = us;
  }
  return out;
}

std::string resolved(const std::string& path, const std::string& file) {
  const fs::path p(path);
  return p.is_absolute() ? p.string() : (fs::path(file).parent_path() / p).lexically_normal().string();
}

// "throttle=2000,yaw=1000 hold 1 wait 1.5"
void takeCalibrate(PeerProfile& p, const std::string& value) {
  const std::size_t hold = value.find(" hold "), wait = value.find(" wait ");
  if (hold == std::string::npos || wait == std::string::npos || wait < hold)
    throw std::invalid_argument("write the calibration sticks, how long they are held and the wait after, e.g. "
                                "calibrate throttle=2000,yaw=1000,pitch=1000 hold 1 wait 1.5");
  p.calibrate = sticks(trim(value.substr(0, hold)));
  p.calibrate_hold_s = number(trim(value.substr(hold + 6, wait - hold - 6)), "hold");
  p.calibrate_wait_s = number(trim(value.substr(wait + 6)), "wait");
  if (p.calibrate_hold_s <= 0 || p.calibrate_hold_s > 10 || p.calibrate_wait_s < 0 || p.calibrate_wait_s > 10)
    throw std::invalid_argument("hold is 0..10 s and wait 0..10 s");
}

// "24 4D 3C 00 FA FA": the bytes.
std::string hexBytes(const std::string& value) {
  std::string out;
  std::istringstream in(value);
  for (std::string byte; in >> byte;) {
    std::size_t used = 0;
    unsigned long v = 0;
    try {
      v = std::stoul(byte, &used, 16);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != byte.size() || byte.size() > 2 || v > 0xFF)
      throw std::invalid_argument(fmt::format("'{}' is not a byte in hex; write e.g. uart-hex 24 4D 3C 00 FA FA", byte));
    out.push_back(static_cast<char>(v));
  }
  return out;
}

// One `KEY VALUE` line into the profile.
void take(PeerProfile& p, const std::string& key, const std::string& value, const std::string& file) {
  if (key == "name") {
    if (value.find_first_of(" ,/:") != std::string::npos)
      throw std::invalid_argument("a name without spaces, commas, slashes or colons, e.g. multiwii24");
    p.name = value;
  } else if (key == "elf") {
    p.elf = resolved(value, file);
  } else if (key == "layout") {
    if (value != "plus" && value != "x") throw std::invalid_argument("layout is plus or x");
    p.layout = value;
  } else if (key == "esc-pins") {
    p.esc_pins = parseEscPins(value);
  } else if (key == "spin") {
    p.spin = parseSpin(value, 4);
  } else if (key == "imu-mount") {
    p.imu_mount = parseImuMount(value);
  } else if (key == "rc") {
    p.rc = parseRcSpec(value, nullptr);
  } else if (key == "channels") {
    p.channels = splitComma(value);
    for (const std::string& c : p.channels)
      if (std::find(stickNames().begin(), stickNames().end(), c) == stickNames().end())
        throw std::invalid_argument(fmt::format("channel '{}' is none of throttle, roll, pitch, yaw, aux1..aux4", c));
  } else if (key == "neutral") {
    p.neutral = sticks(value);
  } else if (key == "arm") {
    const std::size_t hold = value.find(" hold ");
    if (hold == std::string::npos)
      throw std::invalid_argument("write the arming sticks and how long they are held, e.g. "
                                  "arm throttle=1000,yaw=2000 hold 1.5");
    p.arm = sticks(trim(value.substr(0, hold)));
    p.arm_hold_s = number(trim(value.substr(hold + 6)), "hold");
    if (p.arm_hold_s <= 0 || p.arm_hold_s > 10) throw std::invalid_argument("hold is 0..10 s");
  } else if (key == "calibrate") {
    takeCalibrate(p, value);
  } else if (key == "uart-hex") {
    p.uart_bytes = hexBytes(value);
  } else if (key == "armed-text") {
    p.armed_text = value;
  } else if (key == "hover") {
    p.hover = sticks(value);
  } else if (key == "eeprom") {
    p.eeprom = resolved(value, file);
  } else if (key == "boot-s") {
    p.boot_s = number(value, "boot-s");
    if (p.boot_s < 0 || p.boot_s > 30) throw std::invalid_argument("boot-s is 0..30 simulated seconds");
  } else if (key == "deg-us") {
    std::istringstream in(value);
    std::string axis, us;
    in >> axis >> us;
    const double v = number(us, "deg-us");
    if ((axis != "roll" && axis != "pitch") || v == 0 || std::fabs(v) > 100)
      throw std::invalid_argument("write deg-us roll|pitch US, the stick's us per degree (not 0, within +-100), "
                                  "e.g. deg-us roll 5");
    (axis == "roll" ? p.roll_us_per_deg : p.pitch_us_per_deg) = v;
  } else {
    throw std::invalid_argument(fmt::format(
        "unknown key '{}'; the keys: name elf layout esc-pins spin imu-mount rc channels neutral eeprom boot-s "
        "uart-hex calibrate arm armed-text hover deg-us",
        key));
  }
}

void checkComplete(const PeerProfile& p, const std::set<std::string>& seen) {
  for (const char* key : {"name", "elf", "esc-pins", "rc", "channels", "arm", "hover"})
    if (!seen.count(key)) throw std::invalid_argument(fmt::format("{}: no '{}' line", p.file, key));
  if (p.roll_us_per_deg == 0 || p.pitch_us_per_deg == 0)
    throw std::invalid_argument(fmt::format("{}: write deg-us roll US and deg-us pitch US", p.file));
  for (const char* stick : {"throttle", "roll", "pitch"})
    if (std::find(p.channels.begin(), p.channels.end(), stick) == p.channels.end())
      throw std::invalid_argument(fmt::format("{}: channels carries no {}", p.file, stick));
  const std::size_t lines = p.rc.signal == RcSignal::kPpm ? kRcChannels : p.rc.pins.size();
  if (p.channels.size() > lines)
    throw std::invalid_argument(fmt::format("{}: channels names {} but rc {} carries {}", p.file, p.channels.size(),
                                            p.rc.text, lines));
  for (const auto& pin : p.rc.pins)
    for (const auto& esc : p.esc_pins)
      if (pin.port == esc.port && pin.bit == esc.bit)
        throw std::invalid_argument(fmt::format("{}: {} is both a receiver pin and an ESC pin", p.file,
                                                megaPinName(pin)));
  for (const auto* set : {&p.neutral, &p.calibrate, &p.arm, &p.hover})
    for (const auto& [stick, us] : *set)
      if (std::find(p.channels.begin(), p.channels.end(), stick) == p.channels.end())
        throw std::invalid_argument(fmt::format("{}: {} is on no channel (channels {})", p.file, stick,
                                                fmt::join(p.channels, ",")));
}

}  // namespace

std::vector<double> PeerProfile::channelValues(const std::map<std::string, double>& s) const {
  std::vector<double> us;
  for (const std::string& c : channels) {
    const auto given = s.find(c);
    const auto rest = neutral.find(c);
    us.push_back(given != s.end() ? given->second : rest != neutral.end() ? rest->second : 1500.0);
  }
  return us;
}

PeerProfile parsePeerProfile(const std::string& text, const std::string& file) {
  PeerProfile p;
  p.file = file;
  std::set<std::string> seen;
  std::istringstream in(text);
  int number_of_line = 0;
  for (std::string line; std::getline(in, line);) {
    ++number_of_line;
    line = trim(line.substr(0, line.find('#')));
    if (line.empty()) continue;
    const std::size_t space = line.find_first_of(" \t");
    const std::string key = line.substr(0, space);
    const std::string value = space == std::string::npos ? "" : trim(line.substr(space));
    const std::string once = key == "deg-us" ? key + " " + value.substr(0, value.find(' ')) : key;
    try {
      if (value.empty()) throw std::invalid_argument(fmt::format("'{}' has no value", key));
      if (!seen.insert(once).second) throw std::invalid_argument(fmt::format("'{}' is given twice", once));
      seen.insert(key);
      take(p, key, value, file);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(fmt::format("{}:{}: {}", file, number_of_line, e.what()));
    }
  }
  checkComplete(p, seen);
  return p;
}

PeerProfile readPeerProfile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(fmt::format("{}: cannot read the peer profile", path));
  std::stringstream text;
  text << in.rdbuf();
  return parsePeerProfile(text.str(), path);
}

}  // namespace sim
