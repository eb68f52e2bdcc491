// The Mega2560's header pins as the simulator's options name them ("D49", "A8", or the port bit
// "PL0"; hal/mega_pins.hpp has the map), and pins driven from outside the chip (a receiver's
// output, a slave on the bus).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

struct avr_t;
struct avr_irq_t;
struct avr_ioport_t;

namespace sim {

struct BoardPin {
  char port = 'B';   // AVR port 'A'..'L'
  uint8_t bit = 0;   // 0..7
  int arduino = 0;   // header pin D0..D69 (A0..A15 are D54..D69)
  // "D49 (PL0)", "A8 (PK0)".
  std::string label() const;
};

// "D49", "49", "A8" or "PL0" (a port bit that is on the header). Throws std::invalid_argument
// naming `option` (e.g. "--rc"), what was wrong and what pins exist.
BoardPin parseBoardPin(const std::string& text, const std::string& option);
// A comma-separated list of pins; a pin named twice is an error.
std::vector<BoardPin> parseBoardPins(const std::string& list, const std::string& option);

// simavr's state of a port (avr_ioport.h). Throws std::invalid_argument if the core lacks it.
avr_ioport_t* ioPort(avr_t* avr, char port);
// simavr's IRQ of the pin (its level; raising it drives an input).
avr_irq_t* pinIrq(avr_t* avr, char port, uint8_t bit);

// Pins of `port` in `mask` are held from outside the chip at the levels in `value` (a receiver's
// output, a pull-up on the bus); the other pins of the port keep what they had. simavr 1.6 then
// shows these levels on an input pin whenever the firmware writes PORT or DDR, where it would
// otherwise show the internal pull-up (a 1) over a line that is driven low. The caller raises
// the pin's IRQ for the level to reach PINx (pinIrq).
void setExternalLevels(avr_t* avr, char port, uint8_t mask, uint8_t value);
// The pins in `mask` are no longer held from outside.
void clearExternalLevels(avr_t* avr, char port, uint8_t mask);
// After a reset cleared PINx with the other I/O registers: puts the levels of the driven pins in
// `mask` back (their IRQs still hold the levels, so raising them again would change nothing).
void restoreInputLevels(avr_t* avr, char port, uint8_t mask, uint8_t value);

}  // namespace sim
