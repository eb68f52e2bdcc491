// The ATmega2560's I/O ports as the chip drives its pins (datasheet, "I/O-Ports"): PORTx, DDRx,
// PINx (reads the pins; a one written toggles the PORTx bit), pull-ups, and the alternate
// function that matters here: a timer's compare output OCnx drives its pin instead of PORTx
// while the COM bits connect it, and still only where the DDR bit makes the pin an output.
// PB7 carries OC0A and OC1C: with both connected the output compare modulator combines them,
// AND while PORTB7 is 0, OR while it is 1.
//
// In place of simavr 1.6's port handlers (taken over through the core's io[] table), which
// drive every output pin with its PORTx bit on any PORTx write, an OCnx pin included (a pulse on
// D11 cut short whenever the firmware toggles an LED on D13), and read PINx of an output as
// PORTx. simavr's pin IRQs stay: every part, PCINT and the pulse measurement listen to them.
// At a reset every pin that was an output is released: it falls to 0 unless something
// outside pulls it (AVR_IOCTL_IOPORT_SET_EXTERNAL), as an undriven ESC input does.
#pragma once
#include <array>
#include <cstdint>

struct avr_t;
struct avr_irq_t;
struct avr_ioport_t;

namespace sim {

class Ports {
 public:
  explicit Ports(avr_t* avr);
  ~Ports();
  Ports(const Ports&) = delete;
  Ports& operator=(const Ports&) = delete;

  void afterReset();  // the core zeroed the registers: release what was driven

  // Compare output `source` (0, or 1 for the second one on PB7) drives (port, bit) with `level`
  // while `connected`; `cycle` is when it changed (its timer tick).
  void setOverride(char port, int bit, int source, bool connected, bool level, uint64_t cycle);
  // Something outside the chip drives (port, bit) to `level`, a change that happened at `cycle`
  // (<= now; a part's cycle timer passes its `when`): listeners see that cycle. The level is
  // held as the pin's external level (setExternalLevels), so the firmware's pull-up does not
  // show over a line driven low; releaseInput() lets the pin go.
  void setInput(char port, int bit, bool level, uint64_t cycle);
  void releaseInput(char port, int bit);
  // The cycle of the pin change being delivered right now: for a compare output its timer
  // tick, for setInput its cycle (simavr runs both at the next instruction boundary), else the
  // current cycle.
  uint64_t changeCycle() const;

  // simavr's IRQ of a pin, or null for a port the chip does not have.
  avr_irq_t* pinIrq(char port, int bit) const;
  bool level(char port, int bit) const;  // the pin's level as its IRQ holds it

 private:
  struct Port {
    Ports* owner = nullptr;
    avr_ioport_t* core = nullptr;
    std::array<std::array<bool, 2>, 8> on{}, level{};  // overrides by pin and source
    uint8_t asserted = 0;  // pins this port drives or pulls up (released at a reset)
  };
  static void onPortWrite(avr_t* avr, uint16_t addr, uint8_t v, void* param);
  static void onDdrWrite(avr_t* avr, uint16_t addr, uint8_t v, void* param);
  static void onPinWrite(avr_t* avr, uint16_t addr, uint8_t v, void* param);
  static uint8_t onPinRead(avr_t* avr, uint16_t addr, void* param);
  Port* find(char port);
  const Port* find(char port) const;
  uint8_t driven(const Port& p) const;  // the output value of each pin (OCnx or PORTx)
  void update(Port& p);
  void deliver(uint64_t cycle, Port& p, int bit, int level);  // level -1: update()

  avr_t* avr_;
  std::array<Port, 11> ports_{};  // A..L without I
  uint64_t delivering_cycle_ = 0;
  bool delivering_ = false;
};

// Pins of `port` in `mask` are held from outside the chip at the levels in `value` (a
// receiver's output, a pull-up on the bus); the port's other pins keep what they had. An input
// then shows that level whatever PORTx says (where simavr 1.6 showed the internal pull-up, a 1,
// over a line driven low at every PORTx or DDRx write). The caller raises the pin's IRQ for a
// level to reach PINx now (Ports::setInput does both).
void setExternalLevels(avr_t* avr, char port, uint8_t mask, uint8_t value);
// The pins in `mask` are no longer held from outside.
void clearExternalLevels(avr_t* avr, char port, uint8_t mask);

}  // namespace sim
