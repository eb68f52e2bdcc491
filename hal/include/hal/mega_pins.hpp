// The Arduino Mega2560's header pins as data: digital pin n (D0..D69; A0..A15 are D54..D69) is
// bit kMegaPinBits[n] of AVR port kMegaPinPorts[n]. The same map as the Arduino core's
// variants/mega/pins_arduino.h (digital_pin_to_port_PGM, digital_pin_to_bit_mask_PGM), written
// down here once so the simulator's pin options (--rc, --esc-pins) and their docs agree with
// the silkscreen. Pure data: the firmware images do not need it, the host tools read it.
#pragma once
#include <stdint.h>

#include "hal/board.hpp"

namespace hal {

constexpr uint8_t kMegaDigitalPins = 70;     // D0..D69
constexpr uint8_t kMegaFirstAnalogPin = 54;  // A0 = D54 ... A15 = D69
// Port letter of D0, D1, ... D69.
constexpr char kMegaPinPorts[] =
    "EEEEGEHHHHBBBBJJHHDDDDAAAAAAAACCCCCCCCDGGGLLLLLLLLBBBBFFFFFFFFKKKKKKKK";
// Bit in that port of D0, D1, ... D69.
constexpr uint8_t kMegaPinBits[] = {
    0, 1, 4, 5, 5, 3, 3, 4, 5, 6,  // D0..D9
    4, 5, 6, 7, 1, 0, 1, 0, 3, 2,  // D10..D19
    1, 0, 0, 1, 2, 3, 4, 5, 6, 7,  // D20..D29
    7, 6, 5, 4, 3, 2, 1, 0, 7, 2,  // D30..D39
    1, 0, 7, 6, 5, 4, 3, 2, 1, 0,  // D40..D49
    3, 2, 1, 0, 0, 1, 2, 3, 4, 5,  // D50..D59 (D54 = A0)
    6, 7, 0, 1, 2, 3, 4, 5, 6, 7,  // D60..D69 (D62 = A8)
};
static_assert(sizeof kMegaPinPorts == kMegaDigitalPins + 1, "one port letter per header pin");
static_assert(sizeof kMegaPinBits == kMegaDigitalPins, "one bit per header pin");

namespace board {
// No two header pins share a port bit.
constexpr bool megaPinsUnique() {
  for (uint8_t i = 0; i < kMegaDigitalPins; ++i)
    for (uint8_t j = static_cast<uint8_t>(i + 1); j < kMegaDigitalPins; ++j)
      if (kMegaPinPorts[i] == kMegaPinPorts[j] && kMegaPinBits[i] == kMegaPinBits[j]) return false;
  return true;
}
static_assert(megaPinsUnique(), "the header pin map names a port bit twice");
// The ESC table (board.hpp) names each output by its header pin and its port bit: they agree.
constexpr bool escPinsOnTheHeader() {
  for (uint8_t i = 0; i < kEscChannels; ++i) {
    const uint8_t d = kEscPins[i].arduino_pin;
    if (d >= kMegaDigitalPins || kMegaPinPorts[d] != kEscPins[i].port || kMegaPinBits[d] != kEscPins[i].bit)
      return false;
  }
  return true;
}
static_assert(escPinsOnTheHeader(), "an ESC pin's Arduino number and its port bit disagree");
}  // namespace board

}  // namespace hal
