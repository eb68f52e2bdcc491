// The Mega2560's header pins: see sim/pins.hpp.
#include "sim/pins.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <stdexcept>

#include "hal/mega_pins.hpp"

extern "C" {
#include <simavr/avr_ioport.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_io.h>
}

namespace sim {
namespace {

constexpr const char* kPinSyntax =
    "write a header pin as D0..D69, A0..A15 or its port bit (e.g. D49, A8, PK0)";

bool allDigits(const std::string& s) {
  if (s.empty() || s.size() > 3) return false;
  for (char c : s)
    if (!std::isdigit(static_cast<unsigned char>(c))) return false;
  return true;
}

BoardPin fromArduino(int d) {
  BoardPin p;
  p.arduino = d;
  p.port = hal::kMegaPinPorts[d];
  p.bit = hal::kMegaPinBits[d];
  return p;
}

}  // namespace

std::string BoardPin::label() const {
  const std::string header = arduino >= hal::kMegaFirstAnalogPin
                                 ? fmt::format("A{}", arduino - hal::kMegaFirstAnalogPin)
                                 : fmt::format("D{}", arduino);
  return fmt::format("{} (P{}{})", header, port, bit);
}

BoardPin parseBoardPin(const std::string& text, const std::string& option) {
  std::string t;
  for (char c : text)
    if (!std::isspace(static_cast<unsigned char>(c))) t += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (t.size() >= 2 && t[0] == 'D' && allDigits(t.substr(1))) {
    const int d = std::stoi(t.substr(1));
    if (d < hal::kMegaDigitalPins) return fromArduino(d);
    throw std::invalid_argument(fmt::format("{} {}: the Mega2560 has D0..D{}; {}", option, text,
                                            hal::kMegaDigitalPins - 1, kPinSyntax));
  }
  if (allDigits(t) && std::stoi(t) < hal::kMegaDigitalPins) return fromArduino(std::stoi(t));
  if (t.size() >= 2 && t[0] == 'A' && allDigits(t.substr(1))) {
    const int a = std::stoi(t.substr(1));
    if (a < hal::kMegaDigitalPins - hal::kMegaFirstAnalogPin) return fromArduino(hal::kMegaFirstAnalogPin + a);
    throw std::invalid_argument(fmt::format("{} {}: the Mega2560 has A0..A{}; {}", option, text,
                                            hal::kMegaDigitalPins - hal::kMegaFirstAnalogPin - 1, kPinSyntax));
  }
  if (t.size() == 3 && t[0] == 'P' && t[1] >= 'A' && t[1] <= 'L' && t[2] >= '0' && t[2] <= '7') {
    for (int d = 0; d < hal::kMegaDigitalPins; ++d)
      if (hal::kMegaPinPorts[d] == t[1] && hal::kMegaPinBits[d] == t[2] - '0') return fromArduino(d);
    throw std::invalid_argument(fmt::format("{} {}: that port bit is not on the Mega2560's header; {}",
                                            option, text, kPinSyntax));
  }
  throw std::invalid_argument(fmt::format("{} {}: not a pin name; {}", option, text, kPinSyntax));
}

std::vector<BoardPin> parseBoardPins(const std::string& list, const std::string& option) {
  std::vector<BoardPin> pins;
  std::size_t start = 0;
  while (start <= list.size()) {
    const std::size_t comma = std::min(list.find(',', start), list.size());
    const BoardPin pin = parseBoardPin(list.substr(start, comma - start), option);
    for (const BoardPin& p : pins)
      if (p.arduino == pin.arduino)
        throw std::invalid_argument(fmt::format("{} {}: {} is named twice; each pin carries one signal",
                                                option, list, pin.label()));
    pins.push_back(pin);
    start = comma + 1;
  }
  return pins;
}

avr_ioport_t* ioPort(avr_t* avr, char port) {
  for (avr_io_t* io = avr->io_port; io; io = io->next)
    if (io->kind && std::strcmp(io->kind, "port") == 0 && reinterpret_cast<avr_ioport_t*>(io)->name == port)
      return reinterpret_cast<avr_ioport_t*>(io);
  throw std::invalid_argument(fmt::format("this simavr core has no port {}; the board must be an atmega2560", port));
}

avr_irq_t* pinIrq(avr_t* avr, char port, uint8_t bit) {
  return avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(port), bit);
}

void setExternalLevels(avr_t* avr, char port, uint8_t mask, uint8_t value) {
  avr_ioport_t* p = ioPort(avr, port);
  p->external.pull_mask = static_cast<uint8_t>(p->external.pull_mask | mask);
  p->external.pull_value = static_cast<uint8_t>((p->external.pull_value & ~mask) | (value & mask));
}

void clearExternalLevels(avr_t* avr, char port, uint8_t mask) {
  avr_ioport_t* p = ioPort(avr, port);
  p->external.pull_mask = static_cast<uint8_t>(p->external.pull_mask & ~mask);
  p->external.pull_value = static_cast<uint8_t>(p->external.pull_value & ~mask);
}

void restoreInputLevels(avr_t* avr, char port, uint8_t mask, uint8_t value) {
  uint8_t& pin = avr->data[ioPort(avr, port)->r_pin];
  pin = static_cast<uint8_t>((pin & ~mask) | (value & mask));
}

}  // namespace sim
