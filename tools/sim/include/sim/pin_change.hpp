// The ATmega2560's pin-change interrupts (datasheet ch. 15.2), which Debian's simavr 1.6 has only
// in part: its atmega2560 core wires PCINT0..7 (port B) and nothing of PCINT8..23, so a receiver
// on A8..A15 (PK0..7, PCINT16..23) never interrupts, and it treats PCIFR as plain memory (a 1
// written to clear a flag sets it). The board has all three groups here, in place of simavr's:
//
//   group 0  PCINT0..7   PB0..7           PCMSK0  PCIE0/PCIF0  PCINT0_vect (9)
//   group 1  PCINT8      PE0 (RXD0)       PCMSK1  PCIE1/PCIF1  PCINT1_vect (10)
//            PCINT9..15  PJ0..6
//   group 2  PCINT16..23 PK0..7 (A8..A15) PCMSK2  PCIE2/PCIF2  PCINT2_vect (11)
//
// As the chip: any change of a pin's level (driven from outside, or its own output) whose PCMSKn
// bit is set sets PCIFn; PCIFn set while PCIEn is set (or PCIEn set while PCIFn is) requests
// the interrupt; running the vector clears PCIFn, and so does writing a 1 to it. Not modelled:
// the input synchroniser's 2-3 cycles of delay (a change is seen in the cycle it happens).
#pragma once
#include <array>
#include <cstdint>
#include <memory>

struct avr_t;
struct avr_irq_t;
struct avr_int_vector_t;

namespace sim {

class PinChange {
 public:
  // Takes the pin-change registers and vectors over from simavr (the board must be an
  // atmega2560; throws std::runtime_error otherwise). Lives as long as the core (Board owns it).
  explicit PinChange(avr_t* avr);
  ~PinChange();
  PinChange(const PinChange&) = delete;
  PinChange& operator=(const PinChange&) = delete;

  // Pin changes that set PCIFn for `group` (0..2) since construction (host side, tests).
  uint64_t requests(int group) const { return requests_.at(static_cast<std::size_t>(group)); }

 private:
  struct PinParam {
    PinChange* self;
    uint8_t group;
    uint8_t mask_bit;  // the pin's bit in PCMSKn
  };
  static void onPin(avr_irq_t* irq, uint32_t value, void* param);
  static void onFlagWrite(avr_t* avr, uint16_t addr, uint8_t value, void* param);
  static void onEnableWrite(avr_t* avr, uint16_t addr, uint8_t value, void* param);
  void change(uint8_t group, uint8_t mask_bit);

  avr_t* avr_;
  std::array<avr_int_vector_t*, 3> vectors_{};     // group 0 is port B's (simavr's), 1 and 2 ours
  std::unique_ptr<avr_int_vector_t[]> own_;        // groups 1 and 2
  std::array<PinParam, 24> pins_{};
  std::array<avr_irq_t*, 24> pin_irqs_{};
  std::array<uint64_t, 3> requests_{};
};

}  // namespace sim
