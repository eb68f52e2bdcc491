// Mega 2560 pin names: see sim/pin_names.hpp.
#include "sim/pin_names.hpp"

#include <fmt/format.h>

#include <cctype>
#include <stdexcept>

namespace sim {
namespace {

constexpr const char* kPinSyntax =
    "D0..D69, A0..A15 (= D54..D69) or a port pin PA0..PL7 (no port I)";

bool allDigits(const std::string& s) {
  if (s.empty() || s.size() > 3) return false;
  for (char c : s)
    if (!std::isdigit(static_cast<unsigned char>(c))) return false;
  return true;
}

}  // namespace

hal::MegaPin parseMegaPin(const std::string& name) {
  std::string n;
  for (char c : name) n += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  const auto bad = [&]() {
    return std::invalid_argument(fmt::format("pin '{}' is not a Mega 2560 pin: write {}", name, kPinSyntax));
  };
  if (n.size() >= 2 && (n[0] == 'D' || n[0] == 'A') && allDigits(n.substr(1))) {
    const int number = std::stoi(n.substr(1));
    const int d = n[0] == 'D' ? number : hal::kMegaFirstAnalogPin + number;
    const int last = n[0] == 'D' ? hal::kMegaPinCount - 1 : hal::kMegaPinCount - 1 - hal::kMegaFirstAnalogPin;
    if (number > last) throw bad();
    return hal::kMegaPins[d];
  }
  if (n.size() == 3 && n[0] == 'P' && n[1] >= 'A' && n[1] <= 'L' && n[1] != 'I' && n[2] >= '0' && n[2] <= '7') {
    const auto bit = static_cast<uint8_t>(n[2] - '0');
    return hal::MegaPin{hal::megaPinOf(n[1], bit), n[1], bit};
  }
  throw bad();
}

std::string megaPinName(const hal::MegaPin& pin) {
  const std::string port = fmt::format("P{}{}", pin.port, pin.bit);
  if (pin.arduino == hal::kNotOnHeader) return port;
  return fmt::format("D{} ({})", pin.arduino, port);
}

std::array<hal::MegaPin, hal::kEscChannels> parseEscPins(const std::string& list) {
  std::array<hal::MegaPin, hal::kEscChannels> pins{};
  const auto wrong_count = [&]() {
    return std::invalid_argument(fmt::format("--esc-pins {}: name {} pins, ESC 0..{} (the rig's motors), e.g. "
                                             "--esc-pins D3,D5,D6,D2",
                                             list, pins.size(), pins.size() - 1));
  };
  std::size_t count = 0, start = 0;
  for (;;) {
    const std::size_t comma = list.find(',', start);
    const std::string item = list.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    if (count == pins.size()) throw wrong_count();
    pins[count] = parseMegaPin(item);
    for (std::size_t i = 0; i < count; ++i)
      if (pins[i].port == pins[count].port && pins[i].bit == pins[count].bit)
        throw std::invalid_argument(fmt::format("--esc-pins {}: {} is named twice (ESC {} and ESC {}); each "
                                                "motor needs its own pin",
                                                list, megaPinName(pins[count]), i, count));
    ++count;
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (count != pins.size()) throw wrong_count();
  return pins;
}

std::array<hal::MegaPin, hal::kEscChannels> boardEscPins() {
  std::array<hal::MegaPin, hal::kEscChannels> pins{};
  for (int i = 0; i < hal::kEscChannels; ++i)
    pins[i] = hal::MegaPin{hal::kEscPins[i].arduino_pin, hal::kEscPins[i].port, hal::kEscPins[i].bit};
  return pins;
}

}  // namespace sim
