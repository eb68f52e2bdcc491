// `--fault KIND[:ARG...]@T`: see sim/airframe.hpp.
#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include "sim/airframe.hpp"

namespace sim {

const char* const kAirFaultSyntax =
    "KIND[:ARG...]@T, T in simulated seconds:\n"
    "  imu-nack@T         the IMU stops answering (NACK to its address)\n"
    "  imu-freeze@T       the IMU's data registers stop updating\n"
    "  sda-low[:N]@T      a slave holds SDA low (N: it lets go after N SCL clocks made as GPIO)\n"
    "  motor-dead:M@T     motor / ESC M dies (no drive; the rotor coasts down)\n"
    "  prop-loss:M:S@T    propeller M loses the share S (0..1) of its thrust";

namespace {

[[noreturn]] void bad(const std::string& spec, const std::string& what) {
  throw std::invalid_argument(fmt::format("--fault {}: {}; write {}", spec, what, kAirFaultSyntax));
}

double number(const std::string& spec, const std::string& text, const char* what) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v))
    bad(spec, fmt::format("{} '{}' is not a number", what, text));
  return v;
}

int index(const std::string& spec, const std::string& text, const char* what) {
  const double v = number(spec, text, what);
  if (v < 0 || v != static_cast<int>(v)) bad(spec, fmt::format("{} '{}' is not a whole number >= 0", what, text));
  return static_cast<int>(v);
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> parts;
  std::size_t from = 0;
  for (std::size_t at; (at = s.find(sep, from)) != std::string::npos; from = at + 1)
    parts.push_back(s.substr(from, at - from));
  parts.push_back(s.substr(from));
  return parts;
}

}  // namespace

AirFault parseAirFault(const std::string& spec) {
  const std::size_t at = spec.rfind('@');
  if (at == std::string::npos) bad(spec, "no time: add @T (e.g. imu-nack@2.0)");
  AirFault f;
  f.spec = spec;
  f.at_s = number(spec, spec.substr(at + 1), "the time");
  if (f.at_s < 0) bad(spec, "the time is negative");
  const std::vector<std::string> p = split(spec.substr(0, at), ':');
  const std::string& kind = p[0];
  auto args = [&](std::size_t lo, std::size_t hi, const std::string& form) {
    if (p.size() - 1 < lo || p.size() - 1 > hi) bad(spec, fmt::format("{} takes the form {}", kind, form));
  };
  if (kind == "imu-nack" || kind == "imu-freeze") {
    args(0, 0, kind + "@T");
    f.kind = kind == "imu-nack" ? AirFault::Kind::kImuNack : AirFault::Kind::kImuFreeze;
  } else if (kind == "sda-low") {
    args(0, 1, "sda-low@T or sda-low:N@T");
    f.kind = AirFault::Kind::kSdaLow;
    if (p.size() == 2) f.release_clocks = index(spec, p[1], "the clock count N");
  } else if (kind == "motor-dead") {
    args(1, 1, "motor-dead:M@T");
    f.kind = AirFault::Kind::kMotorDead;
    f.motor = index(spec, p[1], "the motor M");
  } else if (kind == "prop-loss") {
    args(2, 2, "prop-loss:M:S@T");
    f.kind = AirFault::Kind::kPropLoss;
    f.motor = index(spec, p[1], "the motor M");
    f.share = number(spec, p[2], "the share S");
    if (f.share < 0 || f.share > 1) bad(spec, fmt::format("the share {} is not within 0..1", p[2]));
  } else {
    bad(spec, fmt::format("'{}' is not a fault kind", kind));
  }
  return f;
}

}  // namespace sim
